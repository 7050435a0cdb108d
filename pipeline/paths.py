"""Every path of the project, derived from the repository root."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIG_DIR = ROOT / "config"
DEM_DIR = ROOT / "dem"
RESULTS_DIR = ROOT / "results"
REFERENCE_DIR = ROOT / "data" / "reference"  # committed DEM runs: used where results/ has none
SCENE = DEM_DIR / "couette.py"
