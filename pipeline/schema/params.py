"""``params.json``: the model's parameters, as ``model.Params.from_json`` and continuum codes read them, with what
fitted them under ``metadata``."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import model
from model import json_text

from .. import io
from ..errors import PipelineError

PARAMS_METADATA_VERSION = 1


@dataclasses.dataclass(frozen=True)
class ParamsFile:
    """``params.json``: the model's parameters and, for a fitted set, what fitted it (``metadata``: ``fit``, the
    ``definitions`` of strain, Phi and p it was fitted in, and the fit's own entries)."""

    params: model.Params
    metadata: dict | None = None

    @property
    def definitions(self) -> dict | None:
        """The definitions of strain, Phi and p the parameters were fitted in (``Definitions``' fields); None for a
        set without them (Table 2's, or one's own: the paper's)."""
        return (self.metadata or {}).get("definitions")


def write_params(path: Path, params: model.Params, metadata: dict | None = None) -> Path:
    """``params.json``, atomically; ``metadata`` gets the version."""
    return io.write_params(path, params, None if metadata is None else
                           {"schema_version": PARAMS_METADATA_VERSION, **metadata})


def read_params(path: Path) -> ParamsFile:
    """``params.json`` checked: the parameters (``model.Params.from_json``) and metadata of this version; else a
    one-line error."""
    params = io.read_params(path)
    metadata = json_text.loads(io.read_text(Path(path)), str(path)).get("metadata")
    if metadata is not None and not isinstance(metadata, dict):
        raise PipelineError(f"{path}: metadata is not a JSON object")
    version = (metadata or {}).get("schema_version", 1)
    if version != PARAMS_METADATA_VERSION:
        raise PipelineError(f"{path}: metadata of version {version!r}; this code reads {PARAMS_METADATA_VERSION}")
    return ParamsFile(params, metadata)
