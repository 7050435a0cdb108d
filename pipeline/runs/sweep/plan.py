"""A sweep's plan: every run (angles x rotations x seeds of one preset), checked as ``make dem`` would check it,
kept as data in ``results/sweeps/<id>/plan.json``."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import sys
from dataclasses import dataclass
from pathlib import Path

from ... import io
from ... import spec as run_spec
from ...config import load_presets
from ...errors import PipelineError, SpecError
from ...paths import RESULTS_DIR, check_folder_name


@dataclass(frozen=True)
class Task:
    """One run of a sweep, as data: the launcher's theta, preset, rotation strain (None: half the period) and
    overrides (``key=value``), the HDF5 file it writes, a label and the DEM engine."""

    theta: str
    preset: str
    rotate_at: str | None
    overrides: tuple[str, ...]
    output: Path
    label: str
    engine: str = run_spec.DEFAULT_ENGINE

    @property
    def args(self) -> tuple[str, ...]:
        """The launcher's arguments (``python -m pipeline.runs run ...``)."""
        args = ("--theta", self.theta, "--preset", self.preset)
        args += ("--engine", self.engine) if self.engine != run_spec.DEFAULT_ENGINE else ()
        args += ("--rotate-at", self.rotate_at) if self.rotate_at is not None else ()
        return args + tuple(x for item in self.overrides for x in ("--set", item))

    @property
    def run_dir(self) -> Path:
        return self.output.with_suffix(".run")

    def spec(self) -> run_spec.DemSpec:
        """The run spec the launcher resolves from these arguments: what ``make dem`` with them would run."""
        overrides = run_spec.parse_overrides(list(self.overrides))
        return run_spec.resolve(self.theta, self.preset, self.rotate_at, overrides, engine=self.engine)

    def to_dict(self) -> dict:
        return {"theta": self.theta, "preset": self.preset, "rotate_at": self.rotate_at,
                "overrides": list(self.overrides), "output": str(self.output), "label": self.label,
                "engine": self.engine}


@dataclass(frozen=True)
class Sweep:
    ident: str
    folder: Path
    preset: str
    tasks: tuple[Task, ...]
    results: Path

    @property
    def job_name(self) -> str:
        return f"gb-{self.ident}"

    def data_set_settings(self) -> list[str]:
        """``PRESET=… ENGINE=… SET=…``: the make variables of the data set of the sweep's runs (their engine and the
        overrides they all share but the seed), for ``make sweep-collect``; checked as ``make dem`` checks them."""
        task = self.tasks[0]
        task.spec()
        shared = [o for o in task.overrides if o.partition("=")[0] != "seed"
                  and all(o in t.overrides for t in self.tasks)]
        return [f"PRESET={self.preset}", f"ENGINE={task.engine}", f"SET={' '.join(shared)}"]


def make_sweep(prefix: str, preset: str, tasks: list[Task], results: Path) -> Sweep:
    """A sweep of ``tasks``, its id ``<prefix>-<hash of the tasks>``."""
    digest = hashlib.sha1(json.dumps([t.args for t in tasks]).encode()).hexdigest()[:8]
    ident = f"{prefix}-{digest}"
    return Sweep(ident, results / "sweeps" / ident, preset, tuple(tasks), results)


def _words(text: str | None) -> list[str]:
    return [] if not text else text.replace(",", " ").split()


#: runs in one sweep above which it must be asked for (``--allow-many``, ``MANY=1``): a typo in THETAS or SEEDS
#: should not queue a thousand runs
MAX_TASKS = 200


def plan(preset: str, thetas: str, rotate_ats: str | None = None, seeds: str | None = None,
         overrides: list[str] = (), results: Path = RESULTS_DIR, allow_many: bool = False,
         engine: str = run_spec.DEFAULT_ENGINE) -> Sweep:
    """Every run of the sweep, each validated as ``make dem`` would validate it."""
    theta_list = _words(thetas)
    if not theta_list:
        raise SpecError("THETAS is empty: give the angles to run, e.g. THETAS=\"30 60 90\"")
    count = len(theta_list) * max(1, len(_words(rotate_ats))) * max(1, len(_words(seeds)))
    if count > MAX_TASKS and not allow_many:
        raise SpecError(f"the sweep has {count} runs, more than {MAX_TASKS}: MANY=1 (--allow-many) if you mean it")
    defaults = load_presets().get(preset, {})
    tasks = {}
    for theta in theta_list:
        for rotate_at in _words(rotate_ats) or [None]:
            for seed in _words(seeds) or [None]:
                items = list(overrides)
                if seed is not None and run_spec.parse_number("seed", seed) != defaults.get("seed"):
                    items.append(f"seed={seed}")
                task = Task(theta, preset, rotate_at, tuple(items), Path(), "", engine)
                spec = task.spec()
                output = run_spec.output_path(spec, results)
                tasks[output] = dataclasses.replace(task, output=output, label=spec.label())
    return make_sweep(preset, preset, list(tasks.values()), results)


def write_plan(sweep: Sweep) -> None:
    io.write_json(sweep.folder / "plan.json", {
        "id": sweep.ident, "preset": sweep.preset, "results": str(sweep.results),
        "tasks": [t.to_dict() for t in sweep.tasks]})
    io.write_text(sweep.results / "sweeps" / "latest", sweep.ident + "\n")


def read_plan(results: Path = RESULTS_DIR, ident: str | None = None) -> Sweep:
    if ident is None:
        latest = results / "sweeps" / "latest"
        if not latest.is_file():
            raise PipelineError(f"no sweep in {results / 'sweeps'}: run `make sweep` first")
        ident = latest.read_text(errors="replace").strip()
    check_folder_name(ident, "sweep")
    path = results / "sweeps" / ident / "plan.json"
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        raise PipelineError(f"sweep {ident!r} has no readable plan ({path})") from None
    try:
        tasks = tuple(Task(str(t["theta"]), check_folder_name(t["preset"]), t["rotate_at"], tuple(t["overrides"]),
                           Path(t["output"]), str(t["label"]), str(t.get("engine", run_spec.DEFAULT_ENGINE)))
                      for t in data["tasks"])
        sweep = Sweep(str(data["id"]), path.parent, check_folder_name(data["preset"]), tasks, Path(data["results"]))
    except (KeyError, TypeError, AttributeError):
        raise PipelineError(f"sweep {ident!r}: {path} is not a plan of this version (make sweep again)") from None
    root = results.resolve()
    for task in sweep.tasks:
        if not task.output.resolve().is_relative_to(root) or any(
                not isinstance(x, str) for x in (task.rotate_at or "", *task.overrides)):
            raise PipelineError(f"sweep {ident!r}: {path} names a run outside {results} or a bad value "
                                f"({task.output}): make sweep again")
    return dataclasses.replace(sweep, results=results)


def launcher_command(task: Task, results: Path, threads: int = 1, ranks: int = 1) -> list[str]:
    return [sys.executable, "-m", "pipeline.runs", "run", *task.args, "--results", str(results),
            "--threads", str(threads), *(["--ranks", str(ranks)] if ranks > 1 else [])]
