"""The fidelity ladder of ``config/fidelity.toml`` (or a user's, ``make fidelity LADDER=...``): its runs, which of
them exist, and running the rest.

A rung is one axis value at one angle: a run of the ladder's preset with that value's overrides (values
equal to the preset's own are dropped, so the preset itself is one run shared by every axis). A run
*exists* when its compact summary is committed (``data/fidelity/<folder>/<name>.json``) or its DEM file
is in ``results/`` or the reference dataset; the rest run through the sweep machinery (``make -j``,
one Yade thread each, resumable from checkpoints).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

from model.cli import printable

from ... import io
from ... import spec as run_spec
from ...config import load_presets
from ...dataset import lookup, selection
from ...errors import SpecError
from ...paths import DATA_ROOTS, FIDELITY_LADDER, RESULTS_DIR, ROOT, first_existing
from ...runs.sweep.local import run_local
from ...runs.sweep.plan import MAX_TASKS, Sweep, Task, make_sweep, write_plan
from ...runs.sweep.slurm import load_cluster_config, submit

SUMMARY_DIR = ROOT / "data" / "fidelity"


@dataclass(frozen=True)
class Rung:
    axis: str
    overrides: dict  # the axis value, as written in the ladder
    theta_deg: float
    spec: dict

    @property
    def relative(self) -> Path:
        """``<folder>/dem/<name>.h5``: where the run lives under a data root."""
        return Path(self.spec.folder, "dem", f"{self.spec.name}.h5")

    @property
    def label(self) -> str:
        return " ".join(f"{k}={v:g}" for k, v in self.overrides.items())


#: the largest ladder file read (the project's is 2 kB)
MAX_LADDER_BYTES = 1 << 20


def load(path: Path = FIDELITY_LADDER) -> dict:
    try:
        ladder = tomllib.loads(io.read_text(path, MAX_LADDER_BYTES))
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise SpecError(f"{path}: cannot read the ladder ({printable(exc)})") from None
    if "preset" not in ladder or not ladder.get("axes"):
        raise SpecError(f"{path}: a ladder needs a preset and at least one axis")
    if ladder["preset"] not in load_presets():
        raise SpecError(f"{path}: preset {ladder['preset']!r} is not one of {', '.join(load_presets())}")
    for axis, entry in ladder["axes"].items():
        if not isinstance(entry, dict) or not entry.get("values") or "thetas" not in {*entry, *ladder}:
            raise SpecError(f"{path}: axis {axis} needs values, and thetas (its own or the ladder's)")
    return ladder


def rungs(ladder: dict, engine: str = run_spec.DEFAULT_ENGINE, source: str = FIDELITY_LADDER.name) -> list[Rung]:
    """Every rung in ``engine``, each validated as ``make dem`` would (a bad value is an error naming ``source``,
    the ladder's file, before anything runs)."""
    preset = ladder["preset"]
    defaults = load_presets()[preset]
    out = []
    for axis, entry in ladder["axes"].items():
        for value in entry["values"]:
            overrides = {k: float(v) for k, v in value.items() if float(v) != defaults.get(k)}
            for theta in entry.get("thetas", ladder["thetas"]):
                try:
                    spec = run_spec.resolve(theta, preset, overrides=overrides, engine=engine)
                except SpecError as exc:
                    raise SpecError(f"{source}, axis {axis}, {value}: {exc}") from None
                out.append(Rung(axis, {k: float(v) for k, v in value.items()}, float(theta), spec))
    return out


def top_runs(ladder: dict, roots: tuple[Path, ...] = DATA_ROOTS) -> tuple[str, list[Path]]:
    """The top rung (``[top]``): the label of the data set of its preset and the DEM files of its runs at its
    angles (every seed, the default rotation), found as ``make fit`` finds them; none where no ``[top]``."""
    top = ladder.get("top")
    if not top:
        return "", []
    chosen = selection.data_set(top["preset"], roots=roots)
    thetas = [float(t) for t in top.get("thetas", ladder["thetas"])]
    return chosen.label, sorted(r.path for theta in thetas for r in lookup.seed_runs(chosen, theta, roots))


def summary_path(rung: Rung, root: Path = SUMMARY_DIR) -> Path:
    return root / rung.spec.folder / f"{rung.spec.name}.json"


def dem_file(rung: Rung, roots: tuple[Path, ...] = DATA_ROOTS) -> Path | None:
    return first_existing(rung.relative, roots)


def missing(all_rungs: list[Rung], summaries: Path = SUMMARY_DIR, roots: tuple[Path, ...] = DATA_ROOTS) -> list[Rung]:
    """The runs that have neither a summary nor a DEM file, each once."""
    out = {}
    for r in all_rungs:
        if not summary_path(r, summaries).exists() and dem_file(r, roots) is None:
            out.setdefault(r.relative, r)
    return list(out.values())


def sweep_of(to_run: list[Rung], preset: str, results: Path = RESULTS_DIR) -> Sweep:
    """The runs to make as a sweep (``pipeline.runs.sweep``): its plan, folder and local or SLURM launch."""
    tasks = [Task(f"{r.theta_deg:g}", preset, None, tuple(f"{k}={v:g}" for k, v in sorted(r.spec.overrides.items())),
                  run_spec.output_path(r.spec, results), r.spec.label(), r.spec.engine) for r in to_run]
    return make_sweep("fidelity", preset, tasks, results)


def make_runs(to_run: list[Rung], preset: str, launch: str, jobs: int, allow_many: bool, source: Path) -> str:
    """The ladder's missing runs made as one sweep, here (``jobs`` side by side) or submitted to SLURM: "made" or
    "submitted". More than ``MAX_TASKS`` runs only when ``allow_many``."""
    if len(to_run) > MAX_TASKS and not allow_many:
        raise SpecError(f"the ladder {source} asks for {len(to_run)} runs, more than {MAX_TASKS}: MANY=1 "
                        "(--allow-many) if you mean it")
    sweep = sweep_of(to_run, preset)
    write_plan(sweep)
    print(f"running {len(to_run)} ladder run(s) as sweep {sweep.ident} ({launch}; make sweep-status "
          f"SWEEP={sweep.ident})", flush=True)
    if launch == "slurm":
        submit(sweep, load_cluster_config())
        return "submitted"
    run_local(sweep, jobs)
    return "made"
