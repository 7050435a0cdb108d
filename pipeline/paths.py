"""Every path of the project, derived from the repository root."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIG_DIR = ROOT / "config"
DEM_DIR = ROOT / "dem"
RESULTS_DIR = ROOT / "results"
REFERENCE_DIR = ROOT / "data" / "reference"  # committed DEM runs: used where results/ has none


def first_existing(relative: Path, roots: tuple[Path, ...]) -> Path | None:
    """``root / relative`` for the first root where it exists (results/ before the reference dataset)."""
    return next((root / relative for root in roots if (root / relative).exists()), None)
