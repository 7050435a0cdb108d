"""``models.json`` and ``models.h5``: every fabric law judged by the runs it was not fitted on (``make models``),
written and read here alone."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import model
from model import json_text

from .. import io
from ..errors import PipelineError
from .base import MadeFrom, Record, read_json_object
from .fit import OwnReversal

MODELS_SCHEMA, MODELS_VERSION = "granular-backstress/models", 2  # models.h5 and models.json; 2: made_from

#: a field kept in memory, not written
UNWRITTEN = {"written": False}


@dataclasses.dataclass(frozen=True)
class HeldOut(Record):
    """One held-out run predicted by a law: per component of A and of the fitted tau/p (``components``: its name to
    ``rms_noise``, the RMS error in units of the run's noise, and ``rms_per_steady``, per the DEM's steady value),
    the sum of squared noise-scaled residuals and their count, and their RMS; ``error`` says why there is no
    prediction (infinite errors then). ``blocks``, not written: per component the scaled (A, tau) residuals and the
    noise's correlation over them, for the z-test."""

    WHAT = "held-out score"

    run: str
    protocol: str
    seed: int
    components: dict
    error: str | None
    chi2: float
    samples: float
    rms_noise: float
    blocks: list | None = dataclasses.field(default=None, compare=False, repr=False, metadata=UNWRITTEN)


@dataclasses.dataclass(frozen=True)
class SplitScore(Record):
    """A law fitted on a split's runs (``params``, ``misfit``; None with ``error`` where it could not be) and its
    held-out runs' scores, pooled in ``rms_noise``."""

    WHAT = "split score"

    name: str
    params: model.Params | None
    misfit: float | None
    error: str | None
    rows: list[HeldOut]
    rms_noise: float


@dataclasses.dataclass(frozen=True)
class AcrossScore(Record):
    """Across cells: the law fitted on the ``other`` data set (``params_there``) predicting this one's runs, and the
    law fitted here predicting the other's."""

    WHAT = "score across cells"

    other: str
    params_there: model.Params
    here_from_there: list[HeldOut]
    rms_noise_here: float
    there_from_here: list[HeldOut]
    rms_noise_there: float


@dataclasses.dataclass(frozen=True)
class LawScore(Record):
    """Everything ``make models`` reports of one law: its fit on every run of the default protocol (``params``, the
    free parameters' values and standard errors, misfit, chi^2, AIC, BIC; whether its own reversal runs), and its
    scores on each split and across cells."""

    WHAT = "law's score"

    variant: str
    params: model.Params
    free: list
    values: list
    standard_errors: list
    misfit: float
    parameters: int
    chi2: float
    aic: float
    bic: float
    own_reversal: OwnReversal
    splits: list[SplitScore]
    across: list[AcrossScore]

    def tests(self):
        """(test, its held-out rows, their pooled RMS in noise units) for every split and cross-cell prediction."""
        for split in self.splits:
            yield split.name, split.rows, split.rms_noise
        for across in self.across:
            yield f"predicting this cell from {across.other}", across.here_from_there, across.rms_noise_here
            yield f"predicting {across.other} from this cell", across.there_from_here, across.rms_noise_there


@dataclasses.dataclass(frozen=True)
class Judgement(Record):
    """A law against Eq. 13's on one held-out test: both pooled RMS errors, the z of the difference of their chi^2
    in units of what the noise alone makes of it (positive: the law predicts better), and the word for it."""

    WHAT = "judgement"

    variant: str
    against: str
    test: str
    rms_noise: float
    rms_noise_against: float
    z: float
    verdict: str

    def line(self) -> str:
        return (f"{self.variant} against {self.against}, {self.test}: {self.rms_noise:.2f} against "
                f"{self.rms_noise_against:.2f} noise units, z = {self.z:+.1f}: {self.verdict}")


@dataclasses.dataclass(frozen=True)
class ModelsSummary(Record):
    """``models.json``: the data set, how the laws were fitted (``stress_fitted``, ``weight``, the angles the
    ``angles`` split fits), each law's score, the laws not fitted on every run (with why), the verdicts and what
    made it."""

    VERSION = MODELS_VERSION
    WHAT = "models summary"

    data_set: str
    stress_fitted: str
    weight: str
    train_angles: list
    beyond_noise_z: float
    variants: list[LawScore]
    not_fitted: dict
    verdict: list[Judgement]
    made_from: dict

    def to_dict(self) -> dict:
        return {"schema_version": self.VERSION, **super().to_dict()}


def models_json(summary: ModelsSummary) -> bytes:
    """``models.json``'s bytes (written inside ``make models``' atomic set of outputs)."""
    return io.json_text(summary.to_dict()).encode()


def read_models(path: Path) -> ModelsSummary:
    """``models.json`` checked (its version, every key)."""
    return ModelsSummary.from_dict(read_json_object(path, "models summary", "models"), path)


def write_models_h5(path: Path, drawn: dict, made_from: MadeFrom) -> None:
    """``models.h5``: per kind of curve ("memory", "jump"), a group per run (its name, seed, angle) with the strain,
    the DEM's curve and each law's (``model/<law>``), stamped with this schema, its version and what made it."""
    with io.h5_file(path) as f:
        f.attrs.update(schema=MODELS_SCHEMA, schema_version=MODELS_VERSION, made_from=json.dumps(made_from.to_dict()))
        for kind, items in drawn.items():
            for k, item in enumerate(items):
                g = f.create_group(f"{kind}/{k:02d}")
                g.attrs["run"], g.attrs["seed"] = item["run"], item["seed"]
                g.attrs["theta"] = item.get("theta", 180.0)
                g["strain"], g["dem"] = item["strain"], item["dem"]
                for variant, values in item["model"].items():
                    g[f"model/{variant}"] = values


def read_models_h5(path: Path, kind: str) -> list:
    """The ``kind`` groups ("memory" or "jump") of ``models.h5``, open (h5py), once the file is this schema's and
    version's and its runs are what it judged (else a one-line error)."""
    import h5py

    f = h5py.File(path, "r")
    try:
        if f.attrs.get("schema") != MODELS_SCHEMA or f.attrs.get("schema_version") != MODELS_VERSION or \
                "made_from" not in f.attrs:
            raise PipelineError(f"{path}: not a models.h5 of version {MODELS_VERSION} that records what made it (run "
                                "`make models`)")
        try:
            made_from = json_text.loads(f.attrs["made_from"], f"{path} attribute made_from")
        except ValueError as exc:
            raise PipelineError(f"{exc}: run `make models` again") from None
        MadeFrom.from_dict(made_from, path).require_unchanged(f"{path} judged runs", "models")
    except PipelineError:
        f.close()
        raise
    return [f[kind][k] for k in sorted(f.get(kind, {}))]
