"""Which DEM runs a stage uses: the files of a data set (``selection.DataSet``), results/ first, then the committed
data."""

from __future__ import annotations

from pathlib import Path

from ..errors import PipelineError
from ..paths import DATA_ROOTS, preset_files
from ..runs.spec import ENGINES
from .dem_file import DemRun, load
from .selection import DataSet


def load_of_preset(path: Path, preset: str) -> DemRun:
    """The run at ``path``, which must be a run of ``preset`` by its own provenance (a file copied into
    another preset's folder is refused, not fitted as that preset)."""
    run = load(path)
    if run.spec.get("preset") != preset:
        raise PipelineError(f"{path} is a run of preset {run.spec.get('preset')!r} by its provenance, not of "
                            f"{preset!r}: move it to results/{run.spec.get('preset')}/dem/")
    return run


def engine_folder(preset: str, engine: str = ENGINES[0]) -> str:
    """The folder of a preset's runs in ``engine`` (``<preset>``, or ``<preset>-<engine>`` for another than Yade)."""
    if engine not in ENGINES:
        raise PipelineError(f"engine={engine!r} is not a DEM engine here (known: {', '.join(ENGINES)})")
    return preset if engine == ENGINES[0] else f"{preset}-{engine}"


def preset_runs(chosen: DataSet, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The data set's runs at its first seed (``<folder>/dem/*.h5``): every angle and rotation."""
    runs = [load_of_preset(p, chosen.preset) for p in preset_files(chosen.folder, roots, variants=False)]
    return [r for r in runs if chosen.matches(r.engine, r.overrides)]


def seed_runs(chosen: DataSet, theta_deg: float, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The data set's runs at ``theta_deg`` and the default rotation, every seed: its own folder's and every
    ``<preset>[-<engine>]-<hash>`` variant whose overrides are the data set's besides the seed."""
    name = f"theta{int(round(theta_deg)):03d}.h5"
    runs = [load_of_preset(p, chosen.preset) for p in preset_files(engine_folder(chosen.preset, chosen.engine), roots)
            if p.name == name]
    return [r for r in runs if chosen.matches(r.engine, r.overrides) and r.default_rotation
            and r.spec["theta_deg"] == theta_deg]


def reversal_seeds(chosen: DataSet, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The data set's reversals (theta = 180, default rotation) at every seed."""
    return [r for r in seed_runs(chosen, 180.0, roots) if r.is_reversal]


def other_angles(runs: list[DemRun]) -> list[DemRun]:
    """The runs at angles other than 180 degrees, rotated at half the period (the Sec. 3.3 cross-check)."""
    return [r for r in runs if not r.is_reversal and r.default_rotation]


def fit_runs(chosen: DataSet, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """What the global fit uses: the data set's reversal seeds, then its other angles at the default rotation."""
    return [*reversal_seeds(chosen, roots), *other_angles(preset_runs(chosen, roots))]
