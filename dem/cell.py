"""The Couette cell's bodies, the same for every engine: the walls' sphere centres and the grains' loose start.

Cell: periodic along e1 and e3 (period W), walls normal to e2. Each wall is a rigid layer of spheres of diameter d:
a compact square layer plus, towards the grains, a checkerboard of spheres in its hollows (roughness). The "inner
plane" of a wall is the centre plane of that rough layer; the gap H is the distance between the two inner planes.
The grains' cloud comes from Yade's ``SpherePack.makeCloud`` (imported when a cloud is drawn), so that a seed gives
the same grains in every engine.
"""

import math

from dem.checks import WALL_RADIUS

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
    cell), the box grows by a quarter and the cloud is drawn again; compaction takes the extra height out. A seed
    that fits at once gives the same cloud as ever."""
    from dem.yade_lib import pack

    d_min, d_max = spec["diameter_min_d"], spec["diameter_max_d"]
    loose_gap = spec["gap_d"] * spec["fill_packing_fraction"] / 0.35
    lo = y_bottom + ROUGH_HEIGHT + WALL_RADIUS
    for _ in range(CLOUD_TRIES):
        cloud = pack.SpherePack()
        y_top = y_bottom + 2 * ROUGH_HEIGHT + loose_gap + d_max
        made = cloud.makeCloud((0, lo, 0), (width, y_top - ROUGH_HEIGHT - WALL_RADIUS, width),
                               rMean=(d_min + d_max) / 4, rRelFuzz=(d_max - d_min) / (d_max + d_min), num=n_grains,
                               periodic=False, seed=int(spec["seed"]) + 1)
        if made == n_grains:
            return [(tuple(c), r) for c, r in cloud], y_top
        loose_gap *= CLOUD_GROWTH
    raise RuntimeError(f"placed only {made} of {n_grains} grains in the initial cloud, in a box "
                       f"{CLOUD_GROWTH ** (CLOUD_TRIES - 1):.1f} times the usual height")
