"""The user's make targets: Make hands their variables over as text, this module checks them, then calls the stages.

The Makefile turns every variable a user may set (``USER_VARIABLES`` there) into plain text that is never expanded
again, exports it, and never writes it into a recipe. ``python -m pipeline.targets TARGET`` reads those variables
from the environment, checks each one a target uses (one line naming the value, before any work) and runs the
target's stages in this process with argument lists, as ``python -m <stage> <arguments>`` would: no shell ever sees
a user's value. ``--plan`` prints the stages' command lines and runs nothing. ``makefile FILE GOAL...`` writes the
Makefile's include file of the goals asked for (``goals_makefile``); Debian's ``python3`` runs it before anything is
installed, so this module imports the standard library only (the stages are imported when they run).
"""

from __future__ import annotations

import dataclasses
import os
import re
import runpy
import shlex
import sys
from collections.abc import Callable, Mapping
from pathlib import Path

from dem.lammps import settings

from .engines import DEFAULT_ENGINE
from .engines import ENGINES as ENGINE_REGISTRY
from .errors import PipelineError
from .paths import FIDELITY_LADDER, ROOT, fidelity_output

#: what a flag variable (FRESH=1) may say
YES, NO = ("1", "yes", "true"), ("", "0", "no", "false")
_NUMBER = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")
_WHOLE = re.compile(r"[0-9]{1,9}")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
_SETTING = re.compile(r"[A-Za-z_][A-Za-z0-9_]*=[A-Za-z0-9_.:+-]+")
_DATA_SET = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*(/[A-Za-z0-9_.=+-]+)*")
_PATH = re.compile(r"[A-Za-z0-9_./-]+")


@dataclasses.dataclass(frozen=True)
class Call:
    """One stage: ``python -m <module> <argv...>``."""

    module: str
    argv: tuple[str, ...] = ()

    def __str__(self) -> str:
        return shlex.join(["python", "-m", self.module, *self.argv])


#: the longest value a make variable may hold (a long list of seeds or settings stays far below)
MAX_VALUE = 1000


class Variables:
    """The user's make variables (an environment), each read with the check of its kind; an empty one is not given."""

    def __init__(self, environ: Mapping[str, str]):
        self._environ = environ

    def text(self, name: str) -> str | None:
        value = self._environ.get(name, "")
        if len(value) > MAX_VALUE:
            raise PipelineError(f"{name}={value[:20]!r}... is {len(value)} characters long: no value needs more than "
                                f"{MAX_VALUE}")
        if "\n" in value or "\r" in value:
            raise PipelineError(f"{name}={value!r} holds a line break: give it on one line")
        return value if value.strip() else None

    def _one(self, name: str, pattern: re.Pattern, what: str, default: str | None) -> str | None:
        value = self.text(name)
        if value is None:
            return default
        if not pattern.fullmatch(value.strip()):
            raise PipelineError(f"{name}={value!r} is not {what}")
        return value.strip()

    def _many(self, name: str, pattern: re.Pattern, what: str, sep: str | None = None) -> list[str]:
        value = self.text(name)
        if value is None:
            return []
        words = [w.strip() for w in value.split(sep)] if sep else value.split()
        if not all(pattern.fullmatch(w) for w in words):
            raise PipelineError(f"{name}={value!r} is not {what}")
        return words

    def number(self, name: str, default: str | None = None) -> str | None:
        return self._one(name, _NUMBER, "a number", default)

    def whole(self, name: str, default: str | None = None) -> str | None:
        return self._one(name, _WHOLE, "a whole number", default)

    def name(self, name: str, default: str | None = None) -> str | None:
        return self._one(name, _NAME, "a name (letters, digits, _ . -)", default)

    def choice(self, name: str, choices: tuple[str, ...], default: str | None = None) -> str | None:
        value = self.text(name)
        if value is None:
            return default
        if value.strip() not in choices:
            raise PipelineError(f"{name}={value!r} is not {' or '.join(choices)}")
        return value.strip()

    def flag(self, name: str) -> bool:
        value = (self.text(name) or "").strip().lower()
        if value not in YES + NO:
            raise PipelineError(f"{name}={self.text(name)!r} is not 1 or empty")
        return value in YES

    def numbers(self, name: str) -> list[str]:
        return self._many(name, _NUMBER, "a list of numbers")

    def wholes(self, name: str) -> list[str]:
        return self._many(name, _WHOLE, "a list of whole numbers")

    def settings(self, name: str) -> list[str]:
        return self._many(name, _SETTING, "a list of key=value")

    def names(self, name: str, choices: tuple[str, ...] | None = None) -> list[str]:
        words = self._many(name, _NAME, "a comma-separated list of names", sep=",")
        if choices and not set(words) <= set(choices):
            raise PipelineError(f"{name}={self.text(name)!r} is not a comma-separated list of {', '.join(choices)}")
        return words

    def presets_engines(self, name: str) -> list[str]:
        pattern = re.compile(_NAME.pattern + "(:(" + "|".join(map(re.escape, ENGINES)) + "))?")
        return self._many(name, pattern, f"a list of PRESET[:ENGINE] (engines: {', '.join(ENGINES)})")

    def data_set(self, name: str) -> str | None:
        return self._one(name, _DATA_SET, "a data set (preset[/engine][/key=value...])", None)

    def path(self, name: str) -> str | None:
        return self._one(name, _PATH, "a run folder (letters, digits, _ . - /)", None)

    def lammps_settings(self, name: str, default: str) -> str:
        """LAMMPS commands separated by ``;``, each one that sets how LAMMPS runs (``dem.lammps.settings``), never one
        that runs a program or reads a file."""
        value = self.text(name)
        if value is None:
            return default
        try:
            settings.parse(value, name)
        except ValueError as exc:
            raise PipelineError(str(exc)) from None
        return value


ENGINES = tuple(ENGINE_REGISTRY)


def data_args(v: Variables) -> list[str]:
    """The data set of a stage: ``--preset``, ``--engine``, ``--set`` as given (the stage picks the default)."""
    preset, engine, skip = v.name("PRESET"), v.choice("ENGINE", ENGINES), v.whole("SKIP_CYCLES")
    return ([*(["--preset", preset] if preset else []), *(["--engine", engine] if engine else [])]
            + [a for s in v.settings("SET") for a in ("--set", s)] + (["--skip-cycles", skip] if skip else []))


def fit_options(v: Variables) -> list[str]:
    """``make fit``'s options: FIT_FROM, STRESS, WEIGHT, VARIANT (the stage checks their values against its
    choices)."""
    fit_from, stress = v.number("FIT_FROM"), v.choice("STRESS", ("shear", "all"))
    weight, variant = v.choice("WEIGHT", ("runs", "angles")), v.name("VARIANT")
    return ([*(["--fit-from", fit_from] if fit_from else []), *(["--stress", stress] if stress else []),
             *(["--weight", weight] if weight else []), *(["--variant", variant] if variant else [])])


def fit_suffix(v: Variables) -> str:
    """The tail of the fit's and its comparison's folders (``pipeline.calibration.naming``): the fit's options and
    SKIP_CYCLES where they differ from their defaults."""
    from .calibration import naming

    fit_from, stress, weight = v.number("FIT_FROM"), v.choice("STRESS", ("shear", "all")), v.choice("WEIGHT",
                                                                                                  ("runs", "angles"))
    return naming.suffix(float(fit_from or 0), stress or naming.STRESS_DEFAULT, weight or naming.WEIGHT_DEFAULT,
                         v.name("VARIANT") or naming.LAW_DEFAULT, int(v.whole("SKIP_CYCLES") or 0))


def fit_paths(v: Variables) -> tuple[str, str]:
    """The fit's and its comparison's folders of the data set the variables name."""
    folder, tail = data_set_of(v).folder, fit_suffix(v)
    return f"results/{folder}/fit{tail}", f"results/{folder}/compare{tail}"


def compare(v: Variables) -> list[Call]:
    fit_dir, compare_dir = fit_paths(v)
    return [Call("pipeline.comparison", (*data_args(v), "--params", f"{fit_dir}/params.json", "--out", compare_dir))]


def figures(v: Variables) -> list[Call]:
    """Figs. 3-9 and report.md: in the data set's folder for the default fit, in its comparison's folder for a fit
    with other options (so that neither replaces the other's)."""
    fit_dir, compare_dir = fit_paths(v)
    out = compare_dir if fit_suffix(v) else str(Path(compare_dir).parent)
    return [Call("pipeline.figures", (*data_args(v), "--fit", fit_dir, "--compare", compare_dir, "--out", out))]


def across_args(v: Variables) -> list[str]:
    """``make models``' ACROSS: the other data sets (``PRESET[:ENGINE]``, space-separated) to predict and be
    predicted by."""
    return [a for item in v.presets_engines("ACROSS") for a in ("--across", item)]


def laws_args(v: Variables) -> list[str]:
    """``make models``' LAWS: the fabric laws judged, comma-separated (the stage checks the names)."""
    laws = v.names("LAWS")
    return ["--laws", ",".join(laws)] if laws else []


def weight_option(v: Variables) -> list[str]:
    weight = v.choice("WEIGHT", ("runs", "angles"))
    return ["--weight", weight] if weight else []


def points_option(v: Variables) -> list[str]:
    """POINTS, where given (the stage holds the default)."""
    points = v.whole("POINTS")
    return ["--points", points] if points else []


def dem(v: Variables) -> list[Call]:
    argv = ["run", "--theta", v.number("THETA", "180"), "--preset", v.name("PRESET", "quick"),
            "--engine", v.choice("ENGINE", ENGINES, DEFAULT_ENGINE), "--threads", v.whole("THREADS", "1")]
    rotate_at, ranks = v.number("ROTATE_AT"), v.whole("RANKS", "1")
    argv += ["--rotate-at", rotate_at] if rotate_at else []
    argv += [a for s in v.settings("SET") for a in ("--set", s)]
    argv += ["--fresh"] if v.flag("FRESH") else []
    argv += ["--allow-inertial"] if v.flag("ALLOW_INERTIAL") else []
    argv += ["--ranks", ranks] if ranks != "1" else []
    from . import spec as run_spec

    run_spec.resolve(argv[2], argv[4], rotate_at, run_spec.parse_overrides(v.settings("SET")),
                     allow_inertial=v.flag("ALLOW_INERTIAL"), engine=argv[6])
    return [Call("pipeline.runs", tuple(argv))]


def sweep(v: Variables) -> list[Call]:
    thetas = v.numbers("THETAS")
    if not thetas:
        raise PipelineError('THETAS is empty: give the angles of the sweep, e.g. THETAS="30 60 90"')
    argv = ["run", "--preset", v.name("PRESET", "quick"), "--thetas", " ".join(thetas)]
    rotate_ats, seeds = v.numbers("ROTATE_ATS"), v.wholes("SEEDS")
    argv += ["--rotate-ats", " ".join(rotate_ats)] if rotate_ats else []
    argv += ["--seeds", " ".join(seeds)] if seeds else []
    argv += [a for s in v.settings("SET") for a in ("--set", s)]
    argv += ["--launch", v.choice("LAUNCH", ("local", "slurm"), "local")]
    argv += [a for s in v.settings("SLURM") for a in ("--slurm", s)]
    jobs, ranks = v.whole("JOBS"), v.whole("RANKS", "1")
    argv += ["--jobs", jobs] if jobs else []
    argv += ["--ranks", ranks] if ranks != "1" else []
    argv += ["--allow-many"] if v.flag("MANY") else []
    argv += ["--engine", v.choice("ENGINE", ENGINES, DEFAULT_ENGINE)]
    from .runs.sweep.plan import plan

    plan(argv[2], argv[4], " ".join(rotate_ats), " ".join(seeds), v.settings("SET"), allow_many=v.flag("MANY"),
         engine=argv[-1])
    return [Call("pipeline.runs.sweep", tuple(argv))]


def sweep_id(v: Variables) -> list[str]:
    ident = v.name("SWEEP")
    return ["--sweep", ident] if ident else []


def needs(v: Variables, name: str, example: str, check: Callable[[str], str | None]) -> str:
    """A variable the target cannot do without: checked, or a one-line error that shows an example."""
    value = check(name)
    if value is None:
        raise PipelineError(f"{name} is empty: give it, e.g. {example}")
    return value


def bench_dem(v: Variables) -> list[Call]:
    presets = v.names("PRESETS") or ["quick", "reduced", "paper"]
    engines = v.names("ENGINES", ENGINES) or [DEFAULT_ENGINE]
    sets = [a for s in v.settings("SET") for a in ("--set", s)]
    return [Call("pipeline.studies.bench_dem", ("--presets", ",".join(presets), "--engines", ",".join(engines),
                                                *sets, "--out", "results/bench"))]


def bench(v: Variables) -> list[Call]:
    """Every benchmark: the model's numerics, the material-point update (POINTS per update) and bench-dem's."""
    return [Call("pipeline.studies.bench_model", ("--out", "results/bench")),
            Call("pipeline.studies.bench_update", (*points_option(v), "--out", "results/bench")),
            *bench_dem(v)]


def bench_lammps_settings(v: Variables) -> list[Call]:
    a = v.lammps_settings("A", "atom_modify sort 0 0.0")
    b = v.lammps_settings("B", "atom_modify sort 1000 0.0")
    run_dir = needs(v, "RUN_DIR", "RUN_DIR=results/<data set>/dem/<run>.run (a LAMMPS run with a checkpoint)", v.path)
    return [Call("pipeline.studies.bench_lammps_settings", ("--run-dir", run_dir, "--a", a, "--b", b,
                                                            "--out", "results/bench"))]


def fidelity(v: Variables, run: bool) -> list[Call]:
    engine = v.choice("ENGINE", ENGINES, DEFAULT_ENGINE)
    ladder = v.path("LADDER") or str(FIDELITY_LADDER.relative_to(ROOT))
    out = fidelity_output(ROOT / ladder, engine).relative_to(ROOT)
    study = ("--run", "--jobs", v.whole("JOBS", "2"), *(["--allow-many"] if v.flag("MANY") else [])) if run else ()
    return [Call("pipeline.studies.fidelity", (*study, "--engine", engine, "--ladder", ladder, "--out", str(out))),
            Call("pipeline.figures.fidelity", ("--table", str(out / "table.json")))]


def versus(v: Variables) -> list[Call]:
    example = "A=paper/yade/inertial_number=0.001/n_cycles=2 B=paper/lammps/inertial_number=0.001"
    a, b = (needs(v, name, example, v.data_set) for name in ("A", "B"))
    return [Call("pipeline.studies.versus", ("--a", a, "--b", b, "--out", "results/versus"))]


def compare_seed(v: Variables) -> list[Call]:
    seed = needs(v, "SEED", "SEED=2 (the seed whose runs to compare)", v.whole)
    fit_dir, compare_dir = fit_paths(v)
    compare_dir = compare_dir.replace("/compare", f"/compare-seed{seed}", 1)
    return [Call("pipeline.comparison", (*data_args(v), "--seed", seed, "--params", f"{fit_dir}/params.json",
                                         "--out", compare_dir)),
            Call("pipeline.figures", (*data_args(v), "--fit", fit_dir, "--compare", compare_dir))]


def fit_angles(v: Variables) -> list[Call]:
    angles = v.numbers("ANGLES")
    if not angles:
        raise PipelineError('ANGLES is empty: give the angles to fit, e.g. ANGLES="180 90 60 30"')
    return [Call("pipeline.calibration", (*data_args(v), *fit_options(v), "--angles", *angles))]


def sweep_collect(v: Variables) -> list[Call]:
    """make figures on the latest sweep's data set: a sub-make with the sweep's own (checked) values."""
    return [Call("pipeline.runs.sweep", ("collect", *sweep_id(v)))]


#: target -> the stages it runs, from the user's variables
TARGETS: dict[str, Callable[[Variables], list[Call]]] = {
    "dem": dem,
    "sweep": sweep,
    "sweep-status": lambda v: [Call("pipeline.runs.sweep", ("status", *sweep_id(v)))],
    "sweep-collect": sweep_collect,
    "runs": lambda v: [Call("pipeline.runs.listing")],
    "fit": lambda v: [Call("pipeline.calibration", (*data_args(v), *fit_options(v)))],
    "fit-bootstrap": lambda v: [Call("pipeline.calibration", (
        *data_args(v), "--bootstrap", v.whole("BOOT", "100"), "--out", f"results/{data_set_of(v).folder}/fit-bootstrap"
    ))],
    "fit-jackknife": lambda v: [Call("pipeline.calibration", (
        *data_args(v), *fit_options(v), "--jackknife", v.choice("OVER", ("seeds", "angles"), "seeds")))],
    "fit-angles": fit_angles,
    "fit-definitions": lambda v: [Call("pipeline.calibration.definitions", (*data_args(v), *weight_option(v)))],
    "fit-from": lambda v: [Call("pipeline.calibration.restart", (*data_args(v), *weight_option(v)))],
    "fit-profile": lambda v: [Call("pipeline.calibration.profile", (
        *data_args(v), "--strain", v.choice("STRAIN", ("nominal", "bulk"), "nominal"),
        "--phi", v.choice("PHI", ("gap", "central"), "gap"), *points_option(v),
        *weight_option(v)))],
    "compare": compare,
    "compare-seed": compare_seed,
    "figures": figures,
    "fidelity": lambda v: fidelity(v, run=True),
    "fidelity-table": lambda v: fidelity(v, run=False),
    "profile-dem": lambda v: [Call("pipeline.studies.profile_dem", (
        "--presets", ",".join(v.names("PRESETS") or ["reduced", "paper"]), "--threads", v.whole("THREADS", "1")))],
    "bench": bench,
    "bench-dem": bench_dem,
    "bench-lammps-settings": bench_lammps_settings,
    "engines": lambda v: [Call("pipeline.studies.versus", (
        "--a", f"{v.name('PRESET', 'reduced')}/yade", "--b", f"{v.name('PRESET', 'reduced')}/lammps",
        "--out", "results/engines"))],
    "versus": versus,
    "cells": lambda v: [Call("pipeline.studies.versus", ("--a", "reduced", "--b", "paper", "--out", "results/cells"))],
    "data-card": lambda v: [Call("pipeline.dataset.card")],
    "jump": lambda v: [Call("pipeline.studies.jump")],
    "budget": lambda v: [Call("pipeline.studies.budget", data_args(v))],
    "models": lambda v: [Call("pipeline.calibration.model_selection", (*data_args(v), *across_args(v), *laws_args(v))),
                         Call("pipeline.figures.models", data_args(v))],
    "stability": lambda v: [Call("pipeline.studies.stability", tuple(
        ["--cases", ",".join(v.names("CASES"))] if v.names("CASES") else []))],
}


def data_set_of(v: Variables):
    """The data set that PRESET, ENGINE and SET name (``pipeline.dataset.selection``), checked."""
    from . import spec as run_spec
    from .dataset import selection

    preset = v.name("PRESET")
    return selection.data_set(preset or selection.most_faithful_preset(), v.choice("ENGINE", ENGINES),
                              run_spec.parse_overrides(v.settings("SET")))


DATA_GOALS = ("fit", "compare", "compare-seed", "figures")


def goals_makefile(v: Variables, goals: list[str]) -> str:
    """``results/.make/goals.mk``: CHECK_ERROR, the first bad value among the goals' variables (the Makefile's
    ``check`` stops on it, in one line, before anything runs); else, for fit, compare and figures, the data set's
    folder (DATA_SET) and every run file that may belong to it (DATA_RUNS), which their file rules need."""
    from .paths import preset_files, shown

    lines = [f"# the goals {' '.join(goals)}, their variables checked (python -m pipeline.targets makefile)"]
    try:
        for goal in goals:
            if goal not in DATA_GOALS:
                TARGETS[goal](v)
        if set(goals) & set(DATA_GOALS):
            fit_options_text(v)
            data_args(v)
            if "compare-seed" in goals:
                compare_seed(v)
            chosen = data_set_of(v)
            runs = [shown(p) for p in preset_files(chosen.preset)]
            lines += [f"DATA_SET := {chosen.folder}", f"DATA_RUNS := {' '.join(runs)}",
                      f"FIT_SUFFIX := {fit_suffix(v)}"]
    except PipelineError as exc:
        text = " ".join(str(exc).split()).replace("$", "$$").replace("#", "\\#").rstrip("\\")
        lines.append(f"CHECK_ERROR := {text}")
    return "\n".join(lines) + "\n"


def fit_options_text(v: Variables) -> str:
    """The options of ``make fit`` as one line (``results/<data set>/fit/options.txt``): a fit with other options
    is a new fit."""
    skip = v.whole("SKIP_CYCLES")
    return " ".join(fit_options(v) + (["--skip-cycles", skip] if skip else [])) + "\n"


def fit_stamp_text(v: Variables) -> str:
    """``options.txt``: the options of ``make fit`` (``fit_options_text``) and the SHA-256 of every run file that
    may belong to its data set, so that a changed run remakes the fit whatever its file time says."""
    from .dataset.manifest import sha256
    from .paths import preset_files, shown

    return fit_options_text(v) + "".join(f"{sha256(p)}  {shown(p)}\n" for p in preset_files(data_set_of(v).preset))


def write_if_changed(path: Path, text: str) -> None:
    """Rewrite ``path`` (atomically) only when its text changes, so that Make sees it changed only then."""
    if path.is_file() and path.read_text() == text:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def say_data_set(v: Variables) -> None:
    chosen = data_set_of(v)
    how = "" if v.name("PRESET") else ", the most faithful one with a reversal run; PRESET=... to choose"
    print(f"data set {chosen.folder} (preset {chosen.preset}{how})", flush=True)


#: the targets that name the data set they read before they start
SAYS_DATA_SET = {"fit", "fit-bootstrap", "fit-jackknife", "fit-angles", "fit-definitions", "fit-from", "fit-profile"}


def run(calls: list[Call]) -> int:
    """Each stage as ``python -m <module> <argv>`` would run it, in this process; the first failure stops."""
    for call in calls:
        sys.argv = [call.module, *call.argv]
        try:
            runpy.run_module(call.module, run_name="__main__", alter_sys=True)
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) or stop.code is None else 1
            if stop.code not in (None, 0):
                if not isinstance(stop.code, int):
                    print(stop.code, file=sys.stderr)
                return code
    return 0


def main(argv: list[str] | None = None, environ: Mapping[str, str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    v = Variables(os.environ if environ is None else environ)
    if argv[:1] == ["makefile"] and len(argv) >= 2 and all(g in TARGETS or g in DATA_GOALS for g in argv[2:]):
        write_if_changed(Path(argv[1]), goals_makefile(v, argv[2:]))
        return 0
    plan = argv[:1] == ["--plan"]
    rest = argv[1:] if plan else argv
    if rest[:1] == ["fit-options"] and len(rest) == 2:
        write_if_changed(Path(rest[1]), fit_stamp_text(v))
        return 0
    if len(rest) != 1 or rest[0] not in TARGETS:
        print(f"usage: python -m pipeline.targets [--plan] TARGET (one of {', '.join(TARGETS)}), or makefile FILE "
              "[GOAL ...]", file=sys.stderr)
        return 2
    try:
        calls = TARGETS[rest[0]](v)
        if plan:
            print("\n".join(map(str, calls)))
            return 0
        if rest[0] in SAYS_DATA_SET:
            say_data_set(v)
    except PipelineError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return run(calls)


if __name__ == "__main__":
    sys.exit(main())
