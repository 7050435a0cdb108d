"""``make fit``'s printout: the global fit first, then the runs that would help most, the stepwise route."""

from __future__ import annotations

import math
from pathlib import Path

from ..schema import FitSummary, Jackknife


def print_global(report: FitSummary) -> None:
    """The global fit first: values with their 68 % intervals from the measured noise, what is determined."""
    g, ident, nm, options = report.global_fit, report.identifiability, report.noise, report.options
    unit = ("the DEM's noise: 1 is a fit within the noise" if ident.noise_measured else
            "the scatter about a smoothed cycle, which is less than the noise")
    weighting = ("; each angle counts once, its seeds averaged" if options.weight == "angles"
                 else "")
    print(f"global fit on {len(g.runs)} run(s){weighting}; misfit {g.estimates.misfit:.2f} (chi^2 per degree "
          f"of freedom in units of {unit})")
    if not ident.noise_measured:
        print(f"intervals: none ({nm.source}): run two cycles or more, or three seeds")
    else:
        print(f"intervals: 68 % from the DEM's noise ({nm.source}; correlated over "
              f"{min(min(v) for v in nm.correlation_strain.values()):.2f}-"
              f"{max(max(v) for v in nm.correlation_strain.values()):.2f} strain), not scaled by the misfit; "
              f"they and 'determined' hold at the persistence exponent k = {options.persistence_exponent:g}, "
              "held (make fit-from profiles it)")
    if options.fit_from:
        print(f"fitted past the reversal jump: the model restarts from the DEM's state {options.fit_from:g} "
              "strain after each change of direction (make fit-from compares restarts)")
    noted = ident.misfit_noted
    spread = ident.spread_over_angles.ranges if ident.spread_over_angles else {}
    if noted:
        print(f"the model misses these runs by sqrt(misfit) = {ident.misfit_widening:.2f} times their noise: the "
              "68 % intervals describe the noise alone; 'widened' takes the misfit as noise (the most lenient "
              "reading), and both assume one parameter set fits every run; 'without one angle' is the range of "
              "the refits that leave out each angle in turn (make fit-jackknife OVER=angles: each one's shift)")
    for name, p in ident.parameters.items():
        line = f"{name:>8s} = {p.value:+.4g}  68 % {interval_text(p.interval_68):>24s}  {p.status}"
        if noted:
            line += f";  widened {interval_text(p.widened_68)}"
        if name in spread:
            line += f";  without one angle {interval_text(spread[name])}"
        print(line)
    d = report.dilatancy
    if d is None:
        print("c2_coef, phi_c: not determined by these runs (Eq. 18's fit does not converge or sits at a bound); "
              "params.json keeps Table 2's")
    for name, value, se in zip(*(() if d is None else (d.free, d.values, d.standard_errors)), strict=True):
        print(f"{name:>8s} = {value:+.4g} ± {se:.2g} (Eq. 18 on Phi; its scatter taken as white)")
    for label, items in (("fixed best", ident.strongest), ("fixed least", ident.weakest)):
        if ident.noise_measured:
            print(f"the data {label}: " + "; ".join(f"{c.combination} (±{c.relative_step:.2g})"
                                                   for c in items))
    if ident.not_determined:
        print(f"not determined by these runs: {', '.join(ident.not_determined)} (hold with --hold NAME=VALUE)")
    t = ident.table2
    if t:
        where = ("inside" if t.inside_95 else "outside") if t.quantiles else "undecided"
        lenient = ("inside" if t.inside_95_widened else "outside") if t.quantiles else "undecided"
        bound = f" against {t.quantile_95:.0f}" if t.quantiles else ""
        print(f"Table 2 on these data: chi^2 {t.relative_rise:+.1%} above the best fit (a rise of "
              f"{t.chi2_rise:.0f}{bound}): {where} the 95 % region from the noise, {lenient} it when widened "
              "by the misfit (make fit-definitions: under each definition)")


def interval_text(band) -> str:
    return "[none]" if band is None else f"[{band[0]:+.4g}, {band[1]:+.4g}]"


def print_next_runs(report: FitSummary, count: int = 5) -> None:
    candidates = report.global_fit.next_runs
    ranked = [r for r in candidates if r.error is None]
    if not ranked:
        if candidates:
            first = candidates[0]
            print(f"runs that would fix the weakest combination: none can be told, no candidate can be weighed at the "
                  f"best fit (the first, {first.run}: {first.error}; fit.json: global, next_runs)")
        return
    first = ranked[0]
    print(f"runs that would fix the weakest combination best per CPU-hour (now ±{first.weakest_before:.3g}; "
          "fit.json: global, next_runs" + ("; another seed of an angle shares that angle's weight"
                                           if report.options.weight == "angles" else "") + "):")
    for r in ranked[:count]:
        print(f"  {r.run}: ±{r.weakest_after:.3g}, {r.cpu_hours:.2f} CPU-hours")


def print_residual_map(report: FitSummary, top: int = 4) -> None:
    """The largest shares of the global fit's chi^2 by run, quantity and strain since a change of direction."""
    rows = report.global_fit.residual_map
    if not rows:
        return
    print("where the global fit's residuals are largest (share of chi^2; chi^2 per sample over the mean; "
          "fit.json: global, residual_map):")
    for r in rows[:top]:
        lo, hi = r.window
        span = f"{lo:g}-{hi:g}" if hi != float("inf") else f"past {lo:g}"
        print(f"  theta = {r.theta_deg:g} (turn at {r.rotate_at:g}), {r.quantity}, {span} strain after a "
              f"change: {r.share:.0%} of chi^2, {r.per_sample_over_mean:.1f}x the mean per sample")


def print_report(report: FitSummary, out: Path) -> None:
    if report.global_fit:
        print_global(report)
        print_residual_map(report)
        print_next_runs(report)
    if report.bootstrap:
        b = report.bootstrap
        print(f"noise bootstrap ({len(b.replicates)} refits, blocks of {b.block_strain:g} strain), 68 %: "
              + ", ".join(f"{n} [{lo:+.4g}, {hi:+.4g}]" for n, (lo, hi) in zip(b.free, b.interval_68, strict=True)))
        st = b.stepwise
        print("the stepwise route on the same resamplings, 95 %: "
              + ", ".join(f"{n} [{lo:+.4g}, {hi:+.4g}]" for n, lo, hi in
                          zip(st.free, st.percentile_2_5, st.percentile_97_5, strict=True)
                          if not n.startswith("persistence_exponent")))
    if report.jackknife:
        print_jackknife(report.jackknife)
    stepwise = report.stepwise
    one_run = len(stepwise.runs) == 1
    print("the paper's stepwise route (Sec. 4), "
          + ("one run ± its error from resamplings of its cycles (docs/calibration.md)" if one_run else
             "mean ± standard error over the reversal runs")
          + ", and its range over smoothing windows 0.03-0.08 and 1-4 relaxation strains of transient "
            "(fit.json: stepwise, sensitivity):")
    sens = stepwise.sensitivity
    settings = [*sens.smoothing_window.values(), *sens.transient_efolds.values()]
    for key, e in stepwise.estimates.items():
        if key.startswith("persistence_exponent"):
            continue  # biased at the DEM's 0.005 sampling (0.50 / 1.04 on model data made with 0.75): fit.json only
        values = [v[key] for v in settings if key in v and math.isfinite(v[key])]
        spread = f"   ({min(values):+.4g} to {max(values):+.4g} over its settings)" if values else ""
        error = f"± {e.standard_error:.2g}" if math.isfinite(e.standard_error) else "(one run of one cycle: no error)"
        print(f"{key:>30s} = {e.value:+.4g} {error}{spread}")
    for c in stepwise.cross_check:
        if c.C_median is not None:
            q = c.C_quartiles
            se = f" ± {c.C_se:.2f}" if c.C_se is not None and math.isfinite(c.C_se) else ""
            print(f"  Sec. 3.3, theta = {c.theta_deg:g}: C = {c.C_median:+.2f}{se} (quartiles {q[0]:+.2f} "
                  f"{q[1]:+.2f}), Y = {c.n:+.3f} {c.m:+.3f} S")
    for note in report.notes[2:]:
        print(f"note: {note}")
    print(f"wrote {out / 'params.json'} (global fit), fit.json and fit.h5"
          + (", params_stepwise.json" if report.stepwise.params else ""))


def print_jackknife(j: Jackknife) -> None:
    """Over seeds, the jackknife's standard errors against the noise model's; over angles (no exchangeable
    draws: no standard error), each refit without one angle and its shift in noise-only standard deviations."""
    if j.over == "seeds":
        print(f"jackknife over the {len(j.left_out)} reversal seeds: standard errors, and in brackets their ratio "
              "to the noise model's part from these runs (about 1 where the seeds differ by noise alone; rough with "
              "few seeds) and to the whole sandwich's: "
              + ", ".join(f"{n} {se:.2g} ({r:.1f}x, {w:.1f}x)" for n, se, r, w in
                          zip(j.free, j.standard_error, j.over_their_noise, j.over_sandwich, strict=True)))
        return
    print(f"each of the {len(j.left_out)} angles left out (with all its runs): the refit, and in brackets its "
          "shift from the fit on all of them in standard deviations of what the noise alone would give it "
          "(|z| of many: one parameter set does not follow every angle)")
    for left, values, z in zip(j.left_out, j.values, j.shift_z, strict=True):
        shifts = ["--" if s is None else f"{s:+.1f}" for s in z]
        print(f"  without {left}: " + ", ".join(f"{n} {v:+.4g} ({s})" for n, v, s in
                                               zip(j.free, values, shifts, strict=True)))

