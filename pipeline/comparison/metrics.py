"""Model against DEM, on arrays: the model's cycle for a run's protocol and the measures that compare them.

The model runs in the fit's strain measure (``FitCycle.prediction``),
so its cycle is compared sample by sample with the DEM's cycle average. The error of a component is
the RMSE over the cycle divided by the steady value of that component's family (the largest |A12|
or |tau12/p| of the cycle).
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

import model

from ..calibration.fit_cycle import FitCycle
from ..dataset.derived import cycle_indices
from ..dataset.smoothing import relaxation_strain
from ..schema.metrics import ErrorRange, ErrorRow, MemoryRow, Overshoot, OvershootRow, SecondLaw, SeedSpread

COMPONENTS = {"A12": ("A", 0, 1), "A32": ("A", 2, 1), "tau12": ("tau", 0, 1), "tau32": ("tau", 2, 1)}
#: strain after a change of direction where the DEM's component along the new direction peaks (θ = 120°, 150°)
OVERSHOOT_EARLY = (0.15, 0.30)
#: the last strain of a segment, whose mean is the segment's steady value
OVERSHOOT_LATE = 0.2
#: strain windows after a change of direction over which the fabric's memory of the old direction is followed
MEMORY_WINDOWS = ((0.05, 0.10), (0.10, 0.20), (0.20, 0.30))
#: strain after a change over which compare.h5 keeps the memory's curve
MEMORY_SPAN = 0.5


def model_for(run, sets: dict) -> dict[str, tuple[FitCycle, model.Result]]:
    """The run's cycle as the fit sees it (built once), and each parameter set's prediction at its samples."""
    data = FitCycle.from_run(run)
    return {label: (data, data.prediction(params)) for label, params in sets.items()}


def bulk_over_nominal(preds: dict[str, tuple[FitCycle, model.Result]]) -> float:
    """The fit's strain per nominal strain of the run ``model_for`` predicted (its cycle's, one for every set)."""
    return next(iter(preds.values()))[0].bulk_over_nominal


def errors(data: FitCycle, pred: model.Result) -> dict[str, float]:
    """RMSE over the cycle of A12, A32, tau12/p, tau32/p, normalised by the steady |A12| or |tau12/p|."""
    steady = {"A": np.max(np.abs(data.A[:, 0, 1])), "tau": np.max(np.abs(data.tau[:, 0, 1]))}
    out = {}
    for name, (field, i, j) in COMPONENTS.items():
        dem = getattr(data, field)[:, i, j]
        mod = getattr(pred, field)[:, i, j]
        out[name] = float(np.sqrt(np.mean((mod - dem) ** 2)) / steady[field])
    return out


def error_rows(runs: list, predictions: list) -> list[ErrorRow]:
    """``errors`` of every run (named by its file, with its seed) against each parameter set's prediction
    (``model_for``'s, one per run)."""
    return [ErrorRow(Path(run.path).stem, run.spec.seed, label, errors(data, pred))
            for run, preds in zip(runs, predictions, strict=True) for label, (data, pred) in preds.items()]


def seed_spread(rows: list[ErrorRow]) -> list[SeedSpread]:
    """Per run and parameter set measured at several seeds (``error_rows``' rows): the seeds, and each component's
    mean, least and largest error over them. With two or three seeds the range is what they show; no spread is
    drawn from so few."""
    groups: dict[tuple, list[ErrorRow]] = {}
    for row in rows:
        groups.setdefault((row.run, row.parameters), []).append(row)
    return [SeedSpread(run, label, sorted(r.seed for r in group),
                       {k: ErrorRange(float(np.mean([r.errors[k] for r in group])), min(r.errors[k] for r in group),
                                      max(r.errors[k] for r in group)) for k in COMPONENTS})
            for (run, label), group in groups.items() if len(group) > 1]


def per_run(measure, runs: list, predictions: list) -> list[dict]:
    """The rows of ``measure(run, preds)`` (``overshoots``, ``memory_curves``) of every run, in order."""
    return [row for run, preds in zip(runs, predictions, strict=True) for row in measure(run, preds)]


def beside_first(first: list, more: list) -> list:
    """``first``'s rows (one seed's, per run and change of direction), each followed by ``more``'s rows of the same
    run and change (other seeds')."""
    return [row for r in first for row in (r, *(m for m in more if (m.run, m.segment) == (r.run, r.segment)))]


def backstress_share(run, C: float) -> float:
    """Share of the backstress C A12 in the steady shear stress tau12/p (paper: 88 %)."""
    c = run.cycle
    rotate_at = run.spec.rotate_at_strain
    steady = (c["strain"] > rotate_at - 0.2) & (c["strain"] < rotate_at)
    return float(np.mean(C * c["A"][steady, 0, 1]) / np.mean(c["tau_over_p"][steady, 0, 1]))


def reversal_parts(strain, tau12, A12, C: float, rotate_at: float) -> dict:
    """The second half of a theta = 180 cycle (the reversal at ``rotate_at``): strain, tau12/p, A12,
    the backstress C A12 and the isotropic part tau12/p - C A12."""
    pick = strain >= rotate_at - 1e-9
    d = {"strain": strain[pick], "tau12": tau12[pick], "A12": A12[pick]}
    d["backstress12"] = C * d["A12"]
    d["isotropic12"] = d["tau12"] - d["backstress12"]
    return d


#: strains after the reversal left out of the relaxation fits (the isotropic part's overshoot and the smoothing's
#: blur of the jump): the measure depends on it, so it is reported at each
RELAXATION_CUTS = (0.02, 0.05, 0.1)


def relaxation_strains(parts: list[dict], cut: float = RELAXATION_CUTS[0]) -> tuple[float, float]:
    """Relaxation strains of the isotropic part and the backstress after the reversal: one exponential
    fit to the mean over ``parts`` (seeds share the cycle's strain grid), from ``cut`` past the reversal on."""
    strain = parts[0]["strain"]
    return (relaxation_strain(strain, np.mean([d["isotropic12"] for d in parts], axis=0), skip=cut),
            relaxation_strain(strain, np.mean([d["backstress12"] for d in parts], axis=0), skip=cut))


@functools.lru_cache(maxsize=8)
def model_reversal(params: model.Params, rotate_at: float) -> model.Result:
    """The model's periodic theta = 180 cycle with ``params`` (read, never changed: the comparison takes several
    measures of each parameter set's cycle, and computes it once)."""
    return model.predict(180, rotate_at=rotate_at, params=params)


def model_cycle_parts(params: model.Params, rotate_at: float) -> dict:
    """``reversal_parts`` of the model's periodic theta = 180 cycle (``relaxation_strains`` of ``[it]`` measures the
    model as the DEM is measured)."""
    cycle = model_reversal(params, rotate_at)
    return reversal_parts(cycle.strain, cycle.tau[:, 0, 1], cycle.A[:, 0, 1], params.C, rotate_at)


def model_backstress_share(params: model.Params, rotate_at: float) -> float:
    """``backstress_share`` of the model's own periodic theta = 180 cycle (Table 2's: the paper's 88 %)."""
    cycle = model_reversal(params, rotate_at)
    steady = (cycle.strain > rotate_at - 0.2) & (cycle.strain < rotate_at)
    return float(np.mean(params.C * cycle.A[steady, 0, 1]) / np.mean(cycle.tau[steady, 0, 1]))


def second_law(runs: list, params: model.Params) -> SecondLaw:
    """Eq. 19 for ``params``: c1 = -C, Phi <= Phi_c + c3 over every DEM cycle, and the smallest total
    work rate of the model's cycles (Eq. 17, per unit p gamma_dot) for the runs' protocols."""
    phi_max = max(float(np.nanmax(r.cycle["packing_fraction"])) for r in runs)
    bound = params.phi_c + params.c3
    w_min = min(float(model.predict(r.spec.theta_deg, rotate_at=r.spec.rotate_at_strain,
                                    params=params).w_total.min()) for r in runs)
    return SecondLaw(params.c1, params.C, phi_max, bound, w_min,
                     bool(params.c1 == -params.C and phi_max <= bound and w_min >= 0))


def along(X: np.ndarray, phi_deg: float) -> np.ndarray:
    """The shear component of ``X`` (..., 3, 3) along the direction s = cos(phi) e1 + sin(phi) e3 (the
    README's rotation sense): s_i X_i2, i.e. X12 at phi = 0 and X32 at 90."""
    phi = np.radians(phi_deg)
    return np.cos(phi) * X[..., 0, 1] + np.sin(phi) * X[..., 2, 1]


def window(strain: np.ndarray, start: float, end: float) -> np.ndarray:
    """Mask of ``strain`` in [start, end]."""
    return (strain >= start - 1e-9) & (strain <= end + 1e-9)


def segment_windows(strain: np.ndarray, start: float, end: float) -> tuple[np.ndarray, np.ndarray]:
    """Masks of ``strain`` OVERSHOOT_EARLY after ``start`` and the last OVERSHOOT_LATE before ``end`` (the sample
    at ``end`` itself, the next change's, left out)."""
    late = (strain >= end - OVERSHOOT_LATE - 1e-9) & (strain < end - 1e-9)
    return window(strain, start + OVERSHOOT_EARLY[0], start + OVERSHOOT_EARLY[1]), late


def cycle_mean_and_error(per_cycle: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """The mean over cycles (the first axis of ``per_cycle``) and its standard error, None with one cycle."""
    n = len(per_cycle)
    return per_cycle.mean(axis=0), per_cycle.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else None


def cycle_grid(spec: dict, strain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A run's strain within the cycle and the indices of each cycle's samples (``derived.cycle_indices``)."""
    return cycle_indices(strain, spec.period_strain, spec.sample_strain, spec.n_cycles)


def changes(spec: dict):
    """The cycle's changes of direction: (label, the new segment's start and end, its direction, the old
    direction, the old segment's start and end), strains in the cycle and directions in degrees."""
    theta, turn, period = spec.theta_deg, spec.rotate_at_strain, spec.period_strain
    yield "after the turn to theta", turn, period, theta, 0.0, 0.0, turn
    yield "after the turn back", 0.0, turn, 0.0, theta, turn, period


def old_direction_curve(A: np.ndarray, strain: np.ndarray, change: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The fabric's memory of the old shear direction after ``change`` (one of ``changes``): A's shear component
    along the wall-plane direction normal to the new one (t_i A_i2, the part the new shear does not produce), as a
    fraction of what the old steady fabric (the old segment's last OVERSHOOT_LATE) puts there; 1 right at the
    change, 0 once the old direction is forgotten. Returns (strain after the change, up to MEMORY_SPAN or the
    segment's end; the fraction there), along the last axis but two of ``A`` (..., samples, 3, 3): one curve
    per cycle, or one for one series."""
    _, start, end, new, old, old_start, old_end = change
    normal = new + 90.0
    steady = along(A, old)[..., segment_windows(strain, old_start, old_end)[1]].mean()
    after = window(strain, start, min(start + MEMORY_SPAN, end))
    return strain[after] - start, along(A, normal)[..., after] / (np.cos(np.radians(normal - old)) * steady)


#: a change whose normal part is smaller (|sin| of the turn) has no memory to follow: the reversal
MEMORY_MIN_SIN = 0.25


def memory_curves(run, preds: dict[str, tuple[FitCycle, model.Result]]) -> list[dict]:
    """``old_direction_curve`` after each change of direction by an angle whose normal part is not small
    (|sin| >= 0.25: not the reversal) from an old segment long enough to be steady at its end (not Fig. 7's turn
    at 0.1 or 0.2) into a segment long enough to follow it: the DEM's per cycle, each parameter set's on the
    model's cycle."""
    spec = run.spec
    grid, idx = cycle_grid(spec, run.series["strain_nominal"])
    out = []
    for change in changes(spec):
        label, start, end, new, old, old_start, old_end = change
        if (end - start < MEMORY_WINDOWS[-1][1] or old_end - old_start < OVERSHOOT_EARLY[1] + OVERSHOOT_LATE
                or abs(np.sin(np.radians(new - old))) < MEMORY_MIN_SIN):
            continue
        strain, dem = old_direction_curve(run.series["A"][idx], grid, change)
        out.append({"run": run.path.stem, "seed": run.spec.seed, "segment": label, "from_deg": old,
                    "direction_deg": new,
                    "strain_after": strain, "dem": dem,
                    "model": {name: old_direction_curve(pred.A, data.strain, change)
                              for name, (data, pred) in preds.items()}})
    return out


def memories(curves: list[dict]) -> list[MemoryRow]:
    """The ``memory_curves``' means over each of MEMORY_WINDOWS: the DEM's as the mean over cycles with its
    standard error (None with one cycle), each parameter set's on the model's cycle."""
    def means(strain, fraction):
        return np.stack([fraction[..., window(strain, a, b)].mean(axis=-1) for a, b in MEMORY_WINDOWS], axis=-1)

    out = []
    for c in curves:
        per_cycle = means(c["strain_after"], c["dem"])
        mean, se = cycle_mean_and_error(per_cycle)
        out.append(MemoryRow(c["run"], c["seed"], c["segment"], c["from_deg"], c["direction_deg"], len(per_cycle),
                             [list(w) for w in MEMORY_WINDOWS], mean.tolist(), None if se is None else se.tolist(),
                             {name: means(*curve).tolist() for name, curve in c["model"].items()}))
    return out


def overshoots(run, preds: dict[str, tuple[FitCycle, model.Result]]) -> list[OvershootRow]:
    """After each change of direction whose segment is long enough (the turn to theta at ``rotate_at`` and the
    turn back to e1 at the period's start), the component of A and tau/p along the new shear direction, signed
    so that its steady value (the segment's last OVERSHOOT_LATE) is positive: its mean OVERSHOOT_EARLY after the
    change minus the steady value. Positive: it overshoots; negative: it has not yet arrived. The DEM's is the
    mean over cycles with its standard error (None with one cycle); each parameter set's is the same measure on
    the model's cycle."""
    spec = run.spec
    grid, idx = cycle_grid(spec, run.series["strain_nominal"])
    out = []
    for label, start, end, phi, *_ in changes(spec):
        if end - start < OVERSHOOT_EARLY[1] + OVERSHOOT_LATE or spec.theta_deg == 0:
            continue
        early, late = segment_windows(grid, start, end)
        model_windows = {name: segment_windows(data.strain, start, end) for name, (data, _) in preds.items()}
        found = {}
        for field, key in (("A", "A"), ("tau", "tau_over_p")):
            per_cycle, steady = early_minus_steady(along(run.series[key][idx], phi), early, late)
            mean, se = cycle_mean_and_error(per_cycle)
            found[field] = Overshoot(float(mean), float(steady.mean()), None if se is None else float(se),
                                     {name: float(early_minus_steady(along(getattr(pred, field), phi),
                                                                     *model_windows[name])[0])
                                      for name, (_, pred) in preds.items()})
        out.append(OvershootRow(run.path.stem, spec.seed, label, phi, len(idx), **found))
    return out


def early_minus_steady(x: np.ndarray, early: np.ndarray, late: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mean over ``early`` - mean over ``late``, the |mean over ``late``|) along the last axis of ``x``, in the
    sense of the steady value's sign (A12 < 0 < tau12 in forward shear): one per cycle, or scalars for one series."""
    steady = x[..., late].mean(axis=-1)
    sign = np.sign(steady.mean())
    return sign * (x[..., early].mean(axis=-1) - steady), sign * steady
