"""``metrics.json`` and ``compare.h5``: the model against a data set's runs (``make compare``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

import model

from ..errors import PipelineError
from .base import MadeFrom, Record, read_json_object
from .definitions import Definitions

METRICS_VERSION = 2  # 2: the parameter sets, the errors and the response after each change each a record
COMPARE_SCHEMA, COMPARE_VERSION = "granular-backstress/compare", 1
#: the labels of the two parameter sets every comparison holds: the paper's and the data set's own fit
TABLE2, OUR_FIT = "Table 2", "our fit"


@dataclasses.dataclass(frozen=True)
class ErrorRow(Record):
    """A run's errors against one parameter set's prediction: per component (``errors``; the file holds them beside
    the run's name), the RMSE over the cycle divided by the steady |A12| or |tau12/p|."""

    WHAT = "error row"
    REST = "errors"

    run: str
    seed: int
    parameters: str
    errors: dict


@dataclasses.dataclass(frozen=True)
class ErrorRange(Record):
    """One component's error over a run's seeds: the mean, the least and the largest."""

    WHAT = "error range"

    mean: float
    least: float
    largest: float


@dataclasses.dataclass(frozen=True)
class SeedSpread(Record):
    """A run measured at several seeds, against one parameter set: its seeds and each component's ``ErrorRange``."""

    WHAT = "spread over seeds"
    REST = "errors"
    run: str
    parameters: str
    seeds: list[int]
    errors: dict[str, ErrorRange]


@dataclasses.dataclass(frozen=True)
class Overshoot(Record):
    """A component along the new shear direction after a change: its mean over OVERSHOOT_EARLY minus its steady
    value, the DEM's (mean over cycles, ``dem_se`` its standard error, None with one cycle) and each parameter
    set's (``model``: label to value); ``steady`` the DEM's steady value."""

    WHAT = "overshoot"

    dem: float
    steady: float
    dem_se: float | None
    model: dict


@dataclasses.dataclass(frozen=True)
class OvershootRow(Record):
    """A run's overshoot of A and tau/p after one change of direction (``segment``), at one seed."""

    WHAT = "overshoot row"

    run: str
    seed: int
    segment: str
    direction_deg: float
    cycles: int
    A: Overshoot
    tau: Overshoot


@dataclasses.dataclass(frozen=True)
class MemoryRow(Record):
    """A run's memory of the old direction after one change (``segment``, from ``from_deg`` to
    ``direction_deg``), at one seed: its mean over each strain window after the change, the DEM's over cycles
    (``dem_se``: standard errors, None with one cycle) and each parameter set's (``model``: label to means)."""

    WHAT = "memory row"

    run: str
    seed: int
    segment: str
    from_deg: float
    direction_deg: float
    cycles: int
    windows: list
    dem: list
    dem_se: list | None
    model: dict


@dataclasses.dataclass(frozen=True)
class Trend(Record):
    """One quantity of one run over its cycles (``dataset.drift``): its mean per cycle, slope per cycle with its
    standard error, t and p (None where there is no degree of freedom)."""

    WHAT = "trend"

    per_cycle: list
    slope: float | None
    standard_error: float | None
    t: float | None
    p: float | None


@dataclasses.dataclass(frozen=True)
class DriftRow(Record):
    """A run's protocol, seed and cycles compared, and each quantity's ``Trend`` over them."""

    WHAT = "drift row"

    theta_deg: float
    rotate_at: float
    seed: int
    cycles: int
    trends: dict[str, Trend]


@dataclasses.dataclass(frozen=True)
class Reversal(Record):
    """The reversal runs' share of the backstress C A12 in the steady shear stress (with our C; with each set's C;
    in each set's own model cycle), their mean packing fraction and the range of Table 2's model cycle."""

    WHAT = "reversal summary"

    backstress_share: float
    mean_packing_fraction: float
    table2_packing_fraction_range: list
    backstress_share_by_C: dict
    model_backstress_share: dict


@dataclasses.dataclass(frozen=True)
class SecondLaw(Record):
    """Eq. 19 with our fit: c1 = -C, the DEM's largest Phi against Phi_c + c3, the smallest total work rate of the
    model's cycles (Eq. 17, per p gamma_dot), and whether all hold."""

    WHAT = "second law"

    c1: float
    C: float
    phi_max_dem: float
    phi_c_plus_c3: float
    min_total_work_rate: float
    holds: bool


@dataclasses.dataclass(frozen=True)
class Strains(Record):
    """Relaxation strains after the reversal of the isotropic part and of the backstress (None: not resolved)."""

    WHAT = "relaxation strains"

    isotropic: float | None
    backstress: float | None


@dataclasses.dataclass(frozen=True)
class CutRelaxation(Record):
    """Relaxation strains at one cut: the DEM's parts split with each set's C, and each set's own model cycle."""

    WHAT = "relaxation at a cut"

    dem: dict[str, Strains]
    model: dict[str, Strains]


@dataclasses.dataclass(frozen=True)
class Relaxation(Record):
    """The relaxation strains after the reversal: the DEM's (mean of ``reversal_runs`` runs, split with our C),
    each set's model cycle, and both at each cut (``by_cut``: the strain left out after the reversal)."""

    WHAT = "relaxation summary"

    reversal_runs: int
    dem: Strains
    model: dict[str, Strains]
    by_cut: dict[str, CutRelaxation]


@dataclasses.dataclass(frozen=True)
class ParamSets(Record):
    """The two parameter sets every comparison holds: the paper's (the file's "Table 2") and the data set's own fit
    ("our fit"); ``labelled`` gives them under those labels, the keys of each table's ``model`` column."""

    WHAT = "parameter sets"
    RENAMED = {TABLE2: "table2", OUR_FIT: "our_fit"}

    table2: model.Params
    our_fit: model.Params

    def labelled(self) -> dict[str, model.Params]:
        return {TABLE2: self.table2, OUR_FIT: self.our_fit}


@dataclasses.dataclass(frozen=True)
class Errors(Record):
    """The model's errors: a row per run and parameter set (``rows``; ``components`` names their columns), and for
    a run measured at several seeds, their range over the seeds."""

    WHAT = "errors"

    components: list[str]
    rows: list[ErrorRow]
    seed_spread: list[SeedSpread]


@dataclasses.dataclass(frozen=True)
class AfterChanges(Record):
    """The response after each change of direction, a row per run, change and seed: the overshoot of A and tau/p
    along the new direction, and the memory of the old one over strain windows."""

    WHAT = "response after changes"

    overshoot: list[OvershootRow]
    memory: list[MemoryRow]


@dataclasses.dataclass(frozen=True)
class Metrics(Record):
    """``metrics.json``: the model against a data set's runs (``make compare``), read with ``definitions``: the two
    parameter sets, the errors, the response after each change of direction, and the tables of ``report.md`` (None
    where the data set has no reversal, or no fit file with reversal curves: ``relaxation``); ``drift``, each run's
    quantities over its cycles."""

    VERSION = METRICS_VERSION
    WHAT = "comparison"
    OMIT_NONE = True

    preset: str
    data_set: str
    definitions: Definitions
    param_sets: ParamSets
    errors: Errors
    after_changes: AfterChanges
    reversal: Reversal | None = None
    second_law: SecondLaw | None = None
    relaxation: Relaxation | None = None
    drift: list[DriftRow] | None = None
    made_from: MadeFrom | None = None

    def to_dict(self) -> dict:
        return {"schema_version": self.VERSION, **super().to_dict()}


def read_metrics(path: Path) -> Metrics:
    return Metrics.from_dict(read_json_object(path, "comparison", "compare"), path)


def check_compared(metrics: Metrics, path: Path) -> None:
    """Believe a comparison only if what made it (the parameters file and the run files) is unchanged since."""
    if metrics.made_from is None:
        raise PipelineError(f"{path} does not record what made it (an older comparison): make compare again")
    metrics.made_from.require_unchanged(f"{path} compared files", "compare")


# ---------------------------------------------------------------- compare.h5
def stamp_compare(f) -> None:
    """Mark an open ``compare.h5`` (h5py) as this schema and version."""
    f.attrs.update(schema=COMPARE_SCHEMA, schema_version=COMPARE_VERSION)


def check_compare(f, path) -> None:
    """Refuse an open ``compare.h5`` of another schema or version (one written before versions is version 1)."""
    schema, version = f.attrs.get("schema"), f.attrs.get("schema_version", 1)
    if not isinstance(version, (int, np.integer)) or isinstance(version, (bool, np.bool_)):
        raise PipelineError(f"{path}: schema_version {version!r} is not a whole number: run `make compare` again")
    if schema != COMPARE_SCHEMA or version != COMPARE_VERSION:
        raise PipelineError(f"{path} is not a comparison of this version (schema {schema!r}, version {version}): "
                            "run `make compare` again")
