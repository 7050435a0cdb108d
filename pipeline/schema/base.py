"""What every file the stages hand each other shares: reading a JSON object in one line of error, a typed record's
fields checked against a file's keys and version, and ``MadeFrom``, what made a product."""

from __future__ import annotations

import dataclasses
import functools
import json
import types
import typing
from pathlib import Path

from model import json_text

from .. import io
from ..errors import PipelineError
from ..paths import ROOT, shown


def read_json_object(path: Path, what: str, make: str, kind: type = dict):
    """A JSON object (or ``kind``: a list of rows) from ``path``; missing, unreadable or of another kind is a
    one-line error naming the make target that writes it."""
    try:
        data = json_text.loads(io.read_text(Path(path)), str(path))
    except FileNotFoundError:
        raise PipelineError(f"{path} not found: run `make {make}` first") from None
    except OSError as exc:
        raise PipelineError(f"{path} is not readable JSON ({exc})") from None
    except ValueError as exc:
        raise PipelineError(f"{exc}: run `make {make}` again") from None
    if not isinstance(data, kind):
        raise PipelineError(f"{path} is not a {what} (not a JSON {'object' if kind is dict else 'list'})")
    return data


def _fields_of(cls, data: dict, path, what: str, renamed: dict | None = None) -> dict:
    """``data``'s entries as ``cls``'s fields (``renamed``: file key -> field), the version checked first; a missing
    or unknown key is a one-line error naming the file."""
    version = data.get("schema_version", 1)
    if not isinstance(version, int) or isinstance(version, bool):
        raise PipelineError(f"{path}: schema_version {version!r} is not a whole number")
    if version != cls.VERSION:
        raise PipelineError(f"{path} is a {what} of version {version!r}; this code reads version {cls.VERSION}")
    renamed = renamed or {}
    given = {renamed.get(k, k): v for k, v in data.items() if k != "schema_version"}
    written = [f for f in dataclasses.fields(cls) if f.metadata.get("written", True)]
    names = {f.name for f in written}
    required = {f.name for f in written
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING}
    missing, unknown = sorted(required - set(given)), sorted(set(given) - names)
    if missing or unknown:
        raise PipelineError(f"{path} is not a {what} of this version: missing {missing}, unknown {unknown}")
    return given


@dataclasses.dataclass(frozen=True)
class Each:
    """A field that is a mapping of names to records of ``kind`` (annotated ``dict[str, kind]``)."""

    kind: type


def _kind(hint):
    """How a field annotated ``hint`` is read: a class that reads itself (``from_dict``: a record, ``model.Params``),
    in ``X | None``, ``list[X]`` or ``dict[str, X]`` (``Each``); None for plain JSON values."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        kinds = [k for k in map(_kind, args) if k is not None]
        return kinds[0] if kinds else None
    if origin is list:
        return _kind(args[0]) if args else None
    if origin is dict:
        inner = _kind(args[1]) if args else None
        return Each(inner) if inner is not None else None
    return hint if isinstance(hint, type) and hasattr(hint, "from_dict") else None


@functools.cache
def nested(cls) -> dict:
    """The fields of the record class ``cls`` that hold records, and how each is read (``_kind`` of its
    annotation)."""
    hints = typing.get_type_hints(cls)
    return {f.name: kind for f in dataclasses.fields(cls) if (kind := _kind(hints[f.name])) is not None}


def _read(kind, value, path):
    """``value`` from a file as ``kind`` (a class with ``from_dict``; ``Each``: a mapping of them), each of a
    list in turn; None stays None."""
    if value is None:
        return None
    if isinstance(value, list):
        return [_read(kind, v, path) for v in value]
    if isinstance(kind, Each):
        if not isinstance(value, dict):
            raise PipelineError(f"{path}: a mapping of {getattr(kind.kind, 'WHAT', kind.kind.__name__)}s is not a "
                                "JSON object")
        return {name: _read(kind.kind, v, f"{path}[{name!r}]") for name, v in value.items()}
    try:
        return kind.from_dict(value, path)
    except PipelineError:
        raise
    except ValueError as exc:  # model.ParameterError: its message names the file
        raise PipelineError(str(exc)) from None


def _plain(hint, value) -> bool:
    """Whether a plain JSON ``value`` is of the annotation ``hint`` (float, int, str, bool, ``X | None``, ``list[X]``,
    ``tuple``, ``dict[str, X]``, bare ``list`` or ``dict``); an annotation it does not know passes."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        return any(_plain(a, value) for a in args)
    if hint is type(None):
        return value is None
    if hint is bool:
        return isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if hint is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if hint is str:
        return isinstance(value, str)
    if hint in (list, tuple) or origin in (list, tuple):
        return isinstance(value, list) and (origin is not list or not args or all(_plain(args[0], v) for v in value))
    if hint is dict or origin is dict:
        return isinstance(value, dict) and (not args or all(isinstance(k, str) and _plain(args[1], v)
                                                            for k, v in value.items()))
    return True


@functools.cache
def plain(cls) -> dict:
    """The fields of the record class ``cls`` that hold plain JSON values, with their annotations."""
    hints = typing.get_type_hints(cls)
    records = nested(cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls) if f.name not in records}


def _written(value):
    """``value`` as a file holds it: a record (or parameters) as its JSON object, in lists and mappings too."""
    if hasattr(value, "to_dict"):
        return value.to_dict()
    if isinstance(value, (list, tuple)):
        return [_written(v) for v in value]
    if isinstance(value, dict):
        return {k: _written(v) for k, v in value.items()}
    return value


class Record:
    """A record in a file: read from and written to its JSON object with the keys ``RENAMED`` maps to its fields
    (a key that is no identifier), a missing or unknown key refused in one line (``_fields_of``). A field annotated
    with a record class (or ``model.Params``), alone, optional, in a list or as ``dict[str, X]``, is read as one
    (``nested``). ``REST`` names a mapping field whose entries the file holds flat beside the others (a table's
    columns); a field whose metadata says ``written=False`` is kept in memory only; with ``OMIT_NONE`` an optional
    field that is None is not written."""

    VERSION = 1
    WHAT = "record"
    RENAMED: dict = {}
    REST = ""
    OMIT_NONE = False

    @classmethod
    def from_dict(cls, data: dict, path="fit.json"):
        if not isinstance(data, dict):
            raise PipelineError(f"{path}: the {cls.WHAT} is not a JSON object")
        if cls.REST:
            names = {f.name for f in dataclasses.fields(cls)} | {"schema_version"}
            data = {**{k: v for k, v in data.items() if cls.RENAMED.get(k, k) in names},
                    cls.REST: {k: v for k, v in data.items() if cls.RENAMED.get(k, k) not in names}}
        fields = _fields_of(cls, data, path, cls.WHAT, cls.RENAMED)
        for name, kind in nested(cls).items():
            fields[name] = _read(kind, fields.get(name), f"{path}: {name}")
        for name, hint in plain(cls).items():
            if name in fields and not _plain(hint, fields[name]):
                raise PipelineError(f"{path}: {name}={str(fields[name])[:40]!r} is not of its type "
                                    f"({getattr(hint, '__name__', None) or str(hint).replace('typing.', '')})")
        try:
            return cls(**fields)
        except ValueError as exc:  # a record that checks its values (``Definitions``)
            raise PipelineError(f"{path}: {exc}") from None

    def to_dict(self) -> dict:
        key = {field: name for name, field in self.RENAMED.items()}
        out = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            omitted = self.OMIT_NONE and value is None and f.default is not dataclasses.MISSING
            if f.metadata.get("written", True) and not omitted:
                out[key.get(f.name, f.name)] = _written(value)
        if self.REST:
            out.update(out.pop(self.REST))
        return out


# ---------------------------------------------------------------- what made a product
@dataclasses.dataclass(frozen=True)
class MadeFrom:
    """What made a product: the SHA-256 of every file it read (``inputs``: path, relative to the project where
    inside it, to digest) and the options that shaped it. A product whose inputs changed since, or whose companion
    records another ``MadeFrom``, is stale whatever the file times say (``stale``, ``digest``)."""

    inputs: dict
    options: dict

    @classmethod
    def of(cls, paths, options: dict) -> MadeFrom:
        return cls({shown(p): io.sha256(Path(p)) for p in paths}, dict(options))

    @classmethod
    def from_dict(cls, data, path) -> MadeFrom:
        if not (isinstance(data, dict) and isinstance(data.get("inputs"), dict) and isinstance(data.get("options"),
                                                                                                 dict)):
            raise PipelineError(f"{path}: made_from is not a record of inputs and options")
        return cls(data["inputs"], data["options"])

    def to_dict(self) -> dict:
        return {"inputs": self.inputs, "options": self.options}

    def digest(self) -> str:
        """SHA-256 of the record itself (its canonical JSON)."""
        import hashlib

        return hashlib.sha256(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()

    def stale(self) -> list[str]:
        """The inputs that are no longer what the product read (changed, or gone)."""
        return [name for name, digest in self.inputs.items()  # ROOT / an absolute path is that path
                if not (ROOT / name).is_file() or io.sha256(ROOT / name) != digest]

    def require_same(self, what: str, expected: dict, make: str) -> None:
        """Refuse, in one line naming the product and the command that remakes it, a product made for another data
        set or with other options than ``expected`` (its options' values by key; a key it lacks is a mismatch)."""
        for key, value in expected.items():
            got = self.options.get(key, "(not recorded)")
            if got != value:
                raise PipelineError(f"{what} was made for {key}={got!r}, not {value!r}: it is another's product; "
                                    f"`make {make}` remakes it")

    def require_unchanged(self, what: str, make: str) -> None:
        """Refuse, in one line, a product whose inputs changed (``what`` names the product and what it did with
        them, ``make`` the target that remakes it)."""
        changed = self.stale()
        if changed:
            raise PipelineError(f"{what} that have changed or gone since ({', '.join(changed[:3])}"
                                f"{' ...' if len(changed) > 3 else ''}): make {make} again")
