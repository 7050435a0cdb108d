"""The contact budget (``dem/core/budget.py``) on hand-made sequences of contact sets with known terms."""

import math

import numpy as np
import pytest

from dem.core import budget, neighbours, protocol
from dem.core.measure import fabric
from pipeline.spec import resolve

RNG = np.random.default_rng(7)


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_normals(n):
    return unit(RNG.normal(size=(n, 3)))


def near(pairs=(), gaps=(), normals=None):
    """Near pairs (id1, id2) with their gaps, all in the region (their normals along e1 unless given)."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    normals = np.tile([1.0, 0.0, 0.0], (len(pairs), 1)) if normals is None else np.asarray(normals, dtype=float)
    return neighbours.NearPairs(neighbours.pair_keys(pairs[:, 0], pairs[:, 1]), np.asarray(gaps, dtype=float),
                                normals, np.zeros(len(pairs)))


def step(tracker, pairs, normals, touching=(), direction=0.0, forces=None, near_pairs=None):
    """One tracking point: region contacts ``pairs`` (id1, id2) with ``normals``; ``touching`` more pairs that touch
    outside the region; ``near_pairs`` the near pairs (none unless given)."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    every = np.concatenate([pairs, np.asarray(touching, dtype=np.int64).reshape(-1, 2)])
    keys = neighbours.pair_keys(pairs[:, 0], pairs[:, 1])
    forces = np.ones(len(pairs)) if forces is None else np.asarray(forces, dtype=float)
    tracker.step(keys, np.asarray(normals, dtype=float), forces, neighbours.pair_keys(every[:, 0], every[:, 1]),
                 direction, near() if near_pairs is None else near_pairs, (-1.0, 1.0))


def test_a_pair_is_one_key_whatever_its_order():
    assert neighbours.pair_keys(np.array([3, 9]), np.array([9, 3]))[0] == neighbours.pair_keys(np.array([9]),
                                                                                             np.array([3]))[0]
    assert len(set(neighbours.pair_keys(np.array([1, 2, 1]), np.array([2, 3, 3])).tolist())) == 3


def test_the_terms_of_a_hand_made_step_are_the_known_ones():
    """Four contacts along e1, e2, e3, e1: the e3 one is lost, the e2 one turns to e3, one along e2 is made."""
    e1, e2, e3 = np.eye(3)
    tracker = budget.ContactTracker()
    step(tracker, [(1, 2), (1, 3), (2, 3), (3, 4)], [e1, e2, e3, e1])
    step(tracker, [(1, 2), (1, 3), (3, 4), (4, 5)], [e1, e3, e1, e2])
    row = tracker.row()
    third = np.eye(3) / 3
    nn = {i: np.outer(e, e) - third for i, e in enumerate((e1, e2, e3))}
    a0 = (2 * nn[0] + nn[1] + nn[2]) / 4
    a_kept_before, a_kept_after = (2 * nn[0] + nn[1]) / 3, (2 * nn[0] + nn[2]) / 3
    np.testing.assert_allclose(row["budget_lost"], (a0 - nn[2]) / 3, atol=1e-15)
    np.testing.assert_allclose(row["budget_kept"], a_kept_after - a_kept_before, atol=1e-15)
    np.testing.assert_allclose(row["budget_made"], (nn[1] - a_kept_after) / 4, atol=1e-15)
    np.testing.assert_allclose(row["budget_crossed"], 0.0, atol=1e-15)
    assert (row["made_count"], row["lost_count"], row["entered_count"], row["left_count"]) == (1, 1, 0, 0)
    np.testing.assert_allclose(row["made_fabric"], nn[1], atol=1e-15)
    np.testing.assert_allclose(row["lost_fabric"], nn[2], atol=1e-15)


def test_a_contact_that_leaves_the_region_but_still_touches_is_crossed_not_lost():
    e1, e2 = np.eye(3)[:2]
    tracker = budget.ContactTracker()
    step(tracker, [(1, 2), (2, 3), (3, 4)], [e1, e2, e2])
    step(tracker, [(1, 2), (2, 3), (5, 6)], [e1, e2, e1], touching=[(3, 4)])  # (3, 4) left; (5, 6) is new
    step(tracker, [(1, 2), (2, 3), (5, 6)], [e1, e2, e1], touching=[(3, 4)])
    row = tracker.row()
    assert (row["made_count"], row["lost_count"], row["entered_count"], row["left_count"]) == (1, 0, 0, 1)
    tracker2 = budget.ContactTracker()
    step(tracker2, [(1, 2), (2, 3), (3, 4)], [e1, e2, e2], touching=[(5, 6)])
    step(tracker2, [(1, 2), (2, 3), (5, 6)], [e1, e2, e1], touching=[(3, 4)])  # (5, 6) touched outside: entered
    row2 = tracker2.row()
    assert (row2["made_count"], row2["lost_count"], row2["entered_count"], row2["left_count"]) == (0, 0, 1, 1)
    np.testing.assert_allclose(row2["budget_made"] + row2["budget_lost"], 0.0, atol=1e-15)
    np.testing.assert_allclose(row2["budget_crossed"], fabric(np.array([e1, e2, e1])) - fabric(np.array([e1, e2, e2])),
                               atol=1e-15)


@pytest.mark.parametrize("steps_per_sample", [1, 3])
def test_the_budget_sums_to_the_change_of_the_fabric_over_a_random_history(steps_per_sample):
    """Contacts made, lost, crossing and rotating at random: the four terms add up to the measured change of A from
    sample to sample, however many tracking points lie between."""
    n_grains = 60
    pairs = {(i, j) for i in range(n_grains) for j in range(i + 1, n_grains) if RNG.random() < 0.05}
    normal = {p: random_normals(1)[0] for p in pairs}
    region = {p: RNG.random() < 0.7 for p in pairs}
    tracker = budget.ContactTracker()
    previous = None
    for k in range(30):
        for p in list(pairs):
            u = RNG.random()
            if u < 0.1:
                pairs.remove(p)
            elif u < 0.15:
                region[p] = not region[p]
            else:
                normal[p] = unit(normal[p] + 0.1 * RNG.normal(size=3))
        for _ in range(8):
            p = tuple(sorted(RNG.choice(n_grains, 2, replace=False).tolist()))
            if p not in pairs:
                pairs.add(p)
                normal[p], region[p] = random_normals(1)[0], RNG.random() < 0.7
        inside = sorted(p for p in pairs if region[p])
        outside = [p for p in pairs if not region[p]]
        order = RNG.permutation(len(inside))  # the engines hand contacts over in any order
        step(tracker, [inside[i] for i in order], [normal[inside[i]] for i in order], outside,
             forces=RNG.random(len(inside)))
        if k % steps_per_sample == 0:
            row = tracker.row()
            a = fabric(np.array([normal[p] for p in inside]))
            total = sum(row[f"budget_{t}"] for t in budget.TERMS)
            if previous is None:
                assert np.all(np.isnan(total))
            else:
                np.testing.assert_allclose(total, a - previous, atol=1e-14)
                assert row["track_points"] == steps_per_sample
            previous = a


def test_every_contact_kept_and_unchanged_persists_with_no_budget():
    normals = random_normals(40)
    pairs = [(i, i + 1) for i in range(40)]
    tracker = budget.ContactTracker()
    for _ in range(4):
        step(tracker, pairs, normals, direction=90.0)
    row = tracker.row()
    np.testing.assert_allclose(row["persistence_touching"][0], 1.0)
    np.testing.assert_allclose(row["persistence_touching"][1:][row["persistence_count"][1:] > 0], 1.0)
    assert row["persistence_count"][0] == 40 == row["persistence_count"][1:].sum()
    for t in budget.TERMS:
        np.testing.assert_allclose(row[f"budget_{t}"], 0.0, atol=1e-15)
    assert row["survivor_share"] == 1.0
    np.testing.assert_allclose(row["survivor_fabric"], fabric(normals), atol=1e-15)


def test_persistence_counts_the_contacts_of_the_last_change_by_how_the_new_shear_loads_them():
    """Shear along s = e1 compresses (e1 - e2)/sqrt2 and stretches (e1 + e2)/sqrt2; e3 is neutral. After the turn to
    180 degrees the classes swap; the set is retaken at the turn."""
    compressed, stretched, neutral = unit([1, -1, 0]), unit([1, 1, 0]), np.array([0.0, 0.0, 1.0])
    tracker = budget.ContactTracker()
    step(tracker, [(1, 2), (2, 3), (3, 4), (4, 5)], [compressed, compressed, stretched, neutral], direction=0.0)
    step(tracker, [(1, 2), (3, 4), (4, 5)], [compressed, stretched, neutral], direction=0.0)
    row = tracker.row()
    np.testing.assert_array_equal(row["persistence_count"], [4, 2, 1, 1])
    np.testing.assert_allclose(row["persistence_touching"], [0.75, 0.5, 1.0, 1.0])
    step(tracker, [(1, 2), (3, 4), (4, 5)], [compressed, stretched, neutral], direction=180.0)  # a reversal
    step(tracker, [(1, 2), (4, 5)], [compressed, neutral], direction=180.0)
    row = tracker.row()
    np.testing.assert_array_equal(row["persistence_count"], [3, 1, 1, 1])  # (3, 4) is now the compressed one
    np.testing.assert_allclose(row["persistence_touching"], [2 / 3, 0.0, 1.0, 1.0])


def test_the_class_edges_are_thirds_of_the_loading():
    phi = 30.0
    s = np.array([math.cos(math.radians(phi)), 0.0, math.sin(math.radians(phi))])
    normals = random_normals(2000)
    x = 2 * (normals @ s) * normals[:, 1]
    cls = budget.loading_class(normals, phi)
    assert np.all(x[cls == 1] < -1 / 3) and np.all(x[cls == 3] > 1 / 3) and np.all(np.abs(x[cls == 2]) <= 1 / 3)


def test_the_strong_network_carries_more_than_the_mean_force():
    e1, e2 = np.eye(3)[:2]
    out = budget.networks(np.array([e1, e1, e2, e2]), np.array([3.0, 2.0, 0.5, 0.5]))
    assert out["strong_fraction"] == 0.5
    np.testing.assert_allclose(out["strong_fabric"], np.outer(e1, e1) - np.eye(3) / 3)
    np.testing.assert_allclose(out["weak_fabric"], np.outer(e2, e2) - np.eye(3) / 3)
    np.testing.assert_allclose(out["force_fabric"], (5 * np.outer(e1, e1) + np.outer(e2, e2)) / 6 - np.eye(3) / 3)


def test_the_tracker_resumes_from_its_arrays_bit_for_bit():
    normals = random_normals(30)
    pairs = [(i, i + 2) for i in range(30)]
    a, b = budget.ContactTracker(), None
    step(a, pairs, normals, direction=0.0)
    step(a, pairs[3:], unit(normals[3:] + 0.05), direction=0.0)
    b = budget.ContactTracker({k: np.array(v) for k, v in a.to_arrays().items()})
    for tracker in (a, b):
        step(tracker, pairs[5:], unit(normals[5:] + 0.1), direction=90.0)
    ra, rb = a.row(), b.row()
    for key in ra:
        np.testing.assert_array_equal(ra[key], rb[key])


def test_tracking_points_hold_every_sample_and_change_and_none_without_tracking():
    spec = resolve(90, "tiny", overrides={"contact_track_strain": 0.002})
    track = protocol.track_strains(spec)
    assert set(np.round(protocol.sample_strains(spec), 9)) <= set(np.round(track, 9))
    assert set(np.round(protocol.direction_changes(spec), 9)) <= set(np.round(track, 9))
    assert np.all(np.diff(track) > 1e-9) and np.max(np.diff(track)) <= 0.002 + 1e-9
    assert protocol.track_strains(resolve(90, "tiny", overrides={"contact_track_strain": 0})) == []


def test_the_survivors_parts_by_class_and_the_made_ones_make_up_the_fabric():
    compressed, stretched, neutral = unit([1, -1, 0]), unit([1, 1, 0]), np.array([0.0, 0.0, 1.0])
    tracker = budget.ContactTracker()
    step(tracker, [(1, 2), (2, 3), (3, 4)], [compressed, stretched, neutral], direction=0.0, forces=[3.0, 1.0, 2.0])
    step(tracker, [(1, 2), (3, 4), (5, 6)], [compressed, neutral, stretched], direction=0.0, forces=[4.0, 2.0, 1.0])
    row = tracker.row()
    made = (np.outer(stretched, stretched) - np.eye(3) / 3) / 3
    np.testing.assert_allclose(row["survivor_part"].sum(axis=0) + made,
                               fabric(np.array([compressed, neutral, stretched])), atol=1e-15)
    np.testing.assert_allclose(row["survivor_part"][2], 0.0)  # the stretched one was lost
    np.testing.assert_allclose(row["survivor_force"][:3], [3.0, 4.0, 2.0])
    assert np.isnan(row["survivor_force"][3])


def test_eq13_terms_add_up_to_the_models_own_fabric_rate():
    """The split of Eq. 13 the budget is set against sums to the rate the model integrates (its jitted kernel)."""
    import model
    from model import equations

    rng = np.random.default_rng(3)
    p = model.PAPER
    for phi in (0.0, 90.0, 150.0):
        a = rng.normal(scale=0.05, size=(3, 3))
        a = 0.5 * (a + a.T)
        a -= np.trace(a) * np.eye(3) / 3
        L = model.shear_velocity_gradient(phi)
        terms = equations.eq13_terms(a[None], L[None], p)
        D = 0.5 * (L + L.T)
        W = 0.5 * (L - L.T)
        norm = np.linalg.norm(D)
        Dh = D / norm
        y = np.array([a[0, 0], a[1, 1], a[0, 1], a[0, 2], a[1, 2], 0.0, 0.0])
        packed = np.array([Dh[0, 0], Dh[1, 1], Dh[2, 2], Dh[0, 1], Dh[0, 2], Dh[1, 2]])
        n = equations.fabric_rates(y, packed, np.array([W[0, 1], W[0, 2], W[1, 2]]) / norm, p.as_array())
        total = (terms["input"] + terms["recovery"] + terms["spin"])[0]
        rate = np.array(n[:5]) / n[5]
        np.testing.assert_allclose([total[0, 0], total[1, 1], total[0, 1], total[0, 2], total[1, 2]], rate,
                                   rtol=1e-10, atol=1e-12)


def test_the_gain_and_loss_by_load_sum_to_the_made_and_lost_counts():
    tracker = budget.ContactTracker()
    pairs, normal = set(), {}
    for k in range(1, 31):
        for p in list(pairs):
            if RNG.random() < 0.2:
                pairs.discard(p)
        for _ in range(int(RNG.integers(0, 8))):
            p = tuple(sorted(RNG.choice(60, size=2, replace=False).tolist()))
            if p not in pairs:
                pairs.add(p)
                normal[p] = random_normals(1)[0]
        listed = sorted(pairs)
        step(tracker, listed, [normal[p] for p in listed], direction=0.0 if k < 15 else 150.0)
        if k % 5 == 0:
            row = tracker.row()
            assert row["made_by_load"].sum() == row["made_count"] and row["lost_by_load"].sum() == row["lost_count"]
            assert row["contacts_by_load"].sum() == len(listed)


def test_the_bins_of_load_run_from_most_compressed_to_most_stretched():
    compressed, stretched, neutral = unit([1, -1, 0]), unit([1, 1, 0]), np.array([0.0, 0.0, 1.0])
    counts = budget.by_load(np.array([compressed, stretched, neutral, neutral]), 0.0)
    assert counts[0] == 1 and counts[-1] == 1 and counts[budget.LOAD_BINS // 2] == 2 and counts.sum() == 4


def test_the_contacts_made_are_traced_to_the_near_shell_they_came_from():
    """(1, 2) was 0.005 apart and (3, 4) 0.05 apart at the point before they touched; (5, 6) came from farther."""
    e1 = np.eye(3)[0]
    tracker = budget.ContactTracker()
    step(tracker, [(7, 8)], [e1], near_pairs=near([(1, 2), (3, 4)], [0.005, 0.05]))
    step(tracker, [(7, 8), (1, 2), (3, 4), (5, 6)], [e1] * 4, near_pairs=near([(9, 10)], [0.02]))
    step(tracker, [(1, 2), (3, 4), (5, 6)], [e1] * 3, near_pairs=near([(7, 8)], [0.02]))  # (7, 8) opens by 0.02
    row = tracker.row()
    assert row["made_count"] == 3 and row["lost_count"] == 1
    np.testing.assert_array_equal(row["made_near"], [1, 1, 2])  # within 0.01, 0.03, 0.1
    np.testing.assert_array_equal(row["made_near_change"], [1, 1, 2])  # the first point is a change
    np.testing.assert_array_equal(row["lost_near"], [0, 1, 1])
    np.testing.assert_array_equal(row["near_count"], [0, 1, 1])
    np.testing.assert_allclose(row["near_fabric"][1], np.outer(e1, e1) - np.eye(3) / 3)
    assert np.all(np.isnan(row["near_fabric"][0]))


def test_a_contact_that_opens_and_closes_again_touches_but_does_not_persist():
    e1, e2 = np.eye(3)[:2]
    tracker = budget.ContactTracker()
    step(tracker, [(1, 2), (2, 3)], [e1, e2], direction=90.0)
    step(tracker, [(1, 2)], [e1], direction=90.0)
    step(tracker, [(1, 2), (2, 3)], [e1, e2], direction=90.0)
    row = tracker.row()
    assert row["persistence_touching"][0] == 1.0 and row["persistence_continuous"][0] == 0.5
    step(tracker, [(1, 2), (2, 3)], [e1, e2], direction=0.0)  # a change: the set is retaken, whole
    assert tracker.row()["persistence_continuous"][0] == 1.0


def test_the_contacts_made_are_traced_to_the_near_shell_of_the_last_change():
    e1 = np.eye(3)[0]
    tracker = budget.ContactTracker()
    step(tracker, [(7, 8)], [e1], near_pairs=near([(1, 2), (3, 4)], [0.05, 0.08]))  # the change
    step(tracker, [(7, 8)], [e1], near_pairs=near([(1, 2), (5, 6)], [0.002, 0.005]))
    step(tracker, [(7, 8), (1, 2), (5, 6)], [e1] * 3, near_pairs=near())
    row = tracker.row()
    np.testing.assert_array_equal(row["made_near"], [2, 2, 2])
    np.testing.assert_array_equal(row["made_near_change"], [0, 0, 1])


def test_a_tracker_from_an_older_checkpoint_is_refused_naming_what_it_lacks():
    arrays = budget.ContactTracker().to_arrays()
    del arrays["change_alive"]
    with pytest.raises(ValueError, match="change_alive"):
        budget.ContactTracker(arrays)
