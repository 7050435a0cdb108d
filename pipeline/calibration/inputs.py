"""Which runs a fit takes: the data set's reversals, its other angles (or some of them) and the runs it leaves out
(where it writes: ``naming``)."""

from __future__ import annotations

from ..dataset.lookup import every_seed, other_angles, reversals_of
from ..errors import CalibrationError


def runs_of(chosen, angles: list[float] | None) -> tuple[list, tuple, tuple]:
    """``(reversals, cross, left_out)`` of the data set ``chosen``: its reversal runs at every seed, its runs at the
    other angles (only ``angles`` where given) and its runs that turn at another strain than half the period,
    which the global fit leaves out; no reversal is a one-line error that says which run to make."""
    every = every_seed(chosen)
    reversals, cross = reversals_of(every), tuple(other_angles(every))
    if not reversals:
        given = f' SET="{" ".join(chosen.settings)}"' if chosen.settings else ""
        raise CalibrationError(f"no reversal run of {chosen.label}: run `make dem THETA=180 "
                               f"PRESET={chosen.preset} ENGINE={chosen.engine}{given}` first")
    if angles:
        cross = only_angles(angles, reversals, cross)
    return reversals, cross, tuple(r for r in every if not r.default_rotation)


def only_angles(angles: list[float], reversals: list, cross: tuple) -> tuple:
    """The runs of ``cross`` at ``angles`` (degrees), after checking that each angle has a run and that the
    reversal (180) is among them: the global fit needs it."""
    present = {180.0} if reversals else set()
    present |= {r.theta_deg for r in cross}
    for theta in angles:
        if theta not in present:
            raise CalibrationError(f"angles: no run at theta = {theta:g} (the data set has "
                                   f"{', '.join(f'{t:g}' for t in sorted(present))})")
    if 180.0 not in angles:
        raise CalibrationError(f"angles={' '.join(f'{t:g}' for t in angles)}: the fit needs the reversal, 180")
    return tuple(r for r in cross if r.theta_deg in angles)
