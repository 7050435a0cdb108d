"""``metrics.json`` and ``compare.h5``: the model against a data set's runs (``make compare``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import model

from ..errors import PipelineError
from .base import MadeFrom, _fields_of, read_json_object

METRICS_VERSION = 1
COMPARE_SCHEMA, COMPARE_VERSION = "granular-backstress/compare", 1


@dataclasses.dataclass(frozen=True)
class Metrics:
    """``metrics.json``: the model against a data set's runs (``make compare``). ``param_sets`` maps a label
    ("Table 2", "our fit") to its parameters; ``errors`` has a row per run and set, ``components`` names the
    columns; the rest are the tables of ``report.md`` (None where the data set has no reversal; ``drift``: a row
    per run, ``pipeline.dataset.drift``)."""

    VERSION = METRICS_VERSION

    preset: str
    data_set: str
    definitions: dict
    param_sets: dict
    components: list
    errors: list
    seed_spread: list
    overshoot: list
    memory: list
    reversal: dict | None = None
    second_law: dict | None = None
    relaxation: dict | None = None
    drift: list | None = None
    made_from: dict | None = None

    @classmethod
    def from_dict(cls, data: dict, path="metrics.json") -> Metrics:
        given = _fields_of(cls, data, path, "comparison")
        try:
            sets = {label: model.Params.from_dict(values, f"{path}: param_sets[{label!r}]")
                    for label, values in given["param_sets"].items()}
        except (AttributeError, model.ParameterError) as exc:
            raise PipelineError(str(exc)) from None
        return cls(**{**given, "param_sets": sets})

    def to_dict(self) -> dict:
        out = {"schema_version": self.VERSION}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "param_sets":
                value = {label: p.to_dict() for label, p in value.items()}
            if value is not None or f.default is dataclasses.MISSING:
                out[f.name] = value
        return out


def read_metrics(path: Path) -> Metrics:
    return Metrics.from_dict(read_json_object(path, "comparison", "compare"), path)


def check_compared(metrics: Metrics, path: Path) -> None:
    """Believe a comparison only if what made it (the parameters file and the run files) is unchanged since."""
    if metrics.made_from is None:
        raise PipelineError(f"{path} does not record what made it (an older comparison): make compare again")
    MadeFrom.from_dict(metrics.made_from, path).require_unchanged(f"{path} compared files", "compare")


# ---------------------------------------------------------------- compare.h5
def stamp_compare(f) -> None:
    """Mark an open ``compare.h5`` (h5py) as this schema and version."""
    f.attrs.update(schema=COMPARE_SCHEMA, schema_version=COMPARE_VERSION)


def check_compare(f, path) -> None:
    """Refuse an open ``compare.h5`` of another schema or version (one written before versions is version 1)."""
    schema, version = f.attrs.get("schema"), int(f.attrs.get("schema_version", 1))
    if schema != COMPARE_SCHEMA or version != COMPARE_VERSION:
        raise PipelineError(f"{path} is not a comparison of this version (schema {schema!r}, version {version}): "
                            "run `make compare` again")
