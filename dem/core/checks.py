"""The checks that stop a run that goes wrong (pure numpy, no Yade): each returns a one-line diagnostic or None."""

import numpy as np

WALL_RADIUS = 0.5


def sample_problem(row, grain_ids, grain_pos, grain_vel, walls, gap0):
    """What is wrong with a sample, if anything: non-finite measurements or grains, a grain outside the
    walls (``walls`` = heights of the inner planes), or a gap that ran away from ``gap0``."""
    for key in ("stress_contact", "fabric", "packing_fraction", "gap"):
        if not np.all(np.isfinite(row[key])):
            return f"{key} is not finite at strain {row['strain']:.3f}"
    if not np.all(np.isfinite(grain_pos)) or not np.all(np.isfinite(grain_vel)):
        return f"NaN grain position or velocity at strain {row['strain']:.3f}"
    y_bottom, y_top = walls
    y = grain_pos[:, 1]
    out = np.flatnonzero((y < y_bottom - WALL_RADIUS) | (y > y_top + WALL_RADIUS))
    if len(out):
        return (f"{len(out)} grain(s) escaped the walls (first: id {grain_ids[out[0]]}, y = {y[out[0]]:.2f}, "
                f"walls at {y_bottom:.2f} and {y_top:.2f})")
    if not 0.5 * gap0 < row["gap"] < 1.5 * gap0:
        return f"wall gap ran away: {row['gap']:.2f} d (H0 = {gap0:.2f} d)"
    return None


def stress_alarm(error_mean, strain_off, interval, spec):
    """``(strain_off, problem)``: add up the strain of consecutive samples (each ``interval`` since the one
    before) whose mean wall-stress error exceeds ``stress_alarm``; a problem once they span
    ``stress_alarm_strain``, or at once when one sample's mean is off by more than twice ``stress_alarm``
    (a wall that the grains no longer hold)."""
    if abs(error_mean) <= spec.stress_alarm:
        return 0.0, None
    strain_off += interval
    if abs(error_mean) > 2 * spec.stress_alarm:
        return strain_off, (f"wall normal stress off target by {error_mean:+.0%} over one sample (more than twice "
                            f"the alarm level, {spec.stress_alarm:.0%})")
    if strain_off >= spec.stress_alarm_strain - 1e-9:
        return strain_off, (f"wall normal stress off target by {error_mean:+.0%} for {spec.stress_alarm_strain} "
                            "strain")
    return strain_off, None
