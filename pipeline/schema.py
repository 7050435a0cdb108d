"""The files the stages hand each other, declared once: ``params.json``, ``fit.json``, ``metrics.json``, ``compare.h5``.

Each has a typed object, a writer and a reader; the readers check the file's version and keys and refuse a file that
is not one in one line. A file written before versions were recorded reads as version 1. ``params.json`` stays what
``model.Params.from_json`` and continuum codes read: the parameters, with what fitted them under ``metadata``.
Nested tables (a row per run, per parameter, per candidate run) stay lists of records, as ``report.md`` prints them.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import model

from . import io
from .errors import PipelineError
from .paths import ROOT, shown

FIT_VERSION = 2  # 2: made_from
METRICS_VERSION = 1
PARAMS_METADATA_VERSION = 1
COMPARE_SCHEMA, COMPARE_VERSION = "granular-backstress/compare", 1
MODELS_SCHEMA, MODELS_VERSION = "granular-backstress/models", 2  # models.h5 and models.json; 2: made_from


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
    names = {f.name for f in dataclasses.fields(cls)}
    required = {f.name for f in dataclasses.fields(cls)
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING}
    missing, unknown = sorted(required - set(given)), sorted(set(given) - names)
    if missing or unknown:
        raise PipelineError(f"{path} is not a {what} of this version: missing {missing}, unknown {unknown}")
    return given


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
        from .dataset.manifest import sha256

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
        from .dataset.manifest import sha256

        return [name for name, digest in self.inputs.items()  # ROOT / an absolute path is that path
                if not (ROOT / name).is_file() or sha256(ROOT / name) != digest]

    def require_unchanged(self, what: str, make: str) -> None:
        """Refuse, in one line, a product whose inputs changed (``what`` names the product and what it did with
        them, ``make`` the target that remakes it)."""
        changed = self.stale()
        if changed:
            raise PipelineError(f"{what} that have changed or gone since ({', '.join(changed[:3])}"
                                f"{' ...' if len(changed) > 3 else ''}): make {make} again")


# ---------------------------------------------------------------- params.json
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
    metadata = json.loads(io.read_text(Path(path))).get("metadata")
    if metadata is not None and not isinstance(metadata, dict):
        raise PipelineError(f"{path}: metadata is not a JSON object")
    version = (metadata or {}).get("schema_version", 1)
    if version != PARAMS_METADATA_VERSION:
        raise PipelineError(f"{path}: metadata of version {version!r}; this code reads {PARAMS_METADATA_VERSION}")
    return ParamsFile(params, metadata)


# ---------------------------------------------------------------- fit.json
class _Record:
    """A record nested in a file: read from and written to its JSON object with the keys ``RENAMED`` maps to its
    fields (a key that is no identifier), a missing or unknown key refused in one line (``_fields_of``)."""

    VERSION = 1
    WHAT = "record"
    RENAMED: dict = {}

    @classmethod
    def from_dict(cls, data: dict, path="fit.json"):
        if not isinstance(data, dict):
            raise PipelineError(f"{path}: the {cls.WHAT} is not a JSON object")
        return cls(**_fields_of(cls, data, path, cls.WHAT, cls.RENAMED))

    def to_dict(self) -> dict:
        key = {field: name for name, field in self.RENAMED.items()}
        return {key.get(f.name, f.name): getattr(self, f.name) for f in dataclasses.fields(self)}


@dataclasses.dataclass(frozen=True)
class StepwiseBootstrap(_Record):
    """The paper's stepwise route (mean over the reversal runs) on ``replicates`` resamplings of every run's
    cycles: per estimate in ``free``, the standard deviation, half the central 68 % range and the 2.5 and 97.5 %
    percentiles."""

    WHAT = "stepwise bootstrap"
    RENAMED = {"percentile_2.5": "percentile_2_5", "percentile_97.5": "percentile_97_5"}

    free: list
    replicates: int
    cycles: int
    standard_deviation: list
    half_width_68: list
    percentile_2_5: list
    percentile_97_5: list
    seed: int


@dataclasses.dataclass(frozen=True)
class Bootstrap(_Record):
    """The global fit refitted on copies of the data with fresh draws of the DEM's noise (in blocks of
    ``block_strain``): each refit's values (``replicates``, one row per refit, columns ``free``), their standard
    deviation, and the basic-bootstrap 68 and 95 % intervals about the fit; ``stepwise``, the stepwise route on
    the same number of resamplings."""

    WHAT = "bootstrap"

    free: list
    replicates: list
    standard_deviation: list
    block_strain: float
    seed: int
    interval_68: list
    interval_95: list
    stepwise: StepwiseBootstrap | None = None

    @classmethod
    def from_dict(cls, data: dict, path="fit.json") -> Bootstrap:
        record = super().from_dict(data, path)
        step = record.stepwise
        return dataclasses.replace(record, stepwise=None if step is None else StepwiseBootstrap.from_dict(step, path))

    def to_dict(self) -> dict:
        return {**super().to_dict(), "stepwise": None if self.stepwise is None else self.stepwise.to_dict()}


@dataclasses.dataclass(frozen=True)
class Jackknife(_Record):
    """The global fit refitted leaving out one group of runs at a time (``over``: "seeds" or "angles"; ``left_out``
    labels the groups; ``values``, one row per refit, columns ``free``): the jackknife standard error, its ratio to
    the whole sandwich's and to the part of it from the left-out runs' noise, and each refit's shift from the fit
    in standard deviations of what the noise alone would give it (``shift_z``; None where undefined)."""

    WHAT = "jackknife"

    free: list
    left_out: list
    values: list
    standard_error: list
    over_sandwich: list
    over_their_noise: list
    shift_z: list
    over: str = ""


@dataclasses.dataclass(frozen=True)
class FitSummary:
    """``fit.json``: the calibration of one data set (``make fit``). ``params`` are the fit's; ``global_fit`` the
    global refinement's estimates, errors and misfit (the file's ``global``); ``identifiability`` what the data fix;
    ``noise`` the noise model; the rest, the tables ``report.md`` and ``make fit`` print."""

    VERSION = FIT_VERSION

    method: str
    definitions: dict
    stress_fitted: str
    weight: str
    held: dict
    fit_from: float
    persistence_exponent: float
    jaumann_window_strain: float
    runs: list
    estimates: dict
    sensitivity: dict | None
    params_stepwise: dict | None
    params: dict
    cross_check: list
    global_fit: dict | None
    noise: dict | None
    identifiability: dict | None
    next_runs: list | None
    dilatancy: dict | None
    bootstrap: Bootstrap | None
    jackknife: Jackknife | None
    global_runs: list | None
    residual_map: list | None
    notes: list
    made_from: dict

    @classmethod
    def from_dict(cls, data: dict, path="fit.json") -> FitSummary:
        fields = _fields_of(cls, data, path, "fit summary", {"global": "global_fit"})
        for name, record in (("bootstrap", Bootstrap), ("jackknife", Jackknife)):
            if fields.get(name) is not None:
                fields[name] = record.from_dict(fields[name], path)
        return cls(**fields)

    def to_dict(self) -> dict:
        out = {"schema_version": self.VERSION, **{f.name: getattr(self, f.name) for f in dataclasses.fields(self)}}
        out["global"] = out.pop("global_fit")
        for name in ("bootstrap", "jackknife"):
            out[name] = None if out[name] is None else out[name].to_dict()
        return out


def write_fit(path: Path, summary: FitSummary) -> None:
    """``fit.json`` (inside the calibration's atomic set of outputs)."""
    io.write_bytes(path, io.json_text(summary.to_dict()).encode())


def read_fit(path: Path) -> FitSummary:
    return FitSummary.from_dict(read_json_object(path, "fit summary", "fit"), path)


def check_fitted(params_path: Path) -> None:
    """Believe a fit's ``params.json`` only if it is what its ``fit.json`` beside it fitted, from the run files as
    they are now: the same values (not edited by hand, not another fit's), the same record of what made it, and no
    input changed since. A parameters file with no ``fit.json`` beside it is one's own: taken as it is."""
    fit_path = Path(params_path).with_name("fit.json")
    if not fit_path.exists():
        return
    fit = read_fit(fit_path)
    made_from = MadeFrom.from_dict(fit.made_from, fit_path)
    given = read_params(params_path)
    if given.params.to_dict() != model.Params.from_dict(fit.params, str(fit_path)).to_dict():
        raise PipelineError(f"{params_path} does not hold the parameters {fit_path.name} beside it fitted (edited by "
                            "hand, or another fit's): make fit again, or give your own set from another folder")
    recorded = (given.metadata or {}).get("made_from")
    if recorded is not None and recorded != made_from.digest():
        raise PipelineError(f"{params_path} and {fit_path.name} come from two fits: make fit again")
    made_from.require_unchanged(f"{fit_path.parent} was fitted on runs", "fit")


# ---------------------------------------------------------------- metrics.json
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
