"""The near pairs (``dem/core/neighbours.py``) of hand-made packings with known gaps, across the periodic sides."""

import numpy as np

from dem.core import neighbours

WIDTH = 10.0


def pairs_of(pos, radius, touching=(), ids=None):
    ids = np.arange(100, 100 + len(pos)) if ids is None else np.asarray(ids)
    touching = np.asarray(touching, dtype=np.int64).reshape(-1, 2)
    keys = np.unique(neighbours.pair_keys(ids[touching[:, 0]], ids[touching[:, 1]]))
    return ids, neighbours.near_pairs(ids, np.asarray(pos, dtype=float), np.asarray(radius, dtype=float), WIDTH, keys)


def test_a_known_packing_gives_its_gaps_across_the_periodic_sides():
    """Grains 0 and 1 are 0.02 apart through the e1 side; 2 and 3 0.05 apart through the e3 side, one of them at a
    negative (unwrapped) position; 4 and 5 touch (listed); 6 is alone; 7 sits 0.5 apart from 4 (beyond every shell)."""
    pos = [[9.74, 3.0, 5.0], [0.28, 3.0, 5.0],       # centres 0.54 apart across x = 10: gap 0.54 - 0.52 = 0.02
           [5.0, 4.0, -0.3], [5.0, 4.0, 9.0],        # -0.3 is 9.7: 0.7 apart, radii 0.3 + 0.35: gap 0.05
           [2.0, 6.0, 2.0], [3.0, 6.0, 2.0],         # touching
           [7.0, 1.0, 7.0],
           [2.0, 7.5, 2.0]]
    radius = [0.26, 0.26, 0.3, 0.35, 0.5, 0.5, 0.4, 0.5]
    ids, near = pairs_of(pos, radius, touching=[(4, 5)])
    found = dict(zip(near.keys.tolist(), near.gap.tolist(), strict=True))
    assert set(found) == {int(neighbours.pair_keys(ids[[0]], ids[[1]])[0]),
                          int(neighbours.pair_keys(ids[[2]], ids[[3]])[0])}
    np.testing.assert_allclose(sorted(found.values()), [0.02, 0.05], atol=1e-12)
    k = list(near.keys).index(neighbours.pair_keys(ids[[0]], ids[[1]])[0])
    np.testing.assert_allclose(near.normal[k], [1.0, 0.0, 0.0], atol=1e-12)  # from 100 to 101, across the side
    np.testing.assert_allclose(near.middle_y[k], 3.0)


def test_the_shells_nest_and_their_fabrics_are_the_pairs_directions():
    pos = [[1.0, 2.0, 1.0], [2.005, 2.0, 1.0],      # gap 0.005 along e1
           [5.0, 2.0, 5.0], [5.0, 3.02, 5.0],       # gap 0.02 along e2
           [8.0, 2.0, 8.0], [8.0, 2.0, 9.08]]       # gap 0.08 along e3
    _, near = pairs_of(pos, [0.5] * 6)
    fabrics, counts = neighbours.shell_fabrics(near, neighbours.in_region(near, (0.0, 10.0)))
    np.testing.assert_array_equal(counts, [1, 2, 3])
    e = np.eye(3)
    np.testing.assert_allclose(fabrics[0], np.outer(e[0], e[0]) - e / 3, atol=1e-12)
    np.testing.assert_allclose(fabrics[2], np.zeros((3, 3)), atol=1e-12)  # e1, e2, e3 once each
    _, counts_low = neighbours.shell_fabrics(near, neighbours.in_region(near, (0.0, 2.4)))
    np.testing.assert_array_equal(counts_low, [1, 1, 2])  # the e2 pair's gap middle is at 2.51


def test_random_packings_agree_with_a_brute_force_search():
    rng = np.random.default_rng(5)
    pos = rng.uniform([0, 0, 0], [WIDTH, 4.0, WIDTH], size=(300, 3))
    radius = rng.uniform(0.25, 0.75, size=300)
    ids, near = pairs_of(pos, radius)
    found = {}
    for a in range(300):
        for b in range(a + 1, 300):
            d = pos[b] - pos[a]
            d[[0, 2]] -= WIDTH * np.round(d[[0, 2]] / WIDTH)
            gap = np.linalg.norm(d) - radius[a] - radius[b]
            if gap <= neighbours.NEAR_GAPS[-1]:
                found[int(neighbours.pair_keys(ids[[a]], ids[[b]])[0])] = gap
    assert len(found) > 50
    assert dict(zip(near.keys.tolist(), near.gap.tolist(), strict=True)).keys() == found.keys()
    np.testing.assert_allclose(near.gap_of(np.array(sorted(found))), [found[k] for k in sorted(found)], atol=1e-12)
