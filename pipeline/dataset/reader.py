"""The one way a DEM run file is opened: as data that cannot reach outside itself.

Only what the schema names is opened (``config/raw_schema.toml``'s fields, ``/parameters/grain_diameter``, the
attributes of ``/``, ``/provenance`` and ``/parameters``). Before a dataset's bytes are read, it must be a hard link to
a plain dataset stored in the file itself (no soft or external link, no virtual dataset, no external raw storage), of
real numbers (integer or float, at most 8 bytes), of the schema's shape for the file's sample count, and carry the
schema's unit. The file's declared size and chunk count are bounded before anything is read, and so are its
attributes and the nesting of the JSON they hold. Every refusal is a :class:`DemFileError` of one line naming the
file and the object.
"""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np

from model import json_text

from ..errors import DemFileError

#: most samples a run file may declare (a paper-cell run of 7 cycles with dense samples has about 4 000)
MAX_SAMPLES = 1_000_000
#: most bytes of datasets a run file may declare (the paper cell's largest run holds about 10 MB)
MAX_BYTES = 2 * 1024 ** 3
#: most chunks a dataset may be stored in (HDF5 keeps an index entry and, on reading, a buffer per chunk)
MAX_CHUNKS = 65_536
#: most attributes per group, and bytes per attribute
MAX_ATTRIBUTES, MAX_ATTRIBUTE_BYTES = 256, 1024 ** 2
#: deepest nesting of a JSON attribute (a spec is two levels deep)
MAX_JSON_DEPTH = 16


class RunFileReader:
    """An open run file (a context manager); ``dataset`` and ``attributes`` read what the schema names only."""

    def __init__(self, path):
        self.path = Path(path)
        if not self.path.exists():
            raise DemFileError(f"cannot open {self.path}: no such file")
        if not self.path.is_file():
            raise DemFileError(f"{self.path} is not a regular file")
        try:
            self.file = h5py.File(self.path, "r")
        except (OSError, ValueError) as exc:
            raise DemFileError(f"cannot open {self.path} as HDF5 ({exc})") from None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.file.close()

    def refuse(self, what: str, why: str):
        raise DemFileError(f"{self.path}: {what} {why}")

    def member(self, name: str, kind: type):
        """The object at the absolute path ``name``, each link on the way a hard link, of type ``kind``."""
        node = self.file
        parts = [p for p in name.split("/") if p]
        for i, part in enumerate(parts):
            where = "/" + "/".join(parts[:i + 1])
            if part not in node:
                self.refuse(where, "is missing")
            link = node.get(part, getlink=True)
            if not isinstance(link, h5py.HardLink):
                self.refuse(where, f"is a {type(link).__name__}: a run file holds its data itself")
            node = node[part]
        if not isinstance(node, kind):
            self.refuse(name, f"is not a {kind.__name__}")
        return node

    def has(self, name: str) -> bool:
        """Whether the group ``name`` is there (as anything: ``member`` then checks what it is)."""
        return name.strip("/") in self.file

    def attributes(self, name: str = "/") -> dict:
        """The attributes of the group ``name``, bounded in number and size, each a number or a string."""
        attrs = (self.file if name == "/" else self.member(name, h5py.Group)).attrs
        if len(attrs) > MAX_ATTRIBUTES:
            self.refuse(name, f"has {len(attrs)} attributes (at most {MAX_ATTRIBUTES})")
        out = {}
        for key in attrs:
            info = attrs.get_id(key)
            if info.get_storage_size() > MAX_ATTRIBUTE_BYTES:
                self.refuse(f"{name} attribute {key!r}", f"holds {info.get_storage_size()} bytes")
            value = attrs[key]
            if isinstance(value, bytes):
                value = value.decode("utf-8", errors="replace")
            if isinstance(value, np.ndarray) and value.dtype.kind not in "biuf":
                self.refuse(f"{name} attribute {key!r}", f"is of type {value.dtype}")
            if isinstance(value, (complex, np.complexfloating)) or not isinstance(
                    value, (str, int, float, np.integer, np.floating, np.bool_, np.ndarray)):
                self.refuse(f"{name} attribute {key!r}", f"is of type {type(value).__name__}")
            out[key] = value
        return out

    def json_attribute(self, attrs: dict, name: str, key: str):
        """The JSON text ``attrs[key]`` (of the group ``name``) parsed, its nesting bounded."""
        text = attrs.get(key)
        if not isinstance(text, str):
            self.refuse(f"{name} attribute {key!r}", "is missing or not text")
        try:
            return json_text.loads(text, "it", MAX_JSON_DEPTH)
        except ValueError as exc:
            self.refuse(f"{name} attribute {key!r}", str(exc).removeprefix("it "))

    def check_dataset(self, name: str, shape: tuple, unit: str | None):
        """The dataset ``name``, checked (storage, type, ``shape`` with None for any length, ``unit``) unread."""
        ds = self.member(name, h5py.Dataset)
        if ds.is_virtual:
            self.refuse(name, "is a virtual dataset: a run file holds its data itself")
        if ds.id.get_create_plist().get_external_count():
            self.refuse(name, "is stored in external files: a run file holds its data itself")
        if ds.chunks and math.prod(-(-s // c) for s, c in zip(ds.shape, ds.chunks, strict=True)) > MAX_CHUNKS:
            self.refuse(name, f"is stored in more than {MAX_CHUNKS} chunks of {ds.chunks}")
        if ds.dtype.kind not in "iuf" or ds.dtype.itemsize > 8:
            self.refuse(name, f"is of type {ds.dtype}, not real numbers")
        if len(ds.shape) != len(shape) or any(want is not None and have != want
                                              for have, want in zip(ds.shape, shape, strict=True)):
            self.refuse(name, f"has shape {ds.shape}, expected {tuple('n' if s is None else s for s in shape)}")
        if unit is not None and ds.attrs.get("unit") != unit:
            self.refuse(name, f"has unit {ds.attrs.get('unit')!r}, expected {unit!r}")
        return ds

    def samples(self, name: str) -> int:
        """The sample count the file declares: the length of ``name`` (``/raw/strain``), bounded."""
        ds = self.check_dataset(name, (None,), None)
        if ds.shape[0] > MAX_SAMPLES:
            self.refuse(name, f"declares {ds.shape[0]} samples (at most {MAX_SAMPLES})")
        return ds.shape[0]

    def read(self, checked: dict) -> dict:
        """The datasets of ``checked`` (``{key: dataset}`` from ``check_dataset``), read once their declared bytes
        are within ``MAX_BYTES`` together."""
        declared = sum(math.prod(ds.shape) * ds.dtype.itemsize for ds in checked.values())
        if declared > MAX_BYTES:
            raise DemFileError(f"{self.path} declares {declared} bytes of data (at most {MAX_BYTES})")
        return {key: ds[()] for key, ds in checked.items()}
