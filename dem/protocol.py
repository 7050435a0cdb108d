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
    return (time - t_shear0) * gamma_dot - spec["pre_strain"]


def direction_deg(s, spec):
    """Wall direction phi (degrees, from e1 towards e3) at strain ``s``."""
    if s < 0:
        return spec["theta_deg"]
    period = spec["period_strain"]
    within = s - period * math.floor(s / period + EPS)
    return 0.0 if within < spec["rotate_at_strain"] - EPS else spec["theta_deg"]


def end_strain(spec):
    """Strain at which the run ends: ``n_cycles`` whole periods after the preceding half period."""
    return spec["n_cycles"] * spec["period_strain"]


def sample_strain(index, spec):
    """Strain of sample ``index`` (0 at the start of the preceding half period)."""
    return index * spec["sample_strain"] - spec["pre_strain"]


def total_samples(spec):
    """Samples in a complete run, both ends included."""
    return int(round((spec["pre_strain"] + end_strain(spec)) / spec["sample_strain"])) + 1


def grain_count(spec):
    """Grains created: ``fill_packing_fraction`` W^2 H over the mean grain volume (diameters uniform in
    [d_min, d_max], so <d^3> = (d_max^4 - d_min^4) / (4 (d_max - d_min)))."""
    d_min, d_max = spec["diameter_min_d"], spec["diameter_max_d"]
    mean_volume = math.pi / 6 * (d_max**4 - d_min**4) / (4 * (d_max - d_min))
    return int(round(spec["fill_packing_fraction"] * spec["width_d"] ** 2 * spec["gap_d"] / mean_volume))
