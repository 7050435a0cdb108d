"""Every path of the project, derived from the repository root, and the lookup of a preset's DEM files.

A preset's runs live in ``results/<preset>/dem/`` (the preset as it is) and ``results/<preset>-<hash>/dem/``
(with overrides); the committed reference dataset ``data/reference/`` has the same layout and is used
where ``results/`` has no file of that name.
"""

from __future__ import annotations

import re
from pathlib import Path

from .engines import DEFAULT_ENGINE
from .errors import PipelineError

ROOT = Path(__file__).resolve().parents[1]
CONFIG_DIR = ROOT / "config"
RESULTS_DIR = ROOT / "results"
DATA_DIR = ROOT / "data"  # committed: never written by a stage
REFERENCE_DIR = DATA_DIR / "reference"  # committed DEM runs: used where results/ has none
DATA_ROOTS = (RESULTS_DIR, REFERENCE_DIR)
FIDELITY_LADDER = CONFIG_DIR / "fidelity.toml"  # the project's fidelity ladder (`make fidelity`)

_FOLDER = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


def shown(path: Path) -> str:
    """``path`` relative to the project where it lies inside it, else absolute."""
    path = Path(path).resolve()
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def check_folder_name(name: str, what: str = "preset") -> str:
    """A preset (or run folder) name that stays inside ``results/``: letters, digits, ``_ . -``, no ``..``."""
    if not isinstance(name, str) or not _FOLDER.fullmatch(name) or ".." in name:
        raise PipelineError(f"{what} {name!r} is not a valid name (letters, digits, '_', '.', '-'; "
                            "it names a folder under results/)")
    return name


def first_existing(relative: Path, roots: tuple[Path, ...] = DATA_ROOTS) -> Path | None:
    """``root / relative`` for the first root where it exists (results/ before the reference dataset). A link
    there that leads nowhere, or in a loop, is an error, not a reason to fall back to the next root."""
    for root in roots:
        path = root / relative
        if path.is_symlink():
            try:
                path.resolve(strict=True)
            except (OSError, RuntimeError):
                raise PipelineError(f"{path} is a link that leads nowhere (or in a loop): remove or fix it") from None
        if path.exists():
            return path
    return None


def regular_file(path: Path) -> Path:
    """``path``, refused in one line naming it unless it is a regular file (or a link to one): a folder, a FIFO (whose
    reading would wait forever), a socket or a device found where a file is looked for is not data."""
    if path.is_symlink() and not path.exists():
        raise PipelineError(f"{path} is a link that leads nowhere (or in a loop): remove or fix it")
    if not path.is_file():
        kind = ("a folder" if path.is_dir() else "a FIFO" if path.is_fifo() else "a socket" if path.is_socket()
                else "a device" if path.is_block_device() or path.is_char_device() else "not a file")
        raise PipelineError(f"{shown(path)} is {kind}, not a regular file: remove it")
    return path


def globbed(root: Path, pattern: str) -> list[Path]:
    """The files under ``root`` matching ``pattern``, sorted, hidden ones (a writer's temporaries) left out, each a
    regular file (``regular_file``)."""
    return [regular_file(p) for p in sorted(root.glob(pattern)) if not p.name.startswith(".")]


def preset_files(preset: str, roots: tuple[Path, ...] = DATA_ROOTS, variants: bool = True) -> list[Path]:
    """Every DEM file of ``preset`` (and, with ``variants``, of ``<preset>-<hash>``), one per relative path,
    results/ first; sorted by folder and name; each a regular file (``globbed``)."""
    check_folder_name(preset)
    patterns = [f"{preset}/dem/*.h5"] + ([f"{preset}-*/dem/*.h5"] if variants else [])
    relative = sorted({p.relative_to(root) for root in roots for pattern in patterns for p in globbed(root, pattern)},
                      key=lambda r: r.parts)
    return [first_existing(r, roots) for r in relative]


def preset_output(preset: str, *parts: str) -> Path:
    """``results/<preset>/<parts...>``, the preset name checked first."""
    return RESULTS_DIR.joinpath(check_folder_name(preset), *parts)


def fidelity_output(ladder: Path = FIDELITY_LADDER, engine: str = DEFAULT_ENGINE) -> Path:
    """``results/fidelity``: ``-<ladder's name>`` added for a ladder but the project's, ``-<engine>`` for an engine
    but the default."""
    name = "fidelity" + ("" if Path(ladder).resolve() == FIDELITY_LADDER.resolve() else f"-{Path(ladder).stem}")
    return RESULTS_DIR / (name + ("" if engine == DEFAULT_ENGINE else f"-{engine}"))
