"""The arguments a target hands its stages, read from the user's make variables (``pipeline.variables``): the data
set, the fit's options and the folders they name."""

from __future__ import annotations

from collections.abc import Callable

from .. import choices
from ..errors import PipelineError
from ..variables import ENGINES, Variables


def data_args(v: Variables) -> list[str]:
    """The data set of a stage: ``--preset``, ``--engine``, ``--set`` as given (the stage picks the default)."""
    preset, engine, skip = v.name("PRESET"), v.choice("ENGINE", ENGINES), v.whole("SKIP_CYCLES")
    return ([*(["--preset", preset] if preset else []), *(["--engine", engine] if engine else [])]
            + [a for s in v.settings("SET") for a in ("--set", s)] + (["--skip-cycles", skip] if skip else []))


def fit_options(v: Variables) -> list[str]:
    """``make fit``'s options: FIT_FROM, STRESS, WEIGHT, VARIANT (the stage checks their values against its
    choices)."""
    fit_from, stress = v.number("FIT_FROM"), v.choice("STRESS", choices.STRESSES)
    weight, variant = v.choice("WEIGHT", choices.WEIGHTS), v.name("VARIANT")
    return ([*(["--fit-from", fit_from] if fit_from else []), *(["--stress", stress] if stress else []),
             *(["--weight", weight] if weight else []), *(["--variant", variant] if variant else [])])


def fit_suffix(v: Variables) -> str:
    """The tail of the fit's and its comparison's folders (``pipeline.calibration.naming``): the fit's options and
    SKIP_CYCLES where they differ from their defaults."""
    from ..calibration import naming

    fit_from, stress, weight = v.number("FIT_FROM"), v.choice("STRESS", choices.STRESSES), v.choice("WEIGHT",
                                                                                                  choices.WEIGHTS)
    return naming.suffix(float(fit_from or 0), stress or naming.STRESS_DEFAULT, weight or naming.WEIGHT_DEFAULT,
                         v.name("VARIANT") or naming.LAW_DEFAULT, int(v.whole("SKIP_CYCLES") or 0))


def fit_paths(v: Variables) -> tuple[str, str]:
    """The fit's and its comparison's folders of the data set the variables name."""
    folder, tail = data_set_of(v).folder, fit_suffix(v)
    return f"results/{folder}/fit{tail}", f"results/{folder}/compare{tail}"


def across_args(v: Variables) -> list[str]:
    """``make models``' ACROSS: the other data sets (``PRESET[:ENGINE]``, space-separated) to predict and be
    predicted by."""
    return [a for item in v.presets_engines("ACROSS") for a in ("--across", item)]


def laws_args(v: Variables) -> list[str]:
    """``make models``' LAWS: the fabric laws judged, comma-separated (the stage checks the names)."""
    laws = v.names("LAWS")
    return ["--laws", ",".join(laws)] if laws else []


def weight_option(v: Variables) -> list[str]:
    weight = v.choice("WEIGHT", choices.WEIGHTS)
    return ["--weight", weight] if weight else []


def points_option(v: Variables) -> list[str]:
    """POINTS, where given (the stage holds the default)."""
    points = v.whole("POINTS")
    return ["--points", points] if points else []


def names_option(v: Variables) -> list[str]:
    """``make fit-profile``'s NAMES: the parameters profiled, comma-separated (the stage checks the names)."""
    names = v.names("NAMES")
    return ["--names", ",".join(names)] if names else []


def sweep_id(v: Variables) -> list[str]:
    ident = v.name("SWEEP")
    return ["--sweep", ident] if ident else []


def needs(v: Variables, name: str, example: str, check: Callable[[str], str | None]) -> str:
    """A variable the target cannot do without: checked, or a one-line error that shows an example."""
    value = check(name)
    if value is None:
        raise PipelineError(f"{name} is empty: give it, e.g. {example}")
    return value


def data_set_of(v: Variables):
    """The data set that PRESET, ENGINE and SET name (``pipeline.dataset.selection``), checked."""
    from .. import spec as run_spec
    from ..dataset import selection

    preset = v.name("PRESET")
    return selection.data_set(preset or selection.most_faithful_preset(), v.choice("ENGINE", ENGINES),
                              run_spec.parse_overrides(v.settings("SET")))
