"""report.md from ``metrics.json`` and ``fit.json``: our parameters beside Table 2, the model-vs-DEM
errors per run and their range over seeds, the overshoot and the memory of the old direction after each change of
direction, the backstress share, Phi, the second law, the relaxation strains, the stepwise route's sensitivity. It
formats numbers; it computes none."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import model

from ..dataset import drift
from ..io import write_text
from ..schema import (
    CutRelaxation,
    DriftRow,
    FitRow,
    FitSummary,
    Identifiability,
    MemoryRow,
    Metrics,
    OvershootRow,
    Reversal,
    SecondLaw,
    SeedSpread,
    Sensitivity,
    Strains,
)


def _strain_text(value: float) -> str:
    return f"{value:.2f}" if value is not None and np.isfinite(value) else "not resolved"


def sensitivity_lines(sens: Sensitivity) -> list[str]:
    """The stepwise estimates against the smoothing window, and Eq. 15's C against its strain window."""
    keys = ("C_eq15", "n", "m", "a1", "b1", "a2", "b2", "persistence_exponent_alpha1", "persistence_exponent_alpha2")
    heads = ("C (Eq. 15)", "n", "m", "a1", "b1", "a2", "b2", "k from alpha1", "k from alpha2")
    lines = ["## Stepwise calibration (paper Sec. 4) against its choices", "",
             "Mean over the reversal runs, per Savitzky-Golay window (strain) used for the smoothing and the "
             "Jaumann rate:", "", "| window | " + " | ".join(heads) + " |", "|---|" + "---|" * len(heads)]
    for window, values in sens.smoothing_window.items():
        lines.append(f"| {window} | " + " | ".join(f"{values[k]:+.3g}" for k in keys) + " |")
    lines += ["", "The fabric law per strain after each change of direction used by the beta_i fits (in 1/e "
              "relaxation strains of A12 after the reversal; default 2):", "",
              "| e-folds | a1 | b1 | a2 | b2 |", "|---|---|---|---|---|"]
    for efolds, values in sens.transient_efolds.items():
        lines.append(f"| {efolds} | " + " | ".join(f"{values[k]:+.3g}" for k in ("a1", "b1", "a2", "b2")) + " |")
    lines += ["", "C from Eq. 15 per strain window after the reversal: " + ", ".join(
        f"{w}: {c:+.2f}" for w, c in sens.eq15_window.items()) + " (on model data Eq. 15 gives C - 2m)."]
    return lines


def second_law_line(law: SecondLaw) -> str:
    return (f"- second law (Eq. 19) with our fit: c1 = {law.c1:.3f} = -C; max Phi of the DEM cycles "
            f"{law.phi_max_dem:.3f} against Phi_c + c3 = {law.phi_c_plus_c3:.3f}; smallest total work rate of "
            f"the model's cycles {law.min_total_work_rate:+.3f} p gamma_dot ({'holds' if law.holds else 'VIOLATED'})")


def band_text(band) -> str:
    return "open" if band is None else f"{band[0]:+.4g} to {band[1]:+.4g}"


def misfit_sentence(ident: Identifiability) -> str:
    """What the intervals mean where the model misses the runs (``identifiability.summary``'s ``misfit_noted``)."""
    spread = ident.spread_over_angles
    angles = (f"The last column is the range of the refits that leave out each of the {len(spread.left_out)} "
              "angles in turn: where it is wider than the intervals, which angles are in the data set moves the "
              "parameter more than the noise does" if spread else "Refits without one angle can move further")
    return (f" **The model misses these runs by √misfit = {ident.misfit_widening:.2f} times their noise**: the "
            "intervals from the noise alone describe the noise, not what other runs would give. The widened ones "
            "take the misfit as if it were noise (the most lenient reading). Both assume that one parameter set "
            f"fits every run. {angles} (`make fit-jackknife OVER=angles`: each refit's shift).")


#: Table 2's parameters that ``make fit`` fits, shown where the fit's summary says nothing of them
TABLE2_FITTED = ("C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")


def fitted_names(fitted, ident: Identifiability | None, se: dict) -> list[str]:
    """The parameters the fit set, in the law's order (``Params.own_names``): those with an interval or a standard
    error (Table 2's fitted ones where the summary has none), and every one the law adds to Eq. 13."""
    known = (set(ident.parameters if ident else {}) | set(se)) or set(TABLE2_FITTED)
    return [n for n in fitted.own_names() if n in known or n not in model.Params.names()]


def parameter_lines(fitted, paper, fit: FitSummary | None) -> list[str]:
    """Our parameters (every one the fitted law owns and the fit set) with their 68 % intervals and status beside
    Table 2; what the data fix; Table 2's test."""
    ident = fit.identifiability if fit else None
    params = ident.parameters if ident else {}
    dilatancy = fit.dilatancy if fit else None
    se = dict(zip(dilatancy.free, dilatancy.standard_errors, strict=True)) if dilatancy else {}
    ours = {n: getattr(fitted, n) for n in fitted.own_names()}
    table2 = {n: f"{getattr(paper, n):+.4g}" if n in paper.own_names() else "–" for n in fitted.own_names()}
    noted = bool(ident and ident.misfit_noted)
    spread = ident.spread_over_angles.ranges if ident and ident.spread_over_angles else {}  # where the misfit is noted
    extra = ([f" 68 %, widened × {ident.misfit_widening:.2f} (√misfit) |"] if noted else []) + (
        [" refits without one angle |"] if spread else [])
    lines = [f"| parameter | our fit | 68 % interval | status |{''.join(extra)} Table 2 |",
             "|---|---|---|---|" + "---|" * len(extra) + "---|"]
    for name in fitted_names(fitted, ident, se):
        p = params.get(name)
        if p:
            cells = ([f" {band_text(p.widened_68)} |"] if noted else []) + (
                [f" {band_text(spread.get(name))} |"] if spread else [])
            lines.append(f"| {name} | {ours[name]:+.4g} | {band_text(p.interval_68)} | {p.status} |"
                         f"{''.join(cells)} {table2[name]} |")
        else:
            scatter = f"± {se[name]:.2g} (Φ scatter taken as white)" if name in se else ""
            lines.append(f"| {name} | {ours[name]:+.4g} | {scatter} | |{' |' * len(extra)} {table2[name]} |")
    if not ident:
        return lines
    g, noise = fit.global_fit, fit.noise
    if not ident.noise_measured:
        return lines + ["", f"No intervals: {noise.source}. Two cycles per run, or three seeds, let the noise be "
                        "measured."]
    lengths = [v for values in noise.correlation_strain.values() for v in values]
    lines += ["", f"Intervals from the DEM's own noise ({noise.source}; correlated over "
              f"{min(lengths):.2f}-{max(lengths):.2f} strain, A and tau/p noise correlated at "
              f"{min(noise.A_tau_correlation):+.2f} to {max(noise.A_tau_correlation):+.2f}), "
              f"not scaled by the misfit. Misfit: {g.estimates.misfit:.2f} (chi^2 per degree of freedom in noise "
              "units; 1 = the model fits within the noise). `make fit-profile` gives the profile intervals, "
              "`make fit-bootstrap` a bootstrap of the noise."
              + (misfit_sentence(ident) if noted else ""), "",
              "## What the data fix", "",
              "Eigen-directions of the covariance in relative parameters: a direction stands for the product of "
              "the powers shown, and its ± is one standard deviation of that product, relative.", "",
              "| | combination | ± (relative) |", "|---|---|---|"]
    for label, items in (("best fixed", ident.strongest), ("least fixed", ident.weakest)):
        lines += [f"| {label} | {c.combination} | {c.relative_step:.2g} |" for c in items]
    if ident.not_determined:
        lines += ["", f"Not determined by these runs: {', '.join(ident.not_determined)}."]
    t = ident.table2
    if t and t.quantiles:
        verdict = {True: "inside", False: "outside"}
        lines += ["", f"Table 2 as a hypothesis (its C, n, m, a_i, b_i on these data): chi^2 {t.relative_rise:+.1%} "
                  f"above the best fit, a rise of {t.chi2_rise:.0f} against {t.quantile_95:.0f} for the "
                  f"95 % region from the noise: {verdict[t.inside_95]} it; "
                  f"{verdict[t.inside_95_widened]} it when the region is widened by the misfit."]
    return lines + next_runs_lines(fit)


def same_weighting(rows: list[FitRow], fit: FitSummary | None) -> bool:
    """Whether the rows of ``make fit-from`` (``fit_from.json``) weighed the runs as the fit in ``fit.json`` did."""
    return all(r.weight == (fit.options.weight if fit else "runs") for r in rows)


def fit_runs_sentence(fit: FitSummary | None) -> str:
    """How many runs the global fit took (``fit.json`` → ``global`` → ``runs``) and how it weighed them."""
    runs = fit.global_fit.runs if fit and fit.global_fit else None
    if not runs:
        return ""
    return (f" The fit took {len(runs)} run(s), every seed of the reversal and of each angle rotated at half the "
            "period, " + ("each angle counted once (WEIGHT=angles)." if fit.options.weight == "angles"
                          else "each run counted once."))


def next_runs_lines(fit: FitSummary) -> list[str]:
    """The best new runs per CPU-hour (``fit.json`` → ``global`` → ``next_runs``), each joined to the fit's runs
    with its weighting."""
    candidates = fit.global_fit.next_runs
    runs = [r for r in candidates if r.error is None]  # last: those that cannot be weighed
    if not runs:
        return ["", "## Runs that would fix the weakest combination best per CPU-hour", "",
                f"None can be told: no candidate can be weighed at the best fit (the first, "
                f"{candidates[0].run}: {candidates[0].error}; fit.json: global, next_runs)."] if candidates else []
    return ["", "## Runs that would fix the weakest combination best per CPU-hour", "",
            f"Its relative ± is {runs[0].weakest_before:.3g} now (fit.json: global, next_runs, every candidate); each "
            "run is joined to the fit's runs"
            + (" with each angle counted once, so another seed of an angle shares that angle's weight."
               if fit.options.weight == "angles" else ", each counting once."), "",
            "| run | weakest ± after | largest relative ± after | CPU-hours |", "|---|---|---|---|",
            *(f"| {r.run} | {r.weakest_after:.3g} | {r.worst_relative_se_after:.3g} | "
              f"{r.cpu_hours:.2f} |" for r in runs[:6])]


def jump_lines(rows: list[FitRow], paper: model.Params) -> list[str]:
    """``make fit-from``'s fits against the restart strain gamma0 (at k = 3/4): how much of the distance to Table 2
    the reversal jump is."""
    shown = ("C", "n", "m", "a1", "b1", "a2", "b2")
    rows = [r for r in rows if r.persistence_exponent == 0.75]
    lines = ["## The distance to Table 2, and the reversal jump", "",
             "The global fit restarted from the DEM's state gamma0 past each change of direction (make fit-from; "
             "the paper's definitions, k = 3/4): gamma0 = 0 is the whole cycle, where the fabric's fast initial drop "
             "is absorbed into the a_i; a gamma0 between the 0.005 grid's points fits only the runs with dense "
             "samples. Each cell: value and its distance to Table 2 in standard errors.", "",
             "| gamma0 | runs | " + " | ".join(shown) + " | Table 2: chi^2 rise | misfit |",
             "|---|---|" + "---|" * (len(shown) + 2)]
    for r in rows:
        cells = []
        for n in shown:
            value, se = r.params[n], r.standard_errors[n]
            z = (value - getattr(paper, n)) / se if se and np.isfinite(se) and se > 0 else np.nan
            cells.append(f"{value:+.4g} ({z:+.1f})" if np.isfinite(z) else f"{value:+.4g} (open)")
        lines.append(f"| {r.fit_from:g} | {r.runs} | " + " | ".join(cells) + f" | {r.table2.relative_rise:+.1%} | "
                     f"{r.misfit:.2f} |")
    return lines


def run_label(row: OvershootRow | MemoryRow, rows: list) -> str:
    """A table row's run, with its seed where the table has the run at several seeds, and its cycles."""
    seeds = {r.seed for r in rows if r.run == row.run}
    return row.run + (f", seed {row.seed}" if len(seeds) > 1 else "") + f" ({row.cycles} cycles)"


def overshoot_lines(rows: list[OvershootRow], labels: list[str]) -> list[str]:
    """The overshoot table: DEM (± its standard error over cycles) and each parameter set, per change."""
    head = " | ".join(f"{field} {who}" for field in ("A", "tau/p") for who in ("DEM", *labels))
    lines = ["## Overshoot after a change of direction", "",
             "The component along the new shear direction (A and tau/p, s_i X_i2), signed so that its steady value "
             "(its mean over the segment's last 0.2 strain) is positive: its mean 0.15-0.30 strain after the change "
             "minus the steady value. Positive: it overshoots; negative: it has not yet arrived. DEM: mean over "
             "the run's cycles ± standard error (a rough one from two or three cycles); a row per seed.", "",
             f"| run | change | {head} |", "|---|---|" + "---|" * (2 + 2 * len(labels))]
    for r in rows:
        cells = []
        for v in (r.A, r.tau):
            cells.append(f"{v.dem:+.4f}" + ("" if v.dem_se is None else f" ± {v.dem_se:.4f}"))
            cells += [f"{v.model[label]:+.4f}" for label in labels]
        lines.append(f"| {run_label(r, rows)} | {r.segment} | " + " | ".join(cells) + " |")
    return lines


def memory_lines(rows: list[MemoryRow], labels: list[str]) -> list[str]:
    """The memory table: per window after the change, the DEM (± its standard error over cycles) and each
    parameter set."""
    windows = [f"{a:g}-{b:g}" for a, b in rows[0].windows]
    head = " | ".join(f"{w}: {who}" for w in windows for who in ("DEM", *labels))
    lines = ["## Memory of the old direction after a change", "",
             "The fabric's shear component along the wall-plane direction normal to the new shear direction "
             "(the part the new shear does not make), as a fraction of what the old direction's steady fabric "
             "puts there: 1 at the change, 0 once the old direction is forgotten; its mean over each window of "
             "strain after the change. DEM: mean over the run's cycles ± standard error (a rough one from two or "
             "three cycles); a row per seed.", "",
             f"| run | change | {head} |", "|---|---|" + "---|" * (len(windows) * (1 + len(labels)))]
    for r in rows:
        cells = []
        for k in range(len(windows)):
            cells.append(f"{r.dem[k]:+.2f}" + ("" if r.dem_se is None else f" ± {r.dem_se[k]:.2f}"))
            cells += [f"{r.model[label][k]:+.2f}" for label in labels]
        lines.append(f"| {run_label(r, rows)} | {r.segment} | " + " | ".join(cells) + " |")
    return lines


def share_text(r: Reversal) -> str:
    """The backstress share with each parameter set's C, and in each set's own model cycle."""
    by_c = ", ".join(f"{v:.0%} with {label}'s C" for label, v in r.backstress_share_by_C.items())
    own = ", ".join(f"{label} {v:.0%}" for label, v in r.model_backstress_share.items())
    return f"; {by_c}; in the model's own cycle: {own}"


def strains_text(s: Strains, joint: str) -> str:
    return f"{_strain_text(s.isotropic)}{joint}{_strain_text(s.backstress)}"


def relaxation_cut_lines(by_cut: dict[str, CutRelaxation]) -> list[str]:
    """The relaxation strains after the reversal at each cut (strain left out after it) and each set's C."""
    labels = list(next(iter(by_cut.values())).dem)
    lines = ["### Relaxation strains after the reversal, by the cut and by C", "",
             "Isotropic part / backstress, to within 5 % of the final value from an exponential fit past the cut; "
             "the DEM's parts split with each set's C, and each set's own model cycle by the same measure (paper, "
             "Fig. 8: 0.25 / 0.6).", "",
             "| cut | " + " | ".join(f"DEM, {label}'s C" for label in labels) + " | "
             + " | ".join(f"model, {label}" for label in labels) + " |", "|---" * (1 + 2 * len(labels)) + "|"]
    for cut, row in by_cut.items():
        cells = [strains_text(part[label], " / ") for part in (row.dem, row.model) for label in labels]
        lines.append(f"| {cut} | " + " | ".join(cells) + " |")
    return lines


def drift_lines(rows: list[DriftRow] | None) -> list[str]:
    """The runs' cycles one by one (``pipeline.dataset.drift``): the gap per cycle and each quantity's trend."""
    if not rows:
        return []
    names = [name for name in drift.QUANTITIES if name in rows[0].trends]
    lines = ["## Drift over the cycles", "",
             "Per run, the gap between the walls' inner planes per cycle (d, over the 0.3 strain before each change) "
             "and each quantity's trend per cycle ± its standard error; **bold** where the drift test finds it at "
             f"p < {drift.LEVEL:g} (a packing still compacting: `SKIP_CYCLES=k` leaves out the first k cycles).", "",
             "| θ | rotation | seed | gap per cycle | " + " | ".join(n.replace("|", "\\|") for n in names) + " |",
             "|---" * (4 + len(names)) + "|"]
    for row in rows:
        cells = []
        for name in names:
            t = row.trends[name]
            text = "" if t.slope is None else f"{t.slope:+.2g} ± {t.standard_error:.1g}"
            cells.append(f"**{text}**" if t.p is not None and t.p < drift.LEVEL else text)
        gaps = " ".join(f"{g:.2f}" for g in row.trends[drift.QUANTITIES[0]].per_cycle)
        lines.append(f"| {row.theta_deg:g} | {row.rotate_at:g} | {row.seed} | {gaps} | " + " | ".join(cells) + " |")
    return lines


def seed_spread_lines(spread: list[SeedSpread], components: list[str]) -> list[str]:
    """The errors of the runs measured at several seeds: their mean over the seeds and their range."""
    lines = ["### Over seeds", "",
             "Runs measured at several seeds: each error's mean over the seeds, and in brackets the least and the "
             "largest. A difference between the parameter sets within this range is not resolved by the seeds.", "",
             "| run | seeds | parameters | " + " | ".join(components) + " |",
             "|---|---|---|" + "---|" * len(components)]
    for r in spread:
        cells = [f"{r.errors[k].mean:.2f} ({r.errors[k].least:.2f}-{r.errors[k].largest:.2f})" for k in components]
        lines.append(f"| {r.run} | {', '.join(map(str, r.seeds))} | {r.parameters} | " + " | ".join(cells) + " |")
    return lines


def law_sentence(fitted) -> str:
    """The fabric law the fit is of (``docs/model.md``)."""
    if fitted.variant == model.params.DEFAULT_VARIANT:
        return "Fabric law: Eq. 13 as written (`rk2025`)."
    added = ", ".join(f"`{n}`" for n in model.params.VARIANTS[fitted.variant])
    return f"Fabric law: `{fitted.variant}`, Eq. 13 with {added} beyond it (docs/model.md)."


def write(metrics: Metrics, fit: FitSummary | None, out: Path, n_runs: int,
          fit_from: list[FitRow] | None = None) -> Path:
    """Write report.md from the comparison's ``metrics``, the calibration's summary ``fit`` and, where ``make
    fit-from`` has run, its rows."""
    sets = metrics.param_sets.labelled()
    paper, ours = metrics.param_sets.table2, metrics.param_sets.our_fit
    errors, after = metrics.errors, metrics.after_changes
    components = errors.components
    lines = [f"# Model against our DEM: `{metrics.data_set}`", "",
             f"{n_runs} DEM run(s) compared, one per protocol"
             + (" (their other seeds: \"Over seeds\")" if errors.seed_spread else "")
             + f"; the model runs in the fit's strain measure for each run's protocol.{fit_runs_sentence(fit)}",
             "",
             "## Parameters", "", law_sentence(ours), "",
             *parameter_lines(ours, paper, fit)]
    lines += ["", "## Model against DEM", "",
              "RMSE over the cycle divided by the steady |A12| or |tau12/p|.", "",
              "| run | parameters | " + " | ".join(components) + " |", "|---|---|" + "---|" * len(components)]
    for e in errors.rows:
        lines.append(f"| {e.run} | {e.parameters} | " + " | ".join(f"{e.errors[k]:.2f}" for k in components) + " |")
    if errors.seed_spread:
        lines += ["", *seed_spread_lines(errors.seed_spread, components)]
    if after.overshoot:
        lines += ["", *overshoot_lines(after.overshoot, list(sets))]
    if after.memory:
        lines += ["", *memory_lines(after.memory, list(sets))]
    if metrics.drift:
        lines += ["", *drift_lines(metrics.drift)]
    if metrics.reversal is not None:
        r = metrics.reversal
        lo, hi = r.table2_packing_fraction_range
        lines += ["", "## Reversal", "",
                  f"- share of the backstress C A12 in the steady shear stress: {r.backstress_share:.0%} with our C "
                  "(paper: 88 %)" + share_text(r),
                  f"- mean packing fraction over the cycle: {r.mean_packing_fraction:.3f} (the model with Table 2: "
                  f"{lo:.3f} to {hi:.3f}; Phi_c = {paper.phi_c} is not the steady value)",
                  second_law_line(metrics.second_law)]
    if metrics.relaxation is not None:
        rel = metrics.relaxation
        lines.append(f"- relaxation strain after the reversal (to within 5 % of the final value, from an exponential "
                     f"fit; 'not resolved' where the fit does not fix it to +-50 %): isotropic part "
                     f"{strains_text(rel.dem, ', backstress ')} in our DEM, mean of {rel.reversal_runs} reversal "
                     "run(s) (paper, read off Fig. 8: 0.25 and 0.6); the model by the same measure: "
                     + "; ".join(f"{label}: {strains_text(v, ' and ')}" for label, v in rel.model.items()))
        lines += ["", *relaxation_cut_lines(rel.by_cut)]
    if fit_from:
        lines += ["", *jump_lines(fit_from, paper)]
    if fit and fit.stepwise.sensitivity:
        lines += ["", *sensitivity_lines(fit.stepwise.sensitivity)]
    return write_text(out, "\n".join(lines) + "\n")
