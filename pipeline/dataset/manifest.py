"""The committed runs' checksums, machine-readable: ``data/reference/MANIFEST.sha256`` (``sha256sum``'s format: 64 hex
digits, two spaces, the file's path under the folder), written by ``make data-card`` beside the human data card.

The check fails closed. Under a folder that is committed data (``data/reference/``, or any folder holding a manifest),
a run file is believed only if it is a regular file, the manifest is readable and every row well formed, the file
has its row, and its SHA-256 is the row's: a missing or damaged manifest, a malformed or duplicated row, a file with
no row, a link or a changed file is a one-line error before the file is read.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import DemFileError
from ..io import atomic_path, sha256, write_bytes
from ..paths import REFERENCE_DIR, globbed

MANIFEST = "MANIFEST.sha256"
#: a row: the digest, two spaces, a relative path of plain names (no ``.`` or ``..`` part, no leading ``/``)
ROW = re.compile(r"([0-9a-f]{64})  ((?:[A-Za-z0-9_+-][A-Za-z0-9_.+-]*/)*[A-Za-z0-9_+-][A-Za-z0-9_.+-]*)")


def run_files(root: Path) -> list[Path]:
    """Every run file of a data folder: ``<root>/<folder>/dem/<name>.h5``."""
    return globbed(root, "*/dem/*.h5")


def read(root: Path) -> dict[str, str]:
    """``{path under root: SHA-256}`` of ``root``'s manifest; anything but a readable, well-formed one is an error."""
    path = root / MANIFEST
    try:
        if path.is_symlink() or not path.is_file():
            raise OSError("not a regular file")
        lines = path.read_text(encoding="ascii").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise DemFileError(f"{path} cannot be read ({exc}): restore it (git checkout) or make data-card") from None
    rows = {}
    for number, line in enumerate(lines, 1):
        match = ROW.fullmatch(line)
        if not match or ".." in match.group(2).split("/"):
            raise DemFileError(f"{path}:{number} is not a row of a manifest ({line[:80]!r})")
        if match.group(2) in rows:
            raise DemFileError(f"{path}:{number} lists {match.group(2)} a second time")
        rows[match.group(2)] = match.group(1)
    return rows


def write(root: Path) -> int:
    """Write ``root``'s manifest from its run files (atomically); how many it lists."""
    files = run_files(root)
    with atomic_path(root / MANIFEST, committed=True) as tmp:
        write_bytes(tmp, "".join(f"{sha256(p)}  {p.relative_to(root).as_posix()}\n" for p in files).encode("ascii"))
    return len(files)


def stale(root: Path) -> list[str]:
    """What differs between ``root``'s manifest and its run files (empty: up to date; an unreadable manifest is
    one difference)."""
    try:
        rows = read(root)
    except DemFileError as exc:
        return [str(exc)]
    files = {p.relative_to(root).as_posix(): p for p in run_files(root)}
    problems = [f"{name}: no file" for name in sorted(set(rows) - set(files))]
    problems += [f"{name}: no row" for name in sorted(set(files) - set(rows))]
    problems += [f"{name}: changed" for name in sorted(set(rows) & set(files)) if sha256(files[name]) != rows[name]]
    return problems


def data_root(path: Path) -> Path | None:
    """The committed data folder ``path`` (``<root>/<folder>/dem/<name>.h5``) lies in, or None (a results folder)."""
    root = path.parent.parent.parent
    if root.resolve() == REFERENCE_DIR.resolve() or (root / MANIFEST).exists() or (root / MANIFEST).is_symlink():
        return root
    return None


def check_committed(path: Path) -> None:
    """Refuse a run file of a committed data folder that its manifest does not vouch for (see the module), whether
    it is read there or through a link elsewhere (the manifest checks the resolved path's folder)."""
    if data_root(path) is not None and (path.is_symlink() or not path.is_file()):
        raise DemFileError(f"{path} is not a regular file: a committed run file is one (restore it: git checkout)")
    resolved = path.resolve()
    root = data_root(resolved)
    if root is None:
        return
    if not resolved.is_file():
        raise DemFileError(f"{path} is not a regular file: a committed run file is one (restore it: git checkout)")
    name = resolved.relative_to(root).as_posix()
    expected = read(root).get(name)
    if expected is None:
        raise DemFileError(f"{path} has no row in {root / MANIFEST}: a committed run file is listed there "
                           "(make data-card lists it)")
    if sha256(resolved) != expected:
        raise DemFileError(f"{path} does not match its SHA-256 in {root / MANIFEST}: it was changed or damaged; "
                           "restore it (git checkout) or, if the change is meant, make data-card")
