"""The Couette cell's bodies, the same for every engine: the walls' sphere centres and the grains' loose start.

Cell: periodic along e1 and e3 (period W), walls normal to e2. Each wall is a rigid layer of spheres of diameter d:
a compact square layer plus, towards the grains, a checkerboard of spheres in its hollows (roughness). The "inner
plane" of a wall is the centre plane of that rough layer; the gap H is the distance between the two inner planes.
The grains' cloud is drawn by ``random_cloud``, numpy's reproduction of Yade's ``SpherePack.makeCloud`` (Debian's
Yade 2023.02a) bit for bit, so that a seed gives the same grains in every engine, with or without Yade, and the
committed runs' clouds are the ones drawn now.
"""

import math

import numpy as np

from dem.core.checks import WALL_RADIUS

ROUGH_HEIGHT = 1 / math.sqrt(2)  # rough layer above the compact layer (sphere in a square hollow)
Y_BOTTOM = 1.0  # height of the bottom wall's compact layer

#: a cloud that does not fit is tried again in a box this much taller, up to CLOUD_TRIES times
CLOUD_GROWTH, CLOUD_TRIES = 1.25, 6


def wall_centres(y_compact, towards, width):
    """Centres of a wall's spheres: the compact square layer at height ``y_compact``, then the rough checkerboard
    on the side ``towards`` (+1 up, -1 down)."""
    centres = [(i + 0.5, y_compact, k + 0.5) for i in range(width) for k in range(width)]
    y_rough = y_compact + towards * ROUGH_HEIGHT
    centres += [(i + 1.0, y_rough, k + 1.0) for i in range(width) for k in range(width) if (i + k) % 2 == 0]
    return centres


def initial_cloud(spec, n_grains, width, y_bottom):
    """The grains' loose start, ``(cloud, y_top)``: a random cloud at packing fraction ~0.35 between the walls'
    rough layers (a list of (centre, radius)), and the height of the top wall's compact layer that encloses it.
    Where a seed's cloud does not fit (random sequential placement stalls, about one seed in seven of the tiny
    cell), the box grows by a quarter and the cloud is drawn again, the random sequence going on; compaction takes
    the extra height out. A seed that fits at once gives the same cloud as ever."""
    d_min, d_max = spec.diameter_min_d, spec.diameter_max_d
    loose_gap = spec.gap_d * spec.fill_packing_fraction / 0.35
    lo = y_bottom + ROUGH_HEIGHT + WALL_RADIUS
    uniform = canonical_uniforms(int(spec.seed) + 1)
    for _ in range(CLOUD_TRIES):
        y_top = y_bottom + 2 * ROUGH_HEIGHT + loose_gap + d_max
        centres, radii = random_cloud((0.0, lo, 0.0), (width, y_top - ROUGH_HEIGHT - WALL_RADIUS, width),
                                      (d_min + d_max) / 4, (d_max - d_min) / (d_max + d_min), n_grains, uniform)
        if len(radii) == n_grains:
            return [(tuple(c), r) for c, r in zip(centres.tolist(), radii.tolist(), strict=True)], y_top
        loose_gap *= CLOUD_GROWTH
    raise RuntimeError(f"placed only {len(radii)} of {n_grains} grains in the initial cloud, in a box "
                       f"{CLOUD_GROWTH ** (CLOUD_TRIES - 1):.1f} times the usual height")


def canonical_uniforms(seed):
    """Uniform numbers in [0, 1) as C++'s ``std::uniform_real_distribution<double>`` draws them from
    ``std::mt19937(seed)`` (libstdc++'s ``generate_canonical``: two 32-bit outputs, the first the low part)."""
    bits = np.random.RandomState(seed)._bit_generator  # MT19937 seeded as std::mt19937(seed) is

    def uniform():
        low, high = bits.random_raw(2)
        u = (float(low) + float(high) * 4294967296.0) / 18446744073709551616.0
        return u if u < 1.0 else math.nextafter(1.0, 0.0)

    return uniform


#: tries to place one sphere before the cloud is given up (Yade's ``maxTry``)
MAX_TRIES = 1000


def random_cloud(lower, upper, r_mean, r_rel_fuzz, count, uniform):
    """Random sequential placement of ``count`` spheres in the box ``lower``-``upper``, as Yade's
    ``SpherePack.makeCloud(lower, upper, rMean, rRelFuzz, num, periodic=False)`` places them: radii
    r_mean (1 + r_rel_fuzz (2 q - 1)) with q = (count - i + 1/2) / (count + 1), largest first; each centre drawn
    uniformly (``uniform``) inside the box until it overlaps no sphere placed before, at most ``MAX_TRIES`` times.
    Returns ``(centres (k, 3), radii (k,))``, k < count where a sphere found no room."""
    lower = np.asarray(lower, dtype=float)
    size = np.asarray(upper, dtype=float) - lower
    centres, radii = np.empty((count, 3)), np.empty(count)
    for i in range(count):
        q = (float(count) - float(i) + 0.5) / (float(count) + 1.0)
        r = r_mean * (2 * (q - 0.5) * r_rel_fuzz + 1)
        reach = (radii[:i] + r) ** 2
        for _ in range(MAX_TRIES):
            c = [lower[a] + ((size[a] - 2 * r) * uniform() + r) for a in range(3)]
            d = centres[:i] - c
            if not np.any(reach >= (d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2]):
                centres[i], radii[i] = c, r
                break
        else:
            return centres[:i], radii[:i]
    return centres, radii
