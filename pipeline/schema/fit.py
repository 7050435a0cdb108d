"""``fit.json``: the calibration of one data set (``make fit``), its resamplings as records of their own."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import model

from .. import io
from ..errors import PipelineError
from .base import MadeFrom, Record, read_json_object
from .definitions import Definitions
from .params import read_params

FIT_VERSION = 3  # 2: made_from; 3: the options, the stepwise route and the global fit each a record


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

    @property
    def interval_68(self) -> list | None:
        return self.intervals["68"]

    @property
    def widened_68(self) -> list | None:
        return self.intervals_misfit_widened["68"]


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

    @property
    def quantile_95(self) -> float:
        return self.quantiles["95"]

    @property
    def inside_95(self) -> bool:
        return self.inside["95"]

    @property
    def inside_95_widened(self) -> bool:
        return self.inside_misfit_widened["95"]


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

    parameters: dict[str, ParameterInterval]
    intervals_68: dict
    not_determined: list
    held: dict
    misfit: float
    misfit_widening: float
    misfit_noted: bool
    weakest: list[Combination]
    strongest: list[Combination]
    noise_measured: bool
    table2: Table2Test | None
    spread_over_angles: SpreadOverAngles | None = None


@dataclasses.dataclass(frozen=True)
class StepwiseRun(Record):
    """The paper's stepwise route (Sec. 4) on one reversal run: its file, seed, the fit's strain per nominal
    strain, the transient strain after the reversal, the steady packing fraction, and each estimate with its
    standard error (``estimates``: name and ``name_se``, held flat in the file)."""

    WHAT = "stepwise run"
    REST = "estimates"

    path: str
    seed: int
    bulk_over_nominal: float
    transient_strain: float
    steady_packing_fraction: float
    C_eq15_by_reversal: list
    estimates: dict[str, float]


@dataclasses.dataclass(frozen=True)
class StepwiseEstimate(Record):
    """A stepwise estimate over the reversal runs: its value (their mean), standard error (NaN, from nowhere: None,
    for one run of one cycle), where the error comes from, and each run's value."""

    WHAT = "stepwise estimate"

    value: float
    standard_error: float
    error_from: str | None
    per_run: list


@dataclasses.dataclass(frozen=True)
class Sensitivity(Record):
    """The stepwise estimates' means against the route's choices: per smoothing window (strain) and per number of
    relaxation strains of transient (each a mapping of estimate to value), and Eq. 15's C per strain window."""

    WHAT = "sensitivity"

    smoothing_window: dict
    transient_efolds: dict
    eq15_window: dict


@dataclasses.dataclass(frozen=True)
class CrossCheck(Record):
    """Sec. 3.3 on one run: C and Y = n + m S from Eq. 14's 12 and 32 components at the ``samples`` instants where
    they can be told; C's median, quartiles and standard error (NaN for one cycle), n and m with their errors
    (None where fewer than three instants can be told)."""

    WHAT = "cross-check"

    path: str
    theta_deg: float
    samples: int
    C_median: float | None = None
    C_quartiles: list | None = None
    C_se: float | None = None
    n: float | None = None
    n_se: float | None = None
    m: float | None = None
    m_se: float | None = None


@dataclasses.dataclass(frozen=True)
class ResidualCell(Record):
    """A cell of the global fit's residual map: a protocol, a quantity, a window of strain since a change of
    direction; its samples, chi^2, share of the whole chi^2 and chi^2 per sample over the mean."""

    WHAT = "residual cell"

    theta_deg: float
    rotate_at: float
    quantity: str
    window: list
    samples: int
    chi2: float
    share: float
    per_sample_over_mean: float


@dataclasses.dataclass(frozen=True)
class OwnReversal(Record):
    """The model's own reversal cycle (theta = 180) with a fit's parameters: the rate a1 + a2 |A| at which the
    fabric leaves the reversal, the peak |A| over the cycle per the steady |A|, or why they cannot be computed."""

    WHAT = "own reversal"

    start_rate: float | None
    peak_over_steady: float | None
    error: str | None


@dataclasses.dataclass(frozen=True)
class FitRow(Record):
    """One global fit of a table (``make fit-definitions``, ``make fit-from``): its definitions, the stress fitted,
    the weighting, the restart strain and persistence exponent; Table 2's parameters' values (``params``), standard
    errors and status; the whole parameter set (``model_params``), misfit, chi^2, Table 2's test, the share of chi^2
    within 0.05 strain after a change, the model's own reversal, the mean packing fraction; ``runs``: how many runs
    it fitted (the restart table's)."""

    WHAT = "fit row"
    OMIT_NONE = True

    definitions: Definitions
    stress_fitted: str
    weight: str
    fit_from: float
    persistence_exponent: float
    dilatancy_note: str
    params: dict
    model_params: model.Params
    standard_errors: dict
    status: dict
    misfit: float
    chi2: float
    table2: Table2Test | None
    chi2_share_after_changes: float
    own_reversal: OwnReversal
    mean_packing_fraction: float
    runs: int | None = None


def read_fit_rows(path: Path, make: str) -> list[FitRow]:
    """A table of fits (``definitions.json``, ``fit_from.json``) as its rows."""
    return [FitRow.from_dict(row, path) for row in read_json_object(path, "table of fits", make, list)]


@dataclasses.dataclass(frozen=True)
class FitOptions(Record):
    """What shaped a fit: its method, the definitions its runs were read with, the stress it fitted, how runs
    share it, the parameters held (name to value), the restart strain after each change of direction, the
    persistence exponent k and the window (strain) of the Jaumann rate's derivatives."""

    WHAT = "fit's options"

    method: str
    definitions: Definitions
    stress_fitted: str
    weight: str
    held: dict[str, float]
    fit_from: float
    persistence_exponent: float
    jaumann_window_strain: float


@dataclasses.dataclass(frozen=True)
class Stepwise(Record):
    """The paper's stepwise route (Sec. 4): each reversal run's estimates, their combination, its sensitivity to
    the route's choices, Sec. 3.3's cross-check on each run at another angle, and the parameter set it gives (None
    where the estimates are no valid set)."""

    WHAT = "stepwise calibration"

    runs: list[StepwiseRun]
    estimates: dict[str, StepwiseEstimate]
    sensitivity: Sensitivity | None
    cross_check: list[CrossCheck]
    params: model.Params | None


@dataclasses.dataclass(frozen=True)
class GlobalRefinement(Record):
    """The global least-squares refinement (the file's ``global``): the runs it fitted, its estimates, where its
    chi^2 lies (the residual map), and the runs it could add next, best first (empty where not ranked: parameters
    held, or the noise not measured)."""

    WHAT = "global refinement"

    runs: list[str]
    estimates: Estimates
    residual_map: list[ResidualCell]
    next_runs: list[CandidateRun]


@dataclasses.dataclass(frozen=True)
class FitSummary(Record):
    """``fit.json``: the calibration of one data set (``make fit``). ``params`` are the fit's: the global
    refinement's (the file's ``global``) with Eq. 18's dilatancy, or the stepwise route's without one;
    ``identifiability`` what the data fix; ``noise`` the noise model; ``notes`` what the numbers hold to."""

    VERSION = FIT_VERSION
    WHAT = "fit summary"
    RENAMED = {"global": "global_fit"}

    options: FitOptions
    stepwise: Stepwise
    params: model.Params
    global_fit: GlobalRefinement | None
    dilatancy: Estimates | None
    noise: NoiseSummary | None
    identifiability: Identifiability | None
    bootstrap: Bootstrap | None
    jackknife: Jackknife | None
    notes: list[str]
    made_from: MadeFrom

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
    made_from = fit.made_from
    given = read_params(params_path)
    if given.params.to_dict() != fit.params.to_dict():
        raise PipelineError(f"{params_path} does not hold the parameters {fit_path.name} beside it fitted (edited by "
                            "hand, or another fit's): make fit again, or give your own set from another folder")
    recorded = (given.metadata or {}).get("made_from")
    if recorded is not None and recorded != made_from.digest():
        raise PipelineError(f"{params_path} and {fit_path.name} come from two fits: make fit again")
    made_from.require_unchanged(f"{fit_path.parent} was fitted on runs", "fit")
