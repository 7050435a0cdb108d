"""The experiment as the scene sets it up and drives it (pure python, no Yade): grain count, strain,
wall direction and sampling of the Fig. 1 protocol.

Strain s = t*gamma_dot is measured from the start of the first period, so the preceding half period
at phi = theta has s in [-pre_strain, 0). In each period phi = 0 for (s mod T) < rotate_at and
phi = theta after; a boundary belongs to the segment it starts (README conventions).
"""

import math

EPS = 1e-12


def strain(time, t_shear0, gamma_dot, spec):
    """Strain t*gamma_dot from the start of the first period, at simulation time ``time``."""
    return (time - t_shear0) * gamma_dot - spec.pre_strain


def direction_deg(s, spec):
    """Wall direction phi (degrees, from e1 towards e3) at strain ``s``."""
    if s < 0:
        return spec.theta_deg
    period = spec.period_strain
    within = s - period * math.floor(s / period + EPS)
    return 0.0 if within < spec.rotate_at_strain - EPS else spec.theta_deg


def end_strain(spec):
    """Strain at which the run ends: ``n_cycles`` whole periods after the preceding half period."""
    return spec.n_cycles * spec.period_strain


def direction_changes(spec):
    """Strains at which the wall direction changes: theta -> 0 at the start of each period, 0 -> theta at
    ``rotate_at`` within it (a change by 0 degrees is none)."""
    if abs(spec.theta_deg) < EPS:
        return []
    period = spec.period_strain
    return [k * period + at for k in range(spec.n_cycles) for at in (0.0, spec.rotate_at_strain)]


def sample_strains(spec):
    """Strains of every sample, sorted: the regular grid every ``sample_strain`` from ``-pre_strain`` to the
    end (both included), plus every ``dense_sample_strain`` within ``dense_window_strain`` after each change
    of direction (the reversal jump). A dense sample within 1e-9 of a grid sample is that grid sample."""
    step = spec.sample_strain
    n_grid = int(round((spec.pre_strain + end_strain(spec)) / step)) + 1
    grid = [i * step - spec.pre_strain for i in range(n_grid)]
    dense = []
    window, fine = spec.dense_window_strain, spec.dense_sample_strain
    if window > 0 and fine > 0:
        for change in direction_changes(spec):
            n_fine = int(math.floor(window / fine + 1e-9))
            dense += [change + j * fine for j in range(1, n_fine + 1)]
    return merged(grid + [s for s in dense if s < end_strain(spec) - 1e-9])


def merged(strains):
    """``strains`` sorted, each within 1e-9 of the one before it dropped."""
    out = []
    for s in sorted(strains):
        if out and s - out[-1] < 1e-9:
            continue
        out.append(s)
    return out


def track_strains(spec):
    """Strains at which the contacts are tracked (``dem.core.budget``): every sample's, every change of direction's
    and every ``contact_track_strain`` from ``-pre_strain``, sorted, within 1e-9 of each other merged; none where
    ``contact_track_strain`` is 0 (the run records no contact budget)."""
    step = spec.contact_track_strain
    if step <= 0:
        return []
    end = end_strain(spec)
    n_grid = int(math.floor((spec.pre_strain + end) / step + 1e-9)) + 1
    grid = [i * step - spec.pre_strain for i in range(n_grid)]
    return merged(grid + sample_strains(spec) + [s for s in direction_changes(spec) if s < end - 1e-9])


def on_grid(strain, spec):
    """True where a sample taken at ``strain`` is one of the regular grid's (a multiple of ``sample_strain``
    from the start): nearer to a grid point than half the dense spacing. A sample lands up to one
    controller interval past its target, far less than that."""
    k = (strain + spec.pre_strain) / spec.sample_strain
    fine = spec.dense_sample_strain if spec.dense_window_strain > 0 else 0.0
    tol = 0.5 * min(fine / spec.sample_strain, 1.0) if fine > 0 else 0.5
    return abs(k - round(k)) < tol


def grain_count(spec):
    """Grains created: ``fill_packing_fraction`` W^2 H over the mean grain volume (diameters uniform in
    [d_min, d_max], so <d^3> = (d_max^4 - d_min^4) / (4 (d_max - d_min)))."""
    d_min, d_max = spec.diameter_min_d, spec.diameter_max_d
    mean_volume = math.pi / 6 * (d_max**4 - d_min**4) / (4 * (d_max - d_min))
    return int(round(spec.fill_packing_fraction * spec.width_d ** 2 * spec.gap_d / mean_volume))
