"""The table of the user's targets: each target's stages (``Call``: ``python -m <module> <argv...>``) built from the
make variables."""

from __future__ import annotations

import dataclasses
import shlex
from collections.abc import Callable
from pathlib import Path

from .. import choices
from ..engines import DEFAULT_ENGINE
from ..errors import PipelineError
from ..paths import FIDELITY_LADDER, ROOT, fidelity_output
from ..variables import ENGINES, Variables
from .arguments import (
    across_args,
    data_args,
    data_set_of,
    fit_options,
    fit_paths,
    fit_suffix,
    laws_args,
    names_option,
    needs,
    points_option,
    sweep_id,
    weight_option,
)


@dataclasses.dataclass(frozen=True)
class Call:
    """One stage: ``python -m <module> <argv...>``."""

    module: str
    argv: tuple[str, ...] = ()

    def __str__(self) -> str:
        return shlex.join(["python", "-m", self.module, *self.argv])




def compare(v: Variables) -> list[Call]:
    fit_dir, compare_dir = fit_paths(v)
    return [Call("pipeline.comparison", (*data_args(v), "--params", f"{fit_dir}/params.json", "--out", compare_dir))]


def figures(v: Variables) -> list[Call]:
    """Figs. 3-9 and report.md: in the data set's folder for the default fit, in its comparison's folder for a fit
    with other options (so that neither replaces the other's)."""
    fit_dir, compare_dir = fit_paths(v)
    out = compare_dir if fit_suffix(v) else str(Path(compare_dir).parent)
    return [Call("pipeline.figures", (*data_args(v), "--fit", fit_dir, "--compare", compare_dir, "--out", out))]


def dem(v: Variables) -> list[Call]:
    argv = ["run", "--theta", v.number("THETA", "180"), "--preset", v.name("PRESET", "quick"),
            "--engine", v.choice("ENGINE", ENGINES, DEFAULT_ENGINE), "--threads", v.whole("THREADS", "1")]
    rotate_at, ranks = v.number("ROTATE_AT"), v.whole("RANKS", "1")
    argv += ["--rotate-at", rotate_at] if rotate_at else []
    argv += [a for s in v.settings("SET") for a in ("--set", s)]
    argv += ["--fresh"] if v.flag("FRESH") else []
    argv += ["--allow-inertial"] if v.flag("ALLOW_INERTIAL") else []
    argv += ["--ranks", ranks] if ranks != "1" else []
    from .. import spec as run_spec

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
    argv += ["--launch", v.choice("LAUNCH", choices.LAUNCHES, "local")]
    argv += [a for s in v.settings("SLURM") for a in ("--slurm", s)]
    jobs, ranks = v.whole("JOBS"), v.whole("RANKS", "1")
    argv += ["--jobs", jobs] if jobs else []
    argv += ["--ranks", ranks] if ranks != "1" else []
    argv += ["--allow-many"] if v.flag("MANY") else []
    argv += ["--engine", v.choice("ENGINE", ENGINES, DEFAULT_ENGINE)]
    from ..runs.sweep.plan import plan

    plan(argv[2], argv[4], " ".join(rotate_ats), " ".join(seeds), v.settings("SET"), allow_many=v.flag("MANY"),
         engine=argv[-1])
    return [Call("pipeline.runs.sweep", tuple(argv))]


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
        *data_args(v), *fit_options(v), "--jackknife", v.choice("OVER", choices.JACKKNIFE_OVER, "seeds")))],
    "fit-angles": fit_angles,
    "fit-definitions": lambda v: [Call("pipeline.calibration.definitions", (*data_args(v), *weight_option(v)))],
    "fit-from": lambda v: [Call("pipeline.calibration.restart", (*data_args(v), *weight_option(v)))],
    "fit-profile": lambda v: [Call("pipeline.calibration.profile", (
        *data_args(v), "--strain", v.choice("STRAIN", choices.STRAINS, "nominal"),
        "--phi", v.choice("PHI", choices.PHIS, "gap"), *points_option(v), *names_option(v),
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
    "models": lambda v: [Call("pipeline.model_selection", (*data_args(v), *across_args(v), *laws_args(v))),
                         Call("pipeline.figures.models", data_args(v))],
    "stability": lambda v: [Call("pipeline.studies.stability", tuple(
        ["--cases", ",".join(v.names("CASES"))] if v.names("CASES") else []))],
}
