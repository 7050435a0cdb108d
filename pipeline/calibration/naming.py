"""Where a fit writes, named by everything that sets its numbers (standard library only: the front door,
``pipeline.targets``, runs in Debian's python3 and names the Makefile's folders with it).

``fit``, ``fit-angles-<thetas>`` or ``fit-jackknife-<over>``, then the options that differ from their defaults, in a
fixed order: ``-from<FIT_FROM>``, ``-<STRESS>``, ``-per-angle`` (``WEIGHT=angles``), ``-<law>`` (``VARIANT``),
``-skip<SKIP_CYCLES>``. The comparison of a fit goes to ``compare`` with the same suffix, so that no law's or option's
fit, comparison or report replaces another's.
"""

#: the defaults of the fit's options (``pipeline.calibration.global_fit`` and ``model.params`` read them from here or
#: are held to them by ``tests/unit/test_selection.py``)
STRESS_DEFAULT = "shear"
WEIGHT_DEFAULT = "runs"
LAW_DEFAULT = "rk2025"


def suffix(fit_from: float = 0.0, stress: str = STRESS_DEFAULT, weight: str = WEIGHT_DEFAULT,
           variant: str = LAW_DEFAULT, skip_cycles: int = 0) -> str:
    """The options that differ from their defaults, as a folder name's tail ("" for none)."""
    return ((f"-from{fit_from:g}" if fit_from else "") + (f"-{stress}" if stress != STRESS_DEFAULT else "")
            + (f"-per-{weight.removesuffix('s')}" if weight != WEIGHT_DEFAULT else "")
            + (f"-{variant}" if variant != LAW_DEFAULT else "") + (f"-skip{skip_cycles}" if skip_cycles else ""))


def fit_folder(angles=None, jackknife: str = "", **options) -> str:
    """The fit's folder in the data set's results (``suffix``'s ``options``)."""
    if angles:
        name = "fit-angles-" + "-".join(f"{float(theta):g}" for theta in angles)
    elif jackknife:
        name = f"fit-jackknife-{jackknife}"
    else:
        name = "fit"
    return name + suffix(**options)
