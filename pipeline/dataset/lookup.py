"""Which DEM runs a stage uses: the files of a data set (``selection.DataSet``), results/ first, then the committed
data."""

from __future__ import annotations

import json
from pathlib import Path

from .. import spec as run_spec
from ..errors import PipelineError
from ..paths import DATA_ROOTS, preset_files
from .dem_file import DemRun, load
from .manifest import check_committed
from .selection import DataSet


def load_of_preset(path: Path, preset: str) -> DemRun:
    """The run at ``path``, which must be a run of ``preset`` by its own provenance (a file copied into
    another preset's folder is refused, not fitted as that preset)."""
    check_committed(path)
    run = load(path)
    if run.spec.preset != preset:
        raise PipelineError(f"{path} is a run of preset {run.spec.preset!r} by its provenance, not of "
                            f"{preset!r}: move it to results/{run.spec.preset}/dem/")
    problems = run_spec.filing_problems(json.loads(run.provenance["spec_json"]), run.spec)
    if problems:
        raise PipelineError(f"{path}: its spec is not the run it names ({'; '.join(problems)}): it cannot stand for "
                            "that run")
    filed_as = f"{path.parent.parent.name}/{path.stem}"
    if filed_as != run.spec.label():
        raise PipelineError(f"{path} is the run {run.spec.label()} by its provenance, filed as {filed_as}: move it to "
                            f"{run.spec.folder}/dem/{run.spec.name}.h5 (a file under another run's name would stand "
                            "for that run)")
    return run


def preset_runs(chosen: DataSet, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The data set's runs at its first seed (``<folder>/dem/*.h5``): every angle and rotation."""
    runs = [load_of_preset(p, chosen.preset) for p in preset_files(chosen.folder, roots, variants=False)]
    return [skipped(r, chosen) for r in runs if chosen.matches(r.engine, r.overrides)]


def skipped(run: DemRun, chosen: DataSet) -> DemRun:
    """``run`` without the data set's first ``skip_cycles`` cycles; a run with no cycle left is a one-line error."""
    if chosen.skip_cycles >= run.spec.n_cycles:
        raise PipelineError(f"skip_cycles={chosen.skip_cycles}: {run.path} has {run.spec.n_cycles} cycle(s), so none "
                            "would be left")
    return run.without_first_cycles(chosen.skip_cycles)


def _of_data_set(chosen: DataSet, roots: tuple[Path, ...], read=lambda path: True) -> list[DemRun]:
    """The data set's runs at every seed (of the files ``read(path)`` keeps, decided before loading): its own
    folder's and every ``<preset>[-<engine>]-<hash>`` variant's whose overrides are the data set's besides the
    seed."""
    folder = run_spec.run_folder(chosen.preset, chosen.engine)
    runs = [load_of_preset(p, chosen.preset) for p in preset_files(folder, roots) if read(p)]
    return [skipped(r, chosen) for r in runs if chosen.matches(r.engine, r.overrides)]


def protocol_and_seed(run: DemRun) -> tuple[float, float, int]:
    """What tells a data set's runs apart: the angle, the rotation's strain and the seed."""
    return run.spec.theta_deg, run.spec.rotate_at_strain, run.spec.seed


def every_seed(chosen: DataSet, roots: tuple[Path, ...] = DATA_ROOTS, read=lambda path: True) -> list[DemRun]:
    """The data set's runs at every seed (of the files ``read(path)`` keeps), sorted by angle, rotation and seed."""
    return sorted(_of_data_set(chosen, roots, read), key=protocol_and_seed)


def other_seeds_of(chosen: DataSet, runs: list[DemRun], roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The data set's runs at every seed but those in ``runs`` (by protocol and seed), without loading ``runs``'
    files again: what the comparison of one seed's runs sets beside them."""
    loaded, taken = {r.path for r in runs}, {protocol_and_seed(r) for r in runs}
    return [r for r in every_seed(chosen, roots, lambda p: p not in loaded) if protocol_and_seed(r) not in taken]


def runs_at_seed(chosen: DataSet, seed: int, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The data set's runs of one ``seed``, every angle and rotation; none there is a one-line error naming the
    seeds that are."""
    every = every_seed(chosen, roots)
    runs = [r for r in every if r.spec.seed == seed]
    if every and not runs:
        raise PipelineError(f"seed={seed}: {chosen.label} has runs of seeds "
                            f"{', '.join(str(s) for s in sorted({r.spec.seed for r in every}))} only")
    return runs


def seed_runs(chosen: DataSet, theta_deg: float, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The data set's runs at ``theta_deg`` and the default rotation, every seed."""
    name = f"theta{int(round(theta_deg)):03d}.h5"
    return [r for r in _of_data_set(chosen, roots, lambda p: p.name == name)
            if r.default_rotation and r.spec.theta_deg == theta_deg]


def reversal_seeds(chosen: DataSet, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The data set's reversals (theta = 180, default rotation) at every seed."""
    return reversals_of(every_seed(chosen, roots))


def reversals_of(runs: list[DemRun]) -> list[DemRun]:
    """The reversals (theta = 180, default rotation) among ``runs``."""
    return [r for r in runs if r.is_reversal and r.default_rotation]


def other_angles(runs: list[DemRun]) -> list[DemRun]:
    """The runs at angles other than 180 degrees, rotated at half the period (the Sec. 3.3 cross-check)."""
    return [r for r in runs if not r.is_reversal and r.default_rotation]


def fit_runs(chosen: DataSet, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """What the global fit uses: the data set's reversals, then its other angles at the default rotation, every
    seed of each."""
    every = every_seed(chosen, roots)
    return [*reversals_of(every), *other_angles(every)]
