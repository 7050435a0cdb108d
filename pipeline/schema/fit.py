"""``fit.json``: the calibration of one data set (``make fit``), its resamplings as records of their own."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import model

from .. import io
from ..errors import PipelineError
from .base import MadeFrom, Record, read_json_object
from .params import read_params

FIT_VERSION = 2  # 2: made_from


@dataclasses.dataclass(frozen=True)
class StepwiseBootstrap(Record):
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
class Bootstrap(Record):
    """The global fit refitted on copies of the data with fresh draws of the DEM's noise (in blocks of
    ``block_strain``): each refit's values (``replicates``, one row per refit, columns ``free``), their standard
    deviation, and the basic-bootstrap 68 and 95 % intervals about the fit; ``stepwise``, the stepwise route on
    the same number of resamplings."""

    WHAT = "bootstrap"
    NESTED = {"stepwise": StepwiseBootstrap}

    free: list
    replicates: list
    standard_deviation: list
    block_strain: float
    seed: int
    interval_68: list
    interval_95: list
    stepwise: StepwiseBootstrap | None = None


@dataclasses.dataclass(frozen=True)
class Jackknife(Record):
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
class Estimates(Record):
    """A least-squares fit (``calibration.global_fit``: the global refinement, and Eq. 18's dilatancy): the law's
    parameters it ends at, the names fitted and their values, standard errors (None where the data fix nothing),
    correlation and covariances (the sandwich from the noise and the white one; None where not computed), the
    misfit (chi^2 per degree of freedom in noise units) and chi^2, the solver's work and word, and the covariance's
    eigen-directions."""

    WHAT = "fit's estimates"

    params: dict
    free: list
    values: list
    standard_errors: list
    correlation: list | None
    covariance: list | None
    white_covariance: list | None
    misfit: float
    chi2: float
    nfev: int
    success: bool
    message: str
    directions: list


@dataclasses.dataclass(frozen=True)
class NoiseSummary(Record):
    """The DEM's noise as a fit measured it (``calibration.noise.NoiseModel``): where from, whether measured (two
    cycles or three seeds), per fitted component (``components``) the noise per sample of a cycle and between seeds
    for A and tau/p, its correlation strain (A's, tau/p's), A against tau/p's correlation, and the correlation at 0.05
    strain."""

    WHAT = "noise summary"
    RENAMED = {"correlation_at_0.05_strain": "correlation_at_005_strain"}

    source: str
    measured: bool
    components: list
    sigma_cycle: dict
    sigma_seed: dict
    correlation_strain: dict
    A_tau_correlation: list
    correlation_at_005_strain: dict


@dataclasses.dataclass(frozen=True)
class CandidateRun(Record):
    """A run the fit could add (``calibration.design.rank``): its protocol, cycles and sampling, its cost in
    CPU-hours, the weakest combination's ± and the largest relative ± before and after joining it, and the gain per
    CPU-hour; or, for one that cannot be weighed at the best fit, ``error`` (its other numbers None)."""

    WHAT = "candidate run"

    run: str
    theta_deg: float
    rotate_at: float
    error: str | None = None
    n_cycles: int | None = None
    sample_strain: float | None = None
    cpu_hours: float | None = None
    weakest_before: float | None = None
    weakest_after: float | None = None
    worst_relative_se_before: float | None = None
    worst_relative_se_after: float | None = None
    gain_per_cpu_hour: float | None = None


@dataclasses.dataclass(frozen=True)
class ParameterInterval(Record):
    """One fitted parameter: its value, standard error from the noise (None where the data fix nothing along it),
    status ("determined", "loosely determined", "not determined", or why there is none) and its intervals per level
    ("68", "95": [low, high], None where open), from the noise and widened by sqrt(misfit)."""

    WHAT = "parameter's interval"

    value: float
    standard_error: float | None
    status: str
    intervals: dict
    intervals_misfit_widened: dict


@dataclasses.dataclass(frozen=True)
class Combination(Record):
    """An eigen-direction of the covariance in relative parameters (``direction``: name to component), one standard
    deviation along it as a relative change (``relative_step``; inf where the data fix nothing), and its text."""

    WHAT = "combination"

    relative_step: float
    direction: dict
    combination: str


@dataclasses.dataclass(frozen=True)
class Table2Test(Record):
    """Table 2 as a hypothesis on the data: its chi^2 rise above the best fit (absolute and relative), the fit's
    misfit, the rise's quantiles from the noise per level (None where a direction is not determined) and whether
    the rise lies inside each level's region, as measured and widened by the misfit."""

    WHAT = "test of Table 2"

    chi2_rise: float
    relative_rise: float
    misfit: float
    quantiles: dict | None
    inside: dict | None = None
    inside_misfit_widened: dict | None = None


@dataclasses.dataclass(frozen=True)
class SpreadOverAngles(Record):
    """Each parameter's range ([low, high]) over the refits that leave out one angle (``left_out``) in turn."""

    WHAT = "spread over angles"

    left_out: list
    ranges: dict


@dataclasses.dataclass(frozen=True)
class Identifiability(Record):
    """What the data determine (``calibration.identifiability.summary``): per parameter its interval
    (``parameters``), the 68 % bands alone, those not determined, the parameters held, the misfit and its widening
    sqrt(misfit) (``misfit_noted`` where it is said beside the intervals), the three weakest and strongest
    combinations, whether the noise was measured, Table 2's test and, where the misfit is noted, the spread over
    the refits without one angle."""

    WHAT = "identifiability summary"

    parameters: dict
    intervals_68: dict
    not_determined: list
    held: dict
    misfit: float
    misfit_widening: float
    misfit_noted: bool
    weakest: list
    strongest: list
    noise_measured: bool
    table2: Table2Test | None
    spread_over_angles: SpreadOverAngles | None = None

    NESTED = {"weakest": Combination, "strongest": Combination, "table2": Table2Test,
              "spread_over_angles": SpreadOverAngles}

    @classmethod
    def from_dict(cls, data: dict, path="fit.json") -> Identifiability:
        record = super().from_dict(data, path)
        if not isinstance(record.parameters, dict):
            raise PipelineError(f"{path}: the identifiability summary's parameters are not a JSON object")
        return dataclasses.replace(record, parameters={name: ParameterInterval.from_dict(p, path)
                                                       for name, p in record.parameters.items()})

    def to_dict(self) -> dict:
        return {**super().to_dict(), "parameters": {name: p.to_dict() for name, p in self.parameters.items()}}


@dataclasses.dataclass(frozen=True)
class FitSummary(Record):
    """``fit.json``: the calibration of one data set (``make fit``). ``params`` are the fit's; ``global_fit`` the
    global refinement's estimates, errors and misfit (the file's ``global``); ``identifiability`` what the data fix;
    ``noise`` the noise model; the rest, the tables ``report.md`` and ``make fit`` print."""

    VERSION = FIT_VERSION
    WHAT = "fit summary"
    RENAMED = {"global": "global_fit"}
    NESTED = {"bootstrap": Bootstrap, "jackknife": Jackknife, "identifiability": Identifiability,
              "global_fit": Estimates, "dilatancy": Estimates, "noise": NoiseSummary, "next_runs": CandidateRun}

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
    global_fit: Estimates | None
    noise: NoiseSummary | None
    identifiability: Identifiability | None
    next_runs: list | None  # of CandidateRun
    dilatancy: Estimates | None
    bootstrap: Bootstrap | None
    jackknife: Jackknife | None
    global_runs: list | None
    residual_map: list | None
    notes: list
    made_from: dict

    def to_dict(self) -> dict:
        return {"schema_version": self.VERSION, **super().to_dict()}


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
