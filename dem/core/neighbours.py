"""The near-contact network: grain pairs that almost touch, where the contacts made come from (numpy and scipy;
both engines, in their python3).

A pair of internal grains i, j (centres x_i, x_j, radii r_i, r_j; the cell periodic along e1 and e3 with period W,
walls normal to e2) has the surface gap ``h = |x_j - x_i| - r_i - r_j`` (minimum image; lengths in d, the mean
grain diameter). Its **near shell** of width g holds the pairs that do not touch (not in the engine's contact list)
with ``h <= g``; ``NEAR_GAPS`` are the widths recorded. The near-contact fabric of a shell is
``G_g = <n n> - I/3`` over its pairs whose gap's middle ``x_i + (r_i + h/2) n`` lies in the central region, the set
Eq. 8's fabric A averages over (there the contact point), with ``n`` the unit vector from i to j.

The search is ``scipy.spatial.cKDTree`` on the periodic box (the height made longer than the grains' span, so no
pair is found through it).
"""

import numpy as np
from scipy.spatial import cKDTree

#: the near shells' widths g/d (d the mean diameter = 1)
NEAR_GAPS = (0.01, 0.03, 0.1)


def pair_keys(id1, id2) -> np.ndarray:
    """One int64 per pair from its two grain ids (order-free; ids below 2**31)."""
    lo = np.minimum(id1, id2).astype(np.int64)
    hi = np.maximum(id1, id2).astype(np.int64)
    return (lo << 32) | hi


class NearPairs:
    """The internal pairs within the widest shell that do not touch, sorted by key: ``keys``, ``gap`` (d),
    ``normal`` (from the lower id's grain to the higher's) and ``middle_y`` (the gap's middle's height, d)."""

    def __init__(self, keys, gap, normal, middle_y):
        order = np.argsort(keys, kind="stable")
        self.keys, self.gap = keys[order], gap[order]
        self.normal, self.middle_y = normal[order].reshape(-1, 3), middle_y[order]

    @classmethod
    def empty(cls):
        return cls(np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros((0, 3)), np.zeros(0))

    def gap_of(self, keys) -> np.ndarray:
        """The gap of each of ``keys`` among these pairs, ``inf`` for a pair that is not one of them."""
        return gap_of(self.keys, self.gap, keys)


def gap_of(sorted_keys, gaps, keys) -> np.ndarray:
    """The gap of each of ``keys`` among the pairs ``sorted_keys`` (sorted, unique) with ``gaps``, ``inf`` for a pair
    that is not one of them."""
    out = np.full(len(keys), np.inf)
    if len(sorted_keys) == 0 or len(keys) == 0:
        return out
    at = np.minimum(np.searchsorted(sorted_keys, keys), len(sorted_keys) - 1)
    found = sorted_keys[at] == keys
    out[found] = gaps[at[found]]
    return out


def near_pairs(ids, pos, radius, width, touching_keys, widest=NEAR_GAPS[-1]) -> NearPairs:
    """The pairs of the grains ``ids`` (centres ``pos`` (m, 3), radii ``radius``; cell period ``width`` along e1
    and e3) within a gap ``widest`` of touching that are not among ``touching_keys`` (sorted, unique)."""
    if len(ids) < 2:
        return NearPairs.empty()
    wrapped = np.array(pos, dtype=float)
    for axis in (0, 2):
        wrapped[:, axis] = np.mod(wrapped[:, axis], width)
        wrapped[wrapped[:, axis] >= width, axis] = 0.0  # np.mod of a tiny negative is the period itself
    reach = 2 * float(np.max(radius)) + widest
    y_low = wrapped[:, 1].min()
    wrapped[:, 1] -= y_low
    height = float(wrapped[:, 1].max()) + 2 * reach + 1.0
    tree = cKDTree(wrapped, boxsize=(width, height, width))
    pairs = tree.query_pairs(reach, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    branch = wrapped[j] - wrapped[i]
    for axis in (0, 2):  # the minimum image
        branch[:, axis] -= width * np.round(branch[:, axis] / width)
    distance = np.sqrt(np.einsum("ci,ci->c", branch, branch))
    gap = distance - radius[i] - radius[j]
    keys = pair_keys(ids[i], ids[j])
    keep = (gap <= widest) & ~member(touching_keys, keys)
    i, j, branch, distance, gap, keys = i[keep], j[keep], branch[keep], distance[keep], gap[keep], keys[keep]
    normal = branch / distance[:, None]
    flip = ids[i] > ids[j]  # from the lower id's grain, whichever the tree listed first
    normal[flip] *= -1
    middle_y = wrapped[i, 1] + y_low + (radius[i] + gap / 2) * (branch[:, 1] / distance)
    return NearPairs(keys, gap, normal, middle_y)


def member(sorted_keys, keys) -> np.ndarray:
    """Whether each of ``keys`` is in ``sorted_keys`` (sorted, unique)."""
    if len(sorted_keys) == 0:
        return np.zeros(len(keys), dtype=bool)
    at = np.minimum(np.searchsorted(sorted_keys, keys), len(sorted_keys) - 1)
    return sorted_keys[at] == keys


def in_region(near: NearPairs, region) -> np.ndarray:
    """Which of the pairs have their gap's middle in the central region ``(lo, hi)`` (``lo <= y < hi``)."""
    return (near.middle_y >= region[0]) & (near.middle_y < region[1])


def shell_fabrics(near: NearPairs, inside) -> tuple[np.ndarray, np.ndarray]:
    """For each of ``NEAR_GAPS``: ``G_g`` (3x3, NaN for an empty shell) over the pairs of the shell among those
    ``inside`` (a mask), and their count."""
    fabrics, counts = np.full((len(NEAR_GAPS), 3, 3), np.nan), np.zeros(len(NEAR_GAPS), dtype=np.int64)
    for k, g in enumerate(NEAR_GAPS):
        n = near.normal[inside & (near.gap <= g)]
        counts[k] = len(n)
        if len(n):
            fabrics[k] = np.einsum("ci,cj->ij", n, n) / len(n) - np.eye(3) / 3
    return fabrics, counts
