"""Which runs a fit takes and where it writes: the data set's reversals, its other angles (or some of them) and
the runs it leaves out, and the fit's folder beside the data set's other fits."""

from __future__ import annotations

from ..dataset.lookup import every_seed, other_angles, reversals_of
from ..errors import CalibrationError
from . import global_fit


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


def folder_name(angles: list[float] | None, jackknife: str, fit_from: float, stress: str,
                weight: str = global_fit.WEIGHT_DEFAULT) -> str:
    """The fit's folder in the data set's results: ``fit`` (``make fit`` keeps its options in ``fit/options.txt``),
    or beside it ``fit-angles-<thetas>`` or ``fit-jackknife-<over>``, with ``-from<FIT_FROM>``, ``-<STRESS>`` and
    ``-per-angle`` (``WEIGHT=angles``) when not the defaults, so that no fit replaces another's files."""
    if angles:
        name = "fit-angles-" + "-".join(f"{theta:g}" for theta in angles)
    elif jackknife:
        name = f"fit-jackknife-{jackknife}"
    else:
        return "fit"
    return name + (f"-from{fit_from:g}" if fit_from else "") + (
        f"-{stress}" if stress != global_fit.STRESS_DEFAULT else "") + (
        f"-per-{weight.removesuffix('s')}" if weight != global_fit.WEIGHT_DEFAULT else "")


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
