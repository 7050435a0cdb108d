"""What every file the stages hand each other shares: reading a JSON object in one line of error, a typed record's
fields checked against a file's keys and version, and ``MadeFrom``, what made a product."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from .. import io
from ..errors import PipelineError
from ..paths import ROOT, shown


def read_json_object(path: Path, what: str, make: str, kind: type = dict):
    """A JSON object (or ``kind``: a list of rows) from ``path``; missing, unreadable or of another kind is a
    one-line error naming the make target that writes it."""
    try:
        data = json.loads(io.read_text(Path(path)))
    except FileNotFoundError:
        raise PipelineError(f"{path} not found: run `make {make}` first") from None
    except (OSError, ValueError) as exc:
        raise PipelineError(f"{path} is not readable JSON ({exc})") from None
    if not isinstance(data, kind):
        raise PipelineError(f"{path} is not a {what} (not a JSON {'object' if kind is dict else 'list'})")
    return data


def _fields_of(cls, data: dict, path, what: str, renamed: dict | None = None) -> dict:
    """``data``'s entries as ``cls``'s fields (``renamed``: file key -> field), the version checked first; a missing
    or unknown key is a one-line error naming the file."""
    version = data.get("schema_version", 1)
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


class Record:
    """A record nested in a file: read from and written to its JSON object with the keys ``RENAMED`` maps to its
    fields (a key that is no identifier), a missing or unknown key refused in one line (``_fields_of``); ``NESTED``
    names the fields that hold a record (or, in a list, records) of a class of their own; a field whose metadata
    says ``written=False`` is kept in memory only."""

    VERSION = 1
    WHAT = "record"
    RENAMED: dict = {}
    NESTED: dict = {}

    @classmethod
    def from_dict(cls, data: dict, path="fit.json"):
        if not isinstance(data, dict):
            raise PipelineError(f"{path}: the {cls.WHAT} is not a JSON object")
        fields = _fields_of(cls, data, path, cls.WHAT, cls.RENAMED)
        for name, kind in cls.NESTED.items():
            value = fields.get(name)
            if isinstance(value, list):
                fields[name] = [kind.from_dict(v, path) for v in value]
            elif value is not None:
                fields[name] = kind.from_dict(value, path)
        return cls(**fields)

    def to_dict(self) -> dict:
        key = {field: name for name, field in self.RENAMED.items()}
        out = {}
        for f in dataclasses.fields(self):
            if not f.metadata.get("written", True):
                continue
            value = getattr(self, f.name)
            if f.name in self.NESTED and value is not None:
                value = [v.to_dict() for v in value] if isinstance(value, list) else value.to_dict()
            out[key.get(f.name, f.name)] = value
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
        from ..dataset.manifest import sha256

        return cls({shown(p): sha256(Path(p)) for p in paths}, dict(options))

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
        from ..dataset.manifest import sha256

        return [name for name, digest in self.inputs.items()  # ROOT / an absolute path is that path
                if not (ROOT / name).is_file() or sha256(ROOT / name) != digest]

    def require_unchanged(self, what: str, make: str) -> None:
        """Refuse, in one line, a product whose inputs changed (``what`` names the product and what it did with
        them, ``make`` the target that remakes it)."""
        changed = self.stale()
        if changed:
            raise PipelineError(f"{what} that have changed or gone since ({', '.join(changed[:3])}"
                                f"{' ...' if len(changed) > 3 else ''}): make {make} again")
