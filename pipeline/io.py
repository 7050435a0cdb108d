"""Atomic output: every file appears complete under its name or not at all (temporary file, then rename)."""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import stat
import tempfile
from pathlib import Path

from .errors import PipelineError
from .paths import DATA_DIR, RESULTS_DIR, shown


@contextlib.contextmanager
def atomic_path(path: Path, committed: bool = False):
    """Yield a temporary path beside ``path`` (same suffix); renamed onto ``path`` on success, removed on error.
    ``committed``: a writer of the committed ``data/`` (the data card's table and manifest, the fidelity ladder's run
    summaries), the only ones that may write there."""
    with atomic_paths(path, committed=committed) as (tmp,):
        yield tmp


@contextlib.contextmanager
def atomic_paths(*paths: Path, committed: bool = False):
    """Temporary paths beside each of ``paths``, renamed onto them together once the block succeeds: a set of
    outputs appears complete, or the previous set stays (an interrupt or an error removes the temporaries)."""
    stack = contextlib.ExitStack()
    with stack:
        temps = [stack.enter_context(_temporary(Path(p), committed)) for p in paths]
        yield temps
        for tmp in temps:
            _sync(tmp)  # on disk before the renames: a crash leaves the old set or the new one
        for tmp, path in zip(temps, paths, strict=True):
            os.replace(tmp, path)
        for folder in {Path(p).parent for p in paths}:
            _sync(folder)


@contextlib.contextmanager
def h5_file(path: Path):
    """An HDF5 file to fill, built in memory and written to ``path`` with plain writes once complete: HDF5's own
    writes onto a full disk leave its objects broken (a cascade of errors, then a segmentation fault at exit),
    where a plain write raises one ``OSError`` that the command turns into one line."""
    import io as bytes_io

    import h5py

    check_destination(Path(path))
    buffer = bytes_io.BytesIO()
    with h5py.File(buffer, "w") as f:
        yield f
    write_bytes(path, buffer.getbuffer())


def sha256(path: Path) -> str:
    """The file's SHA-256, as 64 hex digits; read once per process while the file stays the same inode, size and
    change time (a stage checks a file against the manifest and then records it: one read)."""
    info = os.stat(path)
    return _sha256(os.path.realpath(path), info.st_ino, info.st_size, info.st_mtime_ns, info.st_ctime_ns)


@functools.lru_cache(maxsize=512)
def _sha256(path: str, *_identity) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def write_bytes(path: Path, data) -> None:
    """``data`` into ``path``; an error names the file (a failed ``write`` alone does not)."""
    try:
        with open(path, "wb") as fh:
            fh.write(data)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(path)) from None


def check_destination(path: Path, committed: bool = False) -> None:
    """The one check of where every output lands, before anything is written: refused in one line where ``results``
    is a link, where the path (every link on its way followed) lands inside the committed ``data/`` (but for the data
    card's and the fidelity summaries' writers, ``committed``), or where a path under ``results/`` lands outside it
    (through a link below it)."""
    absolute = Path(os.path.abspath(path))
    if absolute.is_relative_to(RESULTS_DIR) and os.path.islink(RESULTS_DIR):
        raise PipelineError(f"{RESULTS_DIR} is a link (to {os.readlink(RESULTS_DIR)}): outputs go to a folder "
                            "of the project's own; remove the link")
    resolved = absolute.resolve()
    if resolved.is_relative_to(DATA_DIR.resolve()) and not committed:
        raise PipelineError(f"{path} lands in {shown(resolved)}: the committed data is never written (a link on the "
                            "way leads there: remove it)")
    if absolute.is_relative_to(RESULTS_DIR) and not resolved.is_relative_to(RESULTS_DIR):
        raise PipelineError(f"{path} lands outside results/, in {resolved} (a link below results/ leads there: "
                            "remove it)")


def check_output_path(path: Path, committed: bool = False) -> None:
    """Refuse, in one line, an output that is a link or anything but a regular file (renaming onto a link replaces
    the link, as ``/dev/stdout``), and one that lands where no output goes (``check_destination``)."""
    if os.path.islink(path) or (os.path.lexists(path) and not path.is_file()):
        raise PipelineError(f"{path} is a link or not a regular file: an output goes to a file of its own")
    check_destination(Path(path), committed)


@contextlib.contextmanager
def _temporary(path: Path, committed: bool = False):
    """A hidden temporary beside ``path``, unique to this call (several writers of one path never share it),
    with ``path``'s suffix."""
    check_output_path(path, committed)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.tmp", suffix=path.suffix)
    os.fchmod(fd, 0o666 & ~_UMASK)  # the file a plain open() would make, not mkstemp's owner-only one
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
    finally:
        tmp.unlink(missing_ok=True)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _umask()


def _sync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_text(path: Path, text: str, committed: bool = False) -> Path:
    with atomic_path(path, committed=committed) as tmp:
        write_bytes(tmp, text.encode("utf-8"))
    return Path(path)


def json_text(data) -> str:
    """The project's JSON files: sorted keys, one-space indents, a final newline."""
    return json.dumps(data, indent=1, sort_keys=True) + "\n"


def write_json(path: Path, data, committed: bool = False) -> Path:
    return write_text(path, json_text(data), committed)


def write_table(out: Path, stem: str, data, markdown: str) -> Path:
    """A study's result as a set: ``<stem>.json`` (the data) and ``<stem>.md`` (its table), renamed into place
    together; returns the Markdown file's path."""
    paths = (Path(out) / f"{stem}.json", Path(out) / f"{stem}.md")
    with atomic_paths(*paths) as (js, md):
        js.write_text(json_text(data))
        md.write_text(markdown)
    return paths[1]


def write_params(path: Path, params, metadata: dict | None = None) -> Path:
    """A ``model.Params`` as JSON (``Params.to_json``, with ``metadata``), atomically."""
    return write_text(path, params.to_json(metadata))


#: the largest text file a stage reads (parameters, records, ladders: the largest, a fit's JSON, is about 200 kB)
MAX_TEXT_BYTES = 16 << 20


def read_bounded(path: Path, limit: int = MAX_TEXT_BYTES) -> bytes:
    """The bytes of ``path``, which must be a regular file (a FIFO would hang, a device never end) of at most
    ``limit`` bytes; else ``OSError`` with a message of one line."""
    info = os.stat(path)
    if not stat.S_ISREG(info.st_mode):
        raise OSError(f"{path} is not a regular file")
    with open(path, "rb") as fh:
        data = fh.read(limit + 1)
    if len(data) > limit:
        raise OSError(f"{path} is larger than {limit} bytes")
    return data


def read_text(path: Path, limit: int = MAX_TEXT_BYTES) -> str:
    """``read_bounded`` as UTF-8 text (an undecodable byte is an ``OSError`` too)."""
    try:
        return read_bounded(path, limit).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise OSError(f"{path} is not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def read_params(path: Path):
    """A ``model.Params`` from a JSON file; a missing or unreadable file is a one-line ``PipelineError``."""
    import model

    path = Path(path)
    try:
        text = read_text(path)
    except OSError as exc:
        raise PipelineError(f"{path}: cannot read parameters ({exc.strerror or exc})") from None
    return model.Params.from_json(text, str(path))


def check_writable_dir(folder: Path) -> Path:
    """Check, before any long work and without creating anything, that ``folder`` can be made and written."""
    folder = Path(folder)
    check_destination(folder)
    existing = next(p for p in (folder, *folder.parents) if p.exists())
    if not existing.is_dir():
        raise PipelineError(f"cannot write to {folder}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise PipelineError(f"cannot write to {folder}: {existing} is not writable")
    return folder
