"""``models.md``: the held-out table, the in-sample numbers, the parameters and the verdict."""

from __future__ import annotations

from ..schema import Judgement, LawScore
from .scores import BEYOND_NOISE_Z


def markdown(label: str, results: list[LawScore], judgements: list[Judgement],
             not_fitted: dict[str, str] | None = None) -> str:
    """``models.md``: the held-out table, the in-sample numbers, the parameters and the verdict; the laws that could
    not be fitted on every run (``not_fitted``: the reason) are named."""
    variants = [r.variant for r in results]
    lines = [f"# Fabric laws judged by the runs they were not fitted on: {label}", "",
             "Held-out error: RMS over the cycle in units of the run's noise (1 is a prediction within the noise), "
             "pooled over the held-out runs and their components (A: 12, 32, 11, 22, 13; tau/p: 12, 32).", "",
             "| held out | " + " | ".join(variants) + " |", "|---|" + "---|" * len(variants)]
    for k, (name, _, _) in enumerate(results[0].tests()):
        lines.append(f"| {name} | " + " | ".join(f"{list(r.tests())[k][2]:.2f}" for r in results) + " |")
    lines += ["", "In sample (every run of the default protocol):", "",
              "| variant | parameters | misfit | AIC | BIC | own reversal |", "|---|---|---|---|---|---|"]
    for r in results:
        rev = r.own_reversal
        runs_away = "no cycle" if rev.error else f"peak/steady {rev.peak_over_steady:.2f}"
        own = "no steady state" if rev.start_rate is None else f"start rate {rev.start_rate:+.3g}, {runs_away}"
        lines.append(f"| {r.variant} | {r.parameters} | {r.misfit:.2f} | {r.aic:.0f} | {r.bic:.0f} | "
                     f"{own} |")
    lines += ["", "Parameters (fit on every run; ± one standard error from the noise):", ""]
    for r in results:
        lines.append(f"- {r.variant}: " + ", ".join(f"{n} = {v:+.4g} ± {s:.2g}" for n, v, s in
                                                   zip(r.free, r.values, r.standard_errors, strict=True)))
    lines += ["", "Per held-out run (RMS over its components in noise units; inf: no prediction, the law fitted cannot "
              "run its cycle or could not be fitted on the other runs, models.json says which; models.json has each "
              "component, also per the DEM's steady value):", ""]
    for k, split in enumerate(results[0].splits):
        for j, row in enumerate(split.rows):
            cells = [f"{r.splits[k].rows[j].rms_noise:.2f}" for r in results]
            lines.append(f"- {split.name}: {row.protocol} seed {row.seed}: " + ", ".join(
                f"{v} {c}" for v, c in zip(variants, cells, strict=True)))
    lines += ["", f"Verdict: z is how far Eq. 13's held-out chi^2 lies above the law's, in standard deviations of what "
              f"the noise alone makes of that difference (its correlation along strain included); beyond the noise "
              f"past |z| = {BEYOND_NOISE_Z:g}.", ""]
    lines += [f"- {j.line()}" for j in judgements]
    if not_fitted:  # a law whose fit on every run failed
        lines += ["", "Not fitted on every run (so not judged):", ""]
        lines += [f"- {variant}: {reason}" for variant, reason in not_fitted.items()]
    return "\n".join(lines) + "\n"


