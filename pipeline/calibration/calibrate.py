"""Calibrate the model on DEM runs (``make fit``): the paper's stepwise route, the global fit, their intervals.

``calibrate`` computes and returns a :class:`Calibration` (nothing written); ``write`` puts it in a folder
(``params.json``, ``params_stepwise.json``, ``fit.json``, ``fit.h5``); ``pipeline.calibration.text`` prints it.
The reversals (every seed) are calibrated by the stepwise route (``stepwise``), the other angles cross-check
the flow rule (Sec. 3.3), and all of them are fitted at once (``global_fit``).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import model

from .. import choices, io, schema
from ..cli import Progress
from ..dataset.derived import PAPER_DEFINITIONS, Definitions
from ..errors import CalibrationError
from ..schema import FitSummary
from . import design, global_fit, identifiability, resampling
from .residual_map import residual_map
from .stepwise import calibrate_run, combine, cross_check_run, fitted_params, sensitivity, stepwise_bootstrap

JACKKNIFE_OVER = choices.JACKKNIFE_OVER
STEPWISE_RESAMPLES = 40  # resamplings of a single reversal run's cycles that give its stepwise errors


@dataclass(frozen=True)
class Settings:
    """How to calibrate: the Jaumann smoothing window (strain), the definitions the runs are read with, the
    parameters held (name -> value), the restart strain of the global fit past each change of direction, the
    persistence exponent k (held), the optional bootstrap (resamples), and the optional jackknife, leaving
    out one reversal seed ("seeds") or one angle with all its runs ("angles") at a time, the components of tau/p
    fitted, how a protocol's runs share the fit (``global_fit.WEIGHTS``), and the fabric law (its variant)."""

    @property
    def free(self) -> tuple[str, ...]:
        """The parameters refined: ``global_fit.FREE`` and the variant's own, less those held."""
        return tuple(n for n in global_fit.free_names(self.variant) if n not in self.hold)

    def start(self) -> model.Params:
        """Where the global fit starts: Table 2, the law's own parameters where its declaration starts them, the held
        ones at their values."""
        return global_fit.start_of(self.variant, persistence_exponent=self.persistence_exponent, **self.hold)

    window: float = 0.05
    definitions: Definitions = PAPER_DEFINITIONS
    hold: dict = field(default_factory=dict)
    fit_from: float = 0.0
    persistence_exponent: float = 0.75
    bootstrap: int = 0
    jackknife: str = ""  # "", or what to leave out one at a time: JACKKNIFE_OVER
    stress: str = global_fit.STRESS_DEFAULT  # the components of tau/p fitted (global_fit.STRESS_FITS)
    weight: str = global_fit.WEIGHT_DEFAULT  # each run counts once, or each protocol (global_fit.WEIGHTS)
    variant: str = model.params.DEFAULT_VARIANT  # the fabric law fitted (model.params.VARIANTS)

    def __post_init__(self):
        if self.variant not in model.params.VARIANTS:
            raise CalibrationError(f"variant={self.variant!r}: the fabric law is one of "
                                   f"{', '.join(model.params.VARIANTS)}")
        global_fit.check_stress(self.stress)
        global_fit.check_weight(self.weight)
        if not math.isfinite(self.window) or self.window <= 0:
            raise CalibrationError(f"window={self.window} must be a positive strain")
        if not math.isfinite(self.fit_from) or not 0 <= self.fit_from < 0.5:
            raise CalibrationError(f"fit_from={self.fit_from} must be a strain in [0, 0.5)")
        if self.jackknife not in ("", *JACKKNIFE_OVER):
            raise CalibrationError(f"jackknife={self.jackknife!r}: leave out one of {' or '.join(JACKKNIFE_OVER)}")
        if not math.isfinite(self.persistence_exponent) or not 0 < self.persistence_exponent <= 2:
            raise CalibrationError(f"persistence_exponent={self.persistence_exponent} must lie in (0, 2]")


def parse_hold(items: list[str]) -> dict:
    """``["a2=0.25", ...]`` -> ``{"a2": 0.25}``; a malformed item is a one-line ``CalibrationError``."""
    hold = {}
    for item in items:
        name, _, value = item.partition("=")
        try:
            hold[name] = float(value)
        except ValueError:
            raise CalibrationError(f"--hold {item!r} is not NAME=VALUE with a number") from None
    return hold


@dataclass(frozen=True)
class Calibration:
    """Everything a calibration found. ``params`` is the result (the global fit with Eq. 18's dilatancy, or the
    stepwise route's without a global fit); ``to_dict`` is ``fit.json``."""

    settings: Settings
    params: model.Params
    stepwise: model.Params | None
    per_run: list
    cross_check: list
    estimates: dict
    sensitivity: dict
    refined: global_fit.GlobalFit | None
    dilatancy: global_fit.GlobalFit | None
    noise: object | None
    identifiability: schema.Identifiability | None
    next_runs: list
    bootstrap: schema.Bootstrap | None
    jackknife: schema.Jackknife | None
    global_runs: list
    notes: list
    residual_map: list | None = None
    arrays: dict = field(repr=False, default_factory=dict)
    made_from: schema.MadeFrom | None = None

    def summary(self) -> FitSummary:
        """``fit.json``'s content (``pipeline.schema.FitSummary``)."""
        s = self.settings
        method = "stepwise (paper Sec. 4: Eqs. 9, 12, 15, 16, 18), then a global least-squares refinement"
        options = schema.FitOptions(method, s.definitions, s.stress, s.weight, dict(s.hold), s.fit_from,
                                    s.persistence_exponent, s.window)
        stepwise = schema.Stepwise.from_dict({"runs": self.per_run, "estimates": self.estimates,
                                              "sensitivity": self.sensitivity, "cross_check": self.cross_check,
                                              "params": self.stepwise and self.stepwise.to_dict()})
        refined = None if self.refined is None else schema.GlobalRefinement(
            self.global_runs, self.refined.estimates(), self.residual_map, list(self.next_runs))
        return FitSummary(options, stepwise, self.params, refined,
                          None if self.dilatancy is None else self.dilatancy.estimates(),
                          None if self.noise is None else self.noise.summary(), self.identifiability,
                          self.bootstrap, self.jackknife, list(self.notes), self.made_from)

    def params_metadata(self) -> dict | None:
        """What ``params.json`` records beside the values: the fit, its definitions and intervals."""
        if self.identifiability is None:
            return None
        return {"fit": "global (pipeline.calibration.global_fit)", "made_from": self.made_from.digest(),
                "definitions": dataclasses.asdict(self.settings.definitions), "held": self.settings.hold,
                "intervals_68": self.identifiability.intervals_68,
                "not_determined": self.identifiability.not_determined, "misfit": self.refined.misfit}


def check_distinct(runs: list) -> None:
    """Refuse a run given twice (the same spec, seed included, is the same run): it would count as two seeds."""
    seen = {}
    for run in runs:
        key = json.dumps(run.spec.to_dict(), sort_keys=True)
        if key in seen:
            raise CalibrationError(f"{run.path} is the same run as {seen[key]} (same spec and seed): give it once")
        seen[key] = run.path


def check_window(window: float, runs: list) -> None:
    shortest = min(min(r.spec.rotate_at_strain, r.spec.period_strain - r.spec.rotate_at_strain)
                   for r in runs)
    if not (math.isfinite(window) and 0 < window < shortest):
        raise CalibrationError(f"window={window} must be a positive strain shorter than the shortest segment "
                               f"of a cycle ({shortest:g})")


def check_settings(settings: Settings, reversals: list, cross_runs: tuple) -> None:
    """Every refusal before any long work, each a one-line ``CalibrationError``."""
    free = global_fit.free_names(settings.variant)
    unknown = sorted(set(settings.hold) - set(free))
    if unknown:
        raise CalibrationError(f"cannot hold {', '.join(unknown)}: only {', '.join(free)} can be held")
    if not reversals:
        raise CalibrationError("no reversal run found (theta = 180): run `make dem THETA=180 PRESET=...` first")
    not_reversals = [f"{r.path} (theta = {r.spec.theta_deg})" for r in reversals if not r.is_reversal]
    if not_reversals:
        raise CalibrationError(f"not a reversal run: {', '.join(not_reversals)}")
    check_distinct([*reversals, *cross_runs])
    check_window(settings.window, [*reversals, *cross_runs])
    if settings.bootstrap and settings.bootstrap < 2:
        raise CalibrationError(f"bootstrap={settings.bootstrap}: a bootstrap needs at least 2 resamples")
    if settings.jackknife:
        groups = jackknife_groups(settings.jackknife, reversals, cross_runs)
        if len(groups) < 3:
            raise CalibrationError(f"a jackknife over {settings.jackknife} needs at least 3 of them, not "
                                   f"{len(groups)} ({', '.join(groups) or 'none'})")
    if settings.fit_from and settings.bootstrap:
        raise CalibrationError("a bootstrap of a restarted fit (fit_from > 0) is not implemented: leave one out")
    if settings.bootstrap and not any(r.spec.n_cycles > 1 for r in (*reversals, *cross_runs)):
        raise CalibrationError("a bootstrap needs runs with more than one cycle (the noise is measured from them)")


def jackknife_groups(over: str, reversals: list, cross_runs: tuple) -> dict[str, list[int]]:
    """The runs a jackknife leaves out together, as indices into ``[*reversals, *cross_runs]``: each reversal
    seed alone (``"seeds"``), or each angle with all its runs (``"angles"``: every seed of the reversal goes
    out at once)."""
    if over == "seeds":
        return {f"seed {r.spec.seed}": [i] for i, r in enumerate(reversals)}
    groups: dict[str, list[int]] = {}
    for i, r in enumerate([*reversals, *cross_runs]):
        groups.setdefault(f"theta = {r.spec.theta_deg:g}", []).append(i)
    return groups


def calibrate(reversals: list, cross_runs: tuple = (), left_out: tuple = (), settings: Settings = Settings(),
              refine: bool = True) -> Calibration:
    """Calibrate from ``reversals``, cross-check on ``cross_runs`` (other angles, Sec. 3.3) and refine globally
    on all of them (from Table 2, the held parameters at their values), every run read with the settings'
    definitions. ``left_out``: runs the fit does not use (the Fig. 7 rotations), named among the candidates
    of ``next_runs``."""
    hold = dict(settings.hold)
    reversals = [r.with_definitions(settings.definitions) for r in reversals]
    cross_runs = tuple(r.with_definitions(settings.definitions) for r in cross_runs)
    check_settings(settings, reversals, cross_runs)
    start, free = settings.start(), settings.free
    window = settings.window
    per_run_full = [calibrate_run(run, window=window) for run in reversals]
    cross_full = [cross_check_run(run, window=window) for run in cross_runs]
    arrays = {"reversal": [r["arrays"] for r in per_run_full], "cross_check": [c["arrays"] for c in cross_full]}
    per_run = [{k: v for k, v in r.items() if k != "arrays"} for r in per_run_full]
    cross = [{k: v for k, v in c.items() if k != "arrays"} for c in cross_full]
    refined = dilatancy = boot = noise = identifiable = jack = undetermined_dilatancy = None
    next_runs = []
    if refine:
        data, noise = global_fit.prepare([*reversals, *cross_runs], settings.fit_from, settings.stress,
                                         settings.weight)
        refined = global_fit.refine(data, start, free, noise=noise)
        try:
            dilatancy = global_fit.refine_dilatancy(data, refined.params)
        except CalibrationError as exc:  # e.g. reversals alone: Phi_c runs off to a bound along c2_coef
            undetermined_dilatancy = str(exc)
        identifiable = identifiability.summary(refined, data, hold, measured=noise.measured)
        if not hold and noise.measured:
            next_runs = design.rank(refined, noise, [*reversals, *cross_runs],
                                    [r.with_definitions(settings.definitions) for r in left_out], data,
                                    settings.stress, settings.weight)
        if settings.bootstrap:
            boot = dataclasses.replace(
                resampling.bootstrap(data, noise, refined, settings.bootstrap, progress=Progress("bootstrap")),
                stepwise=stepwise_bootstrap(reversals, settings.bootstrap, window))
        if settings.jackknife:
            jack = resampling.jackknife(data, jackknife_groups(settings.jackknife, reversals, cross_runs), refined,
                                        noise, progress=Progress("jackknife"), weight=settings.weight,
                                        over=settings.jackknife)
        angles = jackknife_groups("angles", reversals, cross_runs) if identifiable.misfit_noted else {}
        if len(angles) >= 3:  # the model misses the runs: the noise's ± would mislead
            spread = jack if settings.jackknife == "angles" else resampling.jackknife(
                data, angles, refined, noise, progress=Progress("the model misses the runs: refit without angle"),
                weight=settings.weight)
            identifiable = dataclasses.replace(identifiable,
                                               spread_over_angles=identifiability.spread_over_angles(spread))
    resampled = None
    if len(reversals) == 1 and reversals[0].spec.n_cycles > 1:  # one run: its error from its cycles
        resampled = boot.stepwise if boot else stepwise_bootstrap(reversals, STEPWISE_RESAMPLES, window)
    estimates = combine(per_run, resampled)
    bad = [k for k in ("C_eq15", "n", "m", "a1", "b1", "a2", "b2") if not math.isfinite(estimates[k]["value"])]
    if bad:
        raise CalibrationError(f"the fit gave no finite value for {', '.join(bad)}")
    notes = ["C is Eq. 15's slope: on model data it returns C - 2m (Y still drifts near steady state)",
             "c3 is held at the paper's 0.14; c2_exponent and the persistence exponent at 1/3 and "
             f"{settings.persistence_exponent:g}"]
    try:
        stepwise = fitted_params(estimates)
    except model.ParameterError as exc:  # the paper's route can land outside the model's domain on noisy cells
        if refined is None:
            raise CalibrationError(f"the stepwise calibration gives no valid parameters ({exc})") from None
        stepwise = None
        notes.append(f"the stepwise estimates are no valid parameter set ({exc}): no params_stepwise.json")
    if undetermined_dilatancy:
        notes.append(f"Eq. 18's c2_coef and Phi_c are not determined by these runs ({undetermined_dilatancy}): "
                     "params.json keeps their defaults (Table 2's), with c1 = -C (Eq. 19); runs at other angles "
                     "fix them")
    result = stepwise if refined is None else (global_fit.with_eq19_c1(refined.params) if dilatancy is None
                                               else dilatancy.params)
    return Calibration(settings, result, stepwise, per_run, cross,
                       estimates, sensitivity(reversals), refined, dilatancy, noise, identifiable, next_runs, boot,
                       jack, [str(r.path) for r in (*reversals, *cross_runs)] if refine else [], notes,
                       residual_map(refined, data) if refined is not None else None, arrays,
                       schema.MadeFrom.of([r.path for r in (*reversals, *cross_runs, *left_out)],
                                          {**dataclasses.asdict(settings), "refine": refine}))


def write_arrays(path: Path, arrays: dict, per_run: list[dict], cross: list[dict], made_from: str) -> None:
    """fit.h5: the per-sample values behind the fit (alpha_i, beta_i, Y, C against S), stamped with the digest of
    its fit's ``made_from`` (``fit.json``'s), so that a fit.h5 of another fit is told apart."""
    with io.h5_file(path) as f:
        f.attrs.update(schema="granular-backstress/fit", schema_version=1, made_from=made_from)
        for group, items, meta in (("reversal", arrays["reversal"], per_run),
                                   ("cross_check", arrays["cross_check"], cross)):
            for k, (values, info) in enumerate(zip(items, meta, strict=True)):
                g = f.create_group(f"{group}/{k}")
                g.attrs["path"] = info["path"]
                if "theta_deg" in info:
                    g.attrs["theta_deg"] = info["theta_deg"]
                for name, data in values.items():
                    g.create_dataset(name, data=data).attrs["unit"] = "1"


def write(cal: Calibration, out_dir: Path) -> None:
    """``fit.h5``, ``params_stepwise.json`` (when the stepwise route gives a valid set), ``params.json`` and
    ``fit.json`` in ``out_dir``, renamed into place together: an interrupt leaves the previous complete set."""
    io.check_writable_dir(out_dir)
    names = ["fit.h5", "params.json", "fit.json"] + (["params_stepwise.json"] if cal.stepwise is not None else [])
    with io.atomic_paths(*(out_dir / n for n in names)) as temps:
        tmp = dict(zip(names, temps, strict=True))
        write_arrays(tmp["fit.h5"], cal.arrays, cal.per_run, cal.cross_check, cal.made_from.digest())
        schema.write_params(tmp["params.json"], cal.params, cal.params_metadata())
        schema.write_fit(tmp["fit.json"], cal.summary())
        if cal.stepwise is not None:
            io.write_bytes(tmp["params_stepwise.json"], cal.stepwise.to_json().encode())
    if cal.stepwise is None:
        (out_dir / "params_stepwise.json").unlink(missing_ok=True)


def fit(reversals: list, out_dir: Path, cross_runs: tuple = (), left_out: tuple = (), refine: bool = True,
        data_set: dict | None = None, **settings) -> dict:
    """``calibrate`` with ``Settings(**settings)`` and ``write`` into ``out_dir`` (both checked first); returns
    ``fit.json``'s dict. ``data_set`` (its folder and the cycles it skips) joins the options its ``made_from``
    records, which the stages that read the fit check."""
    chosen = Settings(**settings)
    check_settings(chosen, reversals, tuple(cross_runs))
    io.check_writable_dir(out_dir)
    cal = calibrate(reversals, tuple(cross_runs), tuple(left_out), chosen, refine)
    if data_set:
        cal = dataclasses.replace(cal, made_from=schema.MadeFrom(cal.made_from.inputs,
                                                                 {**cal.made_from.options, **data_set}))
    write(cal, out_dir)
    return cal.summary()
