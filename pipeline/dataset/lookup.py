"""Which DEM runs a stage uses: the lookup of a preset's files (results/ first, then the committed data)."""

from __future__ import annotations

from pathlib import Path

from ..errors import PipelineError
from ..paths import DATA_ROOTS, preset_files
from .dem_file import DemRun, load


def load_of_preset(path: Path, preset: str) -> DemRun:
    """The run at ``path``, which must be a run of ``preset`` by its own provenance (a file copied into
    another preset's folder is refused, not fitted as that preset)."""
    run = load(path)
    if run.spec.get("preset") != preset:
        raise PipelineError(f"{path} is a run of preset {run.spec.get('preset')!r} by its provenance, not of "
                            f"{preset!r}: move it to results/{run.spec.get('preset')}/dem/")
    return run


def preset_runs(preset: str, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The runs of ``preset`` as it is (``<preset>/dem/*.h5``), every angle and rotation."""
    return [load_of_preset(p, preset) for p in preset_files(preset, roots, variants=False)]


def reversal_seeds(preset: str, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """The preset's reversals (theta = 180, default rotation): the preset's own and every
    ``<preset>-<hash>`` variant whose only override is the seed."""
    runs = [load_of_preset(p, preset) for p in preset_files(preset, roots) if p.name == "theta180.h5"]
    return [r for r in runs if r.is_reversal and r.default_rotation and set(r.overrides) <= {"seed"}]


def other_angles(runs: list[DemRun]) -> list[DemRun]:
    """The runs at angles other than 180 degrees, rotated at half the period (the Sec. 3.3 cross-check)."""
    return [r for r in runs if not r.is_reversal and r.default_rotation]


def fit_runs(preset: str, roots: tuple[Path, ...] = DATA_ROOTS) -> list[DemRun]:
    """What the global fit uses: the preset's reversal seeds, then its other angles at the default rotation."""
    return [*reversal_seeds(preset, roots), *other_angles(preset_runs(preset, roots))]
