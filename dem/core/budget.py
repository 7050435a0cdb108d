"""The contact budget: the fabric's change split by what its contacts do, the strong and weak networks, and the
persistence of the contacts present at each change of direction, the gain and loss by direction and the near pairs
the contacts made come from (numpy and scipy; both engines, in their python3).

Contacts are the internal (grain-grain) ones whose contact point lies in the central region, the set Eq. 8's fabric
``A = <n n> - I/3`` averages over (``dem.core.measure``). A contact is keyed by its pair of grains (engine ids, which
both engines keep for a run's life). Between two tracking points (``dem.core.protocol.track_strains``) a region
contact is

- **kept**: in the region at both points (its normal may have rotated);
- **lost**: its pair no longer touches anywhere; **made**: its pair did not touch anywhere before;
- **crossed**: it touched at both points but entered or left the region (the region's border, not contact physics).

A pair that separates and touches again between two points is *kept*: the tracking spacing sets what is missed
(``contact_track_strain``; measured in ``docs/results/budget.md``). With ``d = n n - I/3`` and N the region's contact
count, the change ``A1 - A0`` is taken in three exact steps: remove the lost and leaving contacts, rotate the kept
ones, add the made and entering ones. With K the kept set, L a removed group, M an added group:

    lost  = (N_L / N_K) (A0 - <d>_L)        kept = <d1>_K - <d0>_K        made = (N_M / N1) (<d>_M - <d1>_K)

(``crossed`` is the leaving and entering groups' terms together), so that ``made + lost + kept + crossed = A1 - A0``
to rounding. In the continuum limit these are ``(rate made / N)(<d>_M - A)``, ``-(rate lost / N)(<d>_L - A)`` and
``<d(d)/dt>_K``: the paper's input and recovery terms (Sec. 5, Eq. 13) measured apart.

**Networks**: a contact is strong where its normal force exceeds the region's mean normal force (Radjai et al.,
PRL 1998); the strong and weak partial fabrics are each set's ``<n n> - I/3``; the force-weighted fabric is
``sum f_n n n / sum f_n - I/3``.

**Loading**: a direction n is loaded by the shear along s (``L = gamma_dot s (x) e2``) as
``x = n.D'.n / max_m m.D'.m = 2 (n.s)(n.e2)`` in [-1, 1]: compressed for x < 0, stretched for x > 0.

**Gain and loss functions**: the contacts made and lost between samples, counted in ``LOAD_BINS`` equal bins of x
under the shear of their interval (the lost ones by their last normal), beside the region's contacts and near pairs
per bin at the sample: the rates per bin are the direction-resolved gain and loss a law needs.

**Where contacts come from** (``dem.core.neighbours``): the near shells' fabrics ``G_g`` at each sample, and of the
contacts made, how many were within each shell's gap at the tracking point before and at the last change of
direction (of those lost, how many are within it now): ``made_near_change / made_count`` is the share of the contacts
made that the shell at the turn fed (at the tracking spacing, 0.0005 strain, nearly every contact made was within
0.01 d one point before).

**Persistence**: the region's contacts at each change of direction (the start of shear included) are classed by how
the new shear loads them: *compressed* x < -1/3, *neutral* |x| <= 1/3, *stretched* x > 1/3. At each sample the
fraction of each class whose pair touches now (anywhere; ``persistence_touching``: it may have opened and closed
again between tracking points) and whose pair touched at every tracking point since the change
(``persistence_continuous``) is recorded, with the fabric of those still in the region (the *survivors*), their
share of the region's contacts and of its strong network, each class's part of A (its survivors'
``sum (n n - I/3) / N``: with the contacts made since the change they make up A) and each class's mean normal force
(its unloading).
"""

import math

import numpy as np

from dem.core.neighbours import NEAR_GAPS, NearPairs, gap_of, in_region, member, shell_fabrics

IDENTITY = np.eye(3)
#: the loading classes of the persistence (``x`` as above); "all" is every contact of the change
CLASSES = ("all", "compressed", "neutral", "stretched")
CLASS_EDGE = 1.0 / 3.0
#: the bins of x in [-1, 1] of the gain and loss functions
LOAD_BINS = 8
#: the terms of the fabric budget, in their order in ``row``
TERMS = ("made", "lost", "kept", "crossed")
#: the tracker's persistent arrays (saved beside each checkpoint, ``to_arrays``/``ContactTracker(arrays)``)
STATE_KEYS = ("prev_keys", "prev_normals", "prev_all_keys", "change_keys", "change_class", "change_alive",
              "prev_near_keys", "prev_near_gaps", "change_near_keys", "change_near_gaps", "scalars", "sums", "counted")
_SCALARS = ("started", "direction_deg", "points", "made", "lost", "entered", "left")
_SUMS = ("made", "lost", "kept", "crossed", "made_d", "lost_d")
#: the counts summed between samples, with their lengths
_COUNTED = (("made_by_load", LOAD_BINS), ("lost_by_load", LOAD_BINS), ("made_near", len(NEAR_GAPS)),
            ("lost_near", len(NEAR_GAPS)), ("made_near_change", len(NEAR_GAPS)))


def deviator_sum(normal) -> np.ndarray:
    """``sum_c (n n - I/3)`` over the rows of ``normal`` (a 3x3 zero for none)."""
    return np.einsum("ci,cj->ij", normal, normal) - len(normal) * IDENTITY / 3


def mean_fabric(normal, weight=None) -> np.ndarray:
    """``<n n> - I/3`` (weighted by ``weight`` when given); NaN for no contact or no weight."""
    if len(normal) == 0:
        return np.full((3, 3), np.nan)
    if weight is None:
        return deviator_sum(normal) / len(normal)
    total = weight.sum()
    if not total > 0:
        return np.full((3, 3), np.nan)
    return np.einsum("c,ci,cj->ij", weight, normal, normal) / total - IDENTITY / 3


def loading(normal, direction_deg) -> np.ndarray:
    """``x = 2 (n.s)(n.e2)`` of each normal (rows) under shear along s(direction_deg): -1 most compressed, 1 most
    stretched."""
    phi = math.radians(direction_deg)
    normal = np.asarray(normal, dtype=float).reshape(-1, 3)
    return 2.0 * (normal @ np.array([math.cos(phi), 0.0, math.sin(phi)])) * normal[:, 1]


def loading_class(normal, direction_deg) -> np.ndarray:
    """1 compressed, 2 neutral, 3 stretched: the class of each normal under shear along s(direction_deg)."""
    x = loading(normal, direction_deg)
    return np.where(x < -CLASS_EDGE, 1, np.where(x > CLASS_EDGE, 3, 2)).astype(np.int8)


def by_load(normal, direction_deg) -> np.ndarray:
    """How many of ``normal`` fall in each of ``LOAD_BINS`` equal bins of x in [-1, 1]."""
    x = loading(normal, direction_deg)
    at = np.clip(np.floor((x + 1.0) / 2.0 * LOAD_BINS).astype(np.int64), 0, LOAD_BINS - 1)
    return np.bincount(at, minlength=LOAD_BINS).astype(np.int64)


def networks(normal, normal_force) -> dict:
    """The strong and weak partial fabrics, the strong network's share of contacts and the force-weighted fabric."""
    if len(normal) == 0:
        nan = np.full((3, 3), np.nan)
        return {"strong_fabric": nan, "weak_fabric": nan, "strong_fraction": np.nan, "force_fabric": nan}
    strong = normal_force > normal_force.mean()
    return {"strong_fabric": mean_fabric(normal[strong]), "weak_fabric": mean_fabric(normal[~strong]),
            "strong_fraction": float(strong.mean()), "force_fabric": mean_fabric(normal, normal_force)}


def budget_step(prev_keys, prev_normals, prev_all, keys, normals, all_keys) -> tuple[dict, dict]:
    """The terms of one step's fabric change (``TERMS``, 3x3 each, summing to ``A1 - A0``), and the step's counts,
    deviator sums and masks (over ``keys`` and ``prev_keys``) of the made and lost contacts. Keys sorted and unique;
    ``*_all`` every internal contact's."""
    kept1 = member(prev_keys, keys)
    kept0 = member(keys, prev_keys)
    touching0 = member(prev_all, keys)
    touching1 = member(all_keys, prev_keys)
    made, entered = ~touching0, touching0 & ~kept1
    lost, left = ~touching1, touching1 & ~kept0
    n0, n1, nk = len(prev_keys), len(keys), int(kept1.sum())
    d_made, d_entered = deviator_sum(normals[made]), deviator_sum(normals[entered])
    d_lost, d_left = deviator_sum(prev_normals[lost]), deviator_sum(prev_normals[left])
    counts = {"made": int(made.sum()), "lost": int(lost.sum()), "entered": int(entered.sum()),
              "left": int(left.sum()), "made_d": d_made, "lost_d": d_lost, "made_mask": made, "lost_mask": lost}
    if n0 == 0 or n1 == 0:
        nan = np.full((3, 3), np.nan)
        return {t: nan for t in TERMS}, counts
    if nk == 0:  # nothing kept: the old set leaves, the new one arrives
        return {"made": d_made / n1, "lost": -d_lost / n0, "kept": np.zeros((3, 3)),
                "crossed": d_entered / n1 - d_left / n0}, counts
    a0 = deviator_sum(prev_normals) / n0
    ak0, ak1 = deviator_sum(prev_normals[kept0]) / nk, deviator_sum(normals[kept1]) / nk
    terms = {
        "made": (d_made - counts["made"] * ak1) / n1,
        "lost": (counts["lost"] * a0 - d_lost) / nk,
        "kept": ak1 - ak0,
        "crossed": (d_entered - counts["entered"] * ak1) / n1 + (counts["left"] * a0 - d_left) / nk,
    }
    return terms, counts


class ContactTracker:
    """Region contacts followed from tracking point to tracking point: the budget summed between samples, the set
    of the last change of direction, the near pairs of the last point, and the rows a sample records (``row``). Its
    state is plain arrays (``to_arrays``), saved with the samples beside each checkpoint, so a resumed run tracks
    bit-identically."""

    def __init__(self, arrays=None):
        if arrays is None:
            self.prev_keys = self.prev_all_keys = self.change_keys = np.zeros(0, dtype=np.int64)
            self.prev_normals = np.zeros((0, 3))
            self.change_class = np.zeros(0, dtype=np.int8)
            self.change_alive = np.zeros(0, dtype=bool)
            self.prev_near_keys = self.change_near_keys = np.zeros(0, dtype=np.int64)
            self.prev_near_gaps = self.change_near_gaps = np.zeros(0)
            self.scalars = dict.fromkeys(_SCALARS, 0.0)
            self.scalars["direction_deg"] = math.nan
            self.sums = {name: np.zeros((3, 3)) for name in _SUMS}
            self.counted = {name: np.zeros(n, dtype=np.int64) for name, n in _COUNTED}
            return
        missing = sorted(set(STATE_KEYS) - set(arrays))
        if missing:
            raise ValueError(f"the checkpoint's contact tracker lacks {', '.join(missing)} (an older code's)")
        self.prev_keys = np.asarray(arrays["prev_keys"], dtype=np.int64)
        self.prev_normals = np.asarray(arrays["prev_normals"], dtype=float).reshape(-1, 3)
        self.prev_all_keys = np.asarray(arrays["prev_all_keys"], dtype=np.int64)
        self.change_keys = np.asarray(arrays["change_keys"], dtype=np.int64)
        self.change_class = np.asarray(arrays["change_class"], dtype=np.int8)
        self.change_alive = np.asarray(arrays["change_alive"], dtype=bool)
        self.prev_near_keys = np.asarray(arrays["prev_near_keys"], dtype=np.int64)
        self.prev_near_gaps = np.asarray(arrays["prev_near_gaps"], dtype=float)
        self.change_near_keys = np.asarray(arrays["change_near_keys"], dtype=np.int64)
        self.change_near_gaps = np.asarray(arrays["change_near_gaps"], dtype=float)
        self.scalars = dict(zip(_SCALARS, np.asarray(arrays["scalars"], dtype=float).tolist(), strict=True))
        self.sums = dict(zip(_SUMS, np.asarray(arrays["sums"], dtype=float).reshape(-1, 3, 3), strict=True))
        counted = np.asarray(arrays["counted"], dtype=np.int64)
        ends = np.cumsum([n for _, n in _COUNTED])
        self.counted = {name: part for (name, _), part in zip(_COUNTED, np.split(counted, ends[:-1]), strict=True)}

    def to_arrays(self) -> dict:
        return {"prev_keys": self.prev_keys, "prev_normals": self.prev_normals, "prev_all_keys": self.prev_all_keys,
                "change_keys": self.change_keys, "change_class": self.change_class,
                "change_alive": self.change_alive.astype(np.int8), "prev_near_keys": self.prev_near_keys,
                "prev_near_gaps": self.prev_near_gaps, "change_near_keys": self.change_near_keys,
                "change_near_gaps": self.change_near_gaps, "scalars": np.array([self.scalars[k] for k in _SCALARS]),
                "sums": np.array([self.sums[k] for k in _SUMS]),
                "counted": np.concatenate([self.counted[name] for name, _ in _COUNTED])}

    def step(self, keys, normals, normal_force, all_keys, direction_deg, near: NearPairs, region) -> None:
        """One tracking point: the region's contacts (``keys``, ``normals``, ``normal_force``), every internal
        contact's key (``all_keys``), all unsorted, the near pairs (``dem.core.neighbours.near_pairs``) and the
        central region's heights; ``direction_deg`` the shear direction set at this point. Where it differs from
        the last point's (or at the first point) the region's contacts are this change's set."""
        order = np.argsort(keys, kind="stable")
        keys, normals = keys[order], normals[order]
        self.normal_force = np.asarray(normal_force, dtype=float)[order]  # for ``row`` at this point only
        self.near, self.region = near, region  # likewise
        all_keys = np.unique(all_keys)
        sc = self.scalars
        if sc["started"]:
            terms, counts = budget_step(self.prev_keys, self.prev_normals, self.prev_all_keys, keys, normals,
                                        all_keys)
            for name in TERMS:
                self.sums[name] = self.sums[name] + terms[name]
            for name in ("made", "lost", "entered", "left"):
                sc[name] += counts[name]
            self.sums["made_d"] = self.sums["made_d"] + counts["made_d"]
            self.sums["lost_d"] = self.sums["lost_d"] + counts["lost_d"]
            self._count(keys[counts["made_mask"]], normals[counts["made_mask"]],
                        self.prev_keys[counts["lost_mask"]], self.prev_normals[counts["lost_mask"]], near)
            self.change_alive &= member(all_keys, self.change_keys)
            sc["points"] += 1
        if not sc["started"] or direction_deg != sc["direction_deg"]:
            self.change_keys = keys.copy()
            self.change_class = loading_class(normals, direction_deg)
            self.change_alive = np.ones(len(keys), dtype=bool)
            self.change_near_keys, self.change_near_gaps = near.keys, near.gap
            sc["direction_deg"] = float(direction_deg)
        sc["started"] = 1.0
        self.prev_keys, self.prev_normals, self.prev_all_keys = keys, normals, all_keys
        self.prev_near_keys, self.prev_near_gaps = near.keys, near.gap

    def _count(self, made_keys, made_normals, lost_keys, lost_normals, near):
        """The gain and loss by load under the interval's shear (the last point's direction), and the contacts made
        out of each near shell of the last point and of the last change, and lost into each shell of this point."""
        interval = self.scalars["direction_deg"]
        self.counted["made_by_load"] += by_load(made_normals, interval)
        self.counted["lost_by_load"] += by_load(lost_normals, interval)
        for name, gaps in (("made_near", gap_of(self.prev_near_keys, self.prev_near_gaps, made_keys)),
                           ("made_near_change", gap_of(self.change_near_keys, self.change_near_gaps, made_keys)),
                           ("lost_near", near.gap_of(lost_keys))):
            self.counted[name] += np.array([(gaps <= g).sum() for g in NEAR_GAPS], dtype=np.int64)

    def row(self) -> dict:
        """The fields a sample records (``config/raw_schema.toml`` [contacts] and [neighbours]) at the point just
        ``step``ped; resets the sums. The first sample of a run has no budget (NaN)."""
        sc = self.scalars
        keys, normals, normal_force = self.prev_keys, self.prev_normals, self.normal_force
        first = sc["points"] == 0
        out = {f"budget_{name}": np.full((3, 3), np.nan) if first else self.sums[name] for name in TERMS}
        made, lost = int(sc["made"]), int(sc["lost"])
        out.update(
            made_count=made, lost_count=lost, entered_count=int(sc["entered"]), left_count=int(sc["left"]),
            made_fabric=self.sums["made_d"] / made if made else np.full((3, 3), np.nan),
            lost_fabric=self.sums["lost_d"] / lost if lost else np.full((3, 3), np.nan),
            track_points=int(sc["points"]),
        )
        out.update(networks(normals, normal_force))
        out.update(self._persistence(keys, normals, normal_force))
        out.update(self._neighbours(normals))
        for name in _SUMS:
            self.sums[name] = np.zeros((3, 3))
        for name in ("points", "made", "lost", "entered", "left"):
            sc[name] = 0.0
        for name, n in _COUNTED:
            self.counted[name] = np.zeros(n, dtype=np.int64)
        return out

    def _persistence(self, keys, normals, normal_force) -> dict:
        """The last change's contacts: the share of each class touching now and touching throughout, and the
        survivors in the region."""
        out = {}
        cls = self.change_class
        members = [np.ones(len(cls), dtype=bool)] + [cls == k for k in (1, 2, 3)]
        still = member(self.prev_all_keys, self.change_keys)
        out["persistence_count"] = np.array([m.sum() for m in members], dtype=np.int64)
        out["persistence_touching"] = np.array([still[m].mean() if m.any() else np.nan for m in members])
        out["persistence_continuous"] = np.array([self.change_alive[m].mean() if m.any() else np.nan
                                                  for m in members])
        survivor = member(self.change_keys, keys)
        out["survivor_fabric"] = mean_fabric(normals[survivor])
        out["survivor_share"] = float(survivor.mean()) if len(keys) else np.nan
        at = np.minimum(np.searchsorted(self.change_keys, keys), max(len(self.change_keys) - 1, 0))
        now_class = np.where(survivor, cls[at] if len(cls) else 0, 0)
        classes = [survivor] + [now_class == k for k in (1, 2, 3)]
        out["survivor_part"] = np.array([deviator_sum(normals[now_class == k]) / max(len(keys), 1)
                                         for k in (1, 2, 3)])
        out["survivor_force"] = np.array([normal_force[m].mean() if m.any() else np.nan for m in classes])
        strong = normal_force > normal_force.mean() if len(keys) else np.zeros(0, dtype=bool)
        out["survivor_strong_share"] = float(survivor[strong].mean()) if strong.any() else np.nan
        return out

    def _neighbours(self, normals) -> dict:
        """The near shells' fabrics and counts in the region, the gain and loss by load since the last sample, and
        the region's contacts and near pairs by load under the shear now."""
        near, direction = self.near, self.scalars["direction_deg"]
        inside = in_region(near, self.region)
        fabrics, counts = shell_fabrics(near, inside)
        return {
            "near_fabric": fabrics, "near_count": counts,
            "near_by_load": np.array([by_load(near.normal[inside & (near.gap <= g)], direction) for g in NEAR_GAPS]),
            "contacts_by_load": by_load(normals, direction),
            **{name: self.counted[name].copy() for name, _ in _COUNTED},
        }
