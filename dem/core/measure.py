"""In-situ measurements of the Couette cell from contact and grain arrays (numpy only).

Used inside Yade by ``dem/yade/scene.py`` and tested in the project venv against hand-computed
contact sets. Conventions (README): stress is tension-positive; walls are normal to e2, so every
region and bin is a slab ``lo <= y < hi`` spanning the periodic cell (area ``W^2``).

Contact arrays (one row per real contact):
``id1, id2`` body ids; ``normal`` unit vector from body 1 to body 2; ``point`` contact point;
``force`` total contact force on body 2 (normal + tangential; body 1 gets ``-force``);
``branch`` centre-to-centre distance (r1 + r2 - overlap for spheres).
Grain arrays: ``pos, vel`` (m, 3), ``radius, mass`` (m,).
"""

from __future__ import annotations

import numpy as np

IDENTITY = np.eye(3)


def slab_volume(y, radius, lo, hi):
    """Volume of each sphere (centre height ``y``, radius ``radius``) inside the slab ``lo <= y < hi``."""
    u1 = np.clip(lo - y, -radius, radius)
    u2 = np.clip(hi - y, -radius, radius)
    r2 = radius * radius
    return np.pi * ((r2 * u2 - u2**3 / 3) - (r2 * u1 - u1**3 / 3))


def love_weber_stress(normal, branch, force, volume):
    """Contact (Love-Weber) stress ``sigma_ij = -(1/V) sum_c l_i f_j``, tension positive.

    ``l = branch * normal`` points from body 1 to body 2 and ``f`` is the force on body 2, so a
    repulsive contact (``f`` along ``+normal``) contributes compression (negative).
    """
    if len(branch) == 0:
        return np.zeros((3, 3))
    lever = normal * branch[:, None]
    return -np.einsum("ci,cj->ij", lever, force) / volume


def kinetic_stress(mass, velocity_fluctuation, volume):
    """Kinetic (Reynolds) stress ``-(1/V) sum_b m v' v'``, tension positive."""
    return -np.einsum("b,bi,bj->ij", mass, velocity_fluctuation, velocity_fluctuation) / volume


def fabric(normal):
    """Deviatoric fabric tensor of Eq. 8: ``A = <n n> - I/3`` (NaN when there is no contact)."""
    if len(normal) == 0:
        return np.full((3, 3), np.nan)
    return np.einsum("ci,cj->ij", normal, normal) / len(normal) - IDENTITY / 3


def velocity_gradient(y, velocity, mass):
    """Mass-weighted least-squares slope ``dv/dy`` (3,) of grain velocities against height."""
    if len(y) < 2:
        return np.full(3, np.nan)
    w = mass / mass.sum()
    y_mean = w @ y
    dy = y - y_mean
    denom = w @ (dy * dy)
    if denom <= 0:
        return np.full(3, np.nan)
    return (w * dy) @ velocity / denom


def in_slab(y, lo, hi):
    return (y >= lo) & (y < hi)


def measure(contacts: dict, grains: dict, first_grain_id: int, area: float,
            region: tuple[float, float], edges: np.ndarray) -> dict:
    """One sample: central-region averages and profiles across the gap.

    ``region = (lo, hi)`` heights of the central slab; ``edges`` (nb + 1,) bin edges of the
    profiles. Returns a dict of arrays (see ``dem/yade/scene.py`` for the stored names and units).
    """
    id1, id2 = contacts["id1"], contacts["id2"]
    normal, point = contacts["normal"], contacts["point"]
    force, branch = contacts["force"], contacts["branch"]
    pos, vel = grains["pos"], grains["vel"]
    radius, mass = grains["radius"], grains["mass"]
    y = pos[:, 1]
    nb = len(edges) - 1
    internal = (id1 >= first_grain_id) & (id2 >= first_grain_id)

    # profiles across the gap: grains by centre, contacts by contact point
    grain_bin = np.clip(np.searchsorted(edges, y, side="right") - 1, -1, nb)
    contact_bin = np.searchsorted(edges, point[:, 1], side="right") - 1
    profile_velocity = np.full((nb, 3), np.nan)
    profile_packing = np.empty(nb)
    profile_stress = np.zeros((nb, 3, 3))
    profile_fabric = np.full((nb, 3, 3), np.nan)
    profile_contacts = np.zeros(nb, dtype=np.int64)
    fluctuation = np.zeros_like(vel)
    for k in range(nb):
        lo, hi = edges[k], edges[k + 1]
        volume = area * (hi - lo)
        in_bin = grain_bin == k
        if in_bin.any():
            mean_v = mass[in_bin] @ vel[in_bin] / mass[in_bin].sum()
            profile_velocity[k] = mean_v
            fluctuation[in_bin] = vel[in_bin] - mean_v
        profile_packing[k] = slab_volume(y, radius, lo, hi).sum() / volume
        c_in = contact_bin == k
        profile_stress[k] = (love_weber_stress(normal[c_in], branch[c_in], force[c_in], volume)
                             + kinetic_stress(mass[in_bin], fluctuation[in_bin], volume))
        ci = c_in & internal
        profile_contacts[k] = ci.sum()
        if profile_contacts[k]:
            profile_fabric[k] = fabric(normal[ci])

    # central region
    lo, hi = region
    volume = area * (hi - lo)
    g_in = in_slab(y, lo, hi)
    c_in = in_slab(point[:, 1], lo, hi)
    c_fab = c_in & internal
    grain_ids = grains["id"]
    counts = np.bincount(np.concatenate([id1, id2]), minlength=int(grain_ids.max()) + 1 if len(grain_ids) else 0)
    n_grains = int(g_in.sum())
    return {
        "stress_contact": love_weber_stress(normal[c_in], branch[c_in], force[c_in], volume),
        "stress_kinetic": kinetic_stress(mass[g_in], fluctuation[g_in], volume),
        "fabric": fabric(normal[c_fab]),
        "contacts": int(c_fab.sum()),
        "grains": n_grains,
        "coordination": counts[grain_ids[g_in]].sum() / n_grains if n_grains else np.nan,
        "packing_fraction": slab_volume(y, radius, lo, hi).sum() / volume,
        "velocity_gradient": velocity_gradient(y[g_in], vel[g_in], mass[g_in]),
        "profile_velocity": profile_velocity,
        "profile_packing_fraction": profile_packing,
        "profile_stress": profile_stress,
        "profile_fabric": profile_fabric,
        "profile_contacts": profile_contacts,
    }
