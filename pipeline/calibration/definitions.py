"""The global fit under every definition the paper leaves open, side by side (``make fit-definitions``).

``python -m pipeline.calibration.definitions [--preset P] [--engine E] [--set K=V] [--out DIR]
[--weight runs|angles]`` refits the
preset's runs (its data set) with each strain measure (bulk, nominal) x packing fraction (central, gap) x
pressure (target, wall) x stress components fitted (shear, all: ``global_fit.STRESS_FITS``) and writes
``definitions.md`` and ``definitions.json`` beside the fit: the parameters with their standard errors from the
DEM's noise (measured under each definition), the misfit, and Table 2 tested as a
hypothesis on the same data (its chi^2 rise and whether it lies in the joint 95 % region).
"""

from __future__ import annotations

import itertools
import sys

import numpy as np

import model

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..dataset.derived import Definitions
from ..dataset.lookup import fit_runs
from ..errors import CalibrationError, PipelineError
from ..schema import FitRow, OwnReversal
from . import global_fit, identifiability
from .options import add_weight_argument, table_folder, weighted_label
from .residual_map import residual_map

NAMES = ("C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")


def fit_row(runs: list, definitions: Definitions, fit_from: float = 0.0,
            persistence_exponent: float = 0.75, stress: str = global_fit.STRESS_DEFAULT,
            weight: str = global_fit.WEIGHT_DEFAULT) -> FitRow:
    """The global fit of ``runs`` read with ``definitions`` (restarted ``fit_from`` past each change of direction,
    with the persistence exponent held at ``persistence_exponent``, the runs weighted by ``weight``): parameters,
    standard errors from the noise, status, misfit, chi^2, Table 2 as a hypothesis, and the share of chi^2 within
    0.05 strain after a change."""
    data, noise = global_fit.prepare([r.with_definitions(definitions) for r in runs], fit_from, stress, weight)
    start = model.Params().replace(persistence_exponent=persistence_exponent)
    refined = global_fit.refine(data, start, noise=noise)
    se = dict(zip(refined.names, refined.standard_errors.tolist(), strict=True))
    try:
        dilatancy = global_fit.refine_dilatancy(data, refined.params)
        params, note = dilatancy.params, ""
        se.update(zip(dilatancy.names, dilatancy.standard_errors.tolist(), strict=True))
    except CalibrationError as exc:  # reversals alone: Phi_c runs off to a bound along c2_coef (make fit's note)
        params = global_fit.with_eq19_c1(refined.params)
        note = f"Eq. 18's c2_coef and Phi_c not determined ({exc}): Table 2's shown"
        se.update({n: float("nan") for n in ("c2_coef", "phi_c")})
    summary = identifiability.summary(refined, data)
    return FitRow(definitions, stress, weight, fit_from, persistence_exponent, note,
                  params={n: getattr(params, n) for n in NAMES}, model_params=params,
                  standard_errors={n: se[n] for n in NAMES},
                  status={n: p.status for n, p in summary.parameters.items()}, misfit=refined.misfit,
                  chi2=refined.chi2, table2=summary.table2, chi2_share_after_changes=early_share(refined, data),
                  own_reversal=own_reversal(params),
                  mean_packing_fraction=float(np.mean(np.concatenate([d.phi for d in data]))))


def own_reversal(params: model.Params) -> OwnReversal:
    """The model's own reversal cycle (theta = 180) with ``params``: the rate a1 + a2 |A| at which the fabric
    leaves the reversal (``model.reversal_start_rate``; positive, it grows along its old direction) and the peak
    |A| over the cycle per the steady |A|, or the solver's reason where the cycle cannot be computed (the rate too,
    where the law has no steady state to reverse from). A fit past the jump restarts from the DEM's state and never
    runs through the reversal's start, so it can land where the model's own reversal runs away."""
    try:
        rate = model.reversal_start_rate(params)
    except model.SolverError as exc:  # no steady state to reverse from
        return OwnReversal(None, None, "no steady state: " + str(exc).split(" (parameters off")[0])
    try:
        cycle = model.predict(180, params=params)
    except model.SolverError as exc:
        return OwnReversal(rate, None, str(exc).split(" (parameters off")[0])
    steady = model.modulus(model.steady_state(model.shear_velocity_gradient(0.0), params)[0])
    return OwnReversal(rate, float(model.modulus(cycle.A).max() / steady), None)


#: the strain after a change of direction over which ``early_share`` sums the residuals
EARLY_STRAIN = 0.05


def early_share(refined, data: list) -> float:
    """The share of the best fit's chi^2 that lies within ``EARLY_STRAIN`` after a change of direction (in
    a cycle, 2 of 280 samples per 0.005: a uniform misfit would give 2 * 0.05 / 1.4 = 7 %)."""
    rows = residual_map(refined, data, (0.0, EARLY_STRAIN - 1e-9, np.inf))
    return float(sum(r.share for r in rows if r.window[0] == 0.0)) if rows else float("nan")


def preset_fit_runs(chosen: selection.DataSet) -> list:
    """The runs the global fit of the data set ``chosen`` uses; none is a one-line error."""
    runs = fit_runs(chosen)
    if not runs:
        raise PipelineError(f"no run of {chosen.label}")
    return runs


def compare_definitions(runs: list, weight: str = global_fit.WEIGHT_DEFAULT) -> list[FitRow]:
    rows = []
    for stress, (strain, phi, pressure) in itertools.product(global_fit.STRESS_FITS,
                                                             itertools.product(*Definitions.CHOICES.values())):
        definitions = Definitions(strain, phi, pressure)
        rows.append(fit_row(runs, definitions, stress=stress, weight=weight))
        print(f"{definitions.label()}, tau {stress}: misfit {rows[-1].misfit:.2f}, "
              f"Table 2 chi^2 {rows[-1].table2.relative_rise:+.1%}", flush=True)
    return rows


def markdown(rows: list[FitRow], label: str) -> str:
    head = ("| τ fitted | strain | Φ | p | " + " | ".join(NAMES)
            + " | misfit | Table 2: χ² rise | in 95 % region (noise / widened) | mean Φ |")
    lines = [f"# The global fit under each definition: `{label}`", "",
             "± one standard error from the DEM's measured noise (correlated along strain; not scaled by the "
             "misfit). Φc and c2_coef: Eq. 18 on Φ, its scatter taken as white. *misfit*: χ² per degree of "
             "freedom in noise units (1 = within the noise). *τ fitted*: the components of τ/p fitted, shear "
             "(12 and 32: the paper's) or all (the diagonal too, where the DEM's normal-stress differences lie). "
             "Table 2 is tested on its flow rule and fabric law "
             "(C, n, m, a_i, b_i): the rise of χ² above the best fit, and whether that lies inside the joint 95 % "
             "region from the noise, and inside it widened by the misfit.", "",
             head, "|" + "---|" * (len(NAMES) + 8)]
    yes = {True: "yes", False: "no", None: "n/a"}
    for r in rows:
        d, p, se, t = r.definitions, r.params, r.standard_errors, r.table2
        cells = " | ".join(f"{p[n]:+.4g} ± {se[n]:.2g}" if se[n] is not None and np.isfinite(se[n])
                           else f"{p[n]:+.4g} (open)" for n in NAMES)
        inside = f"{yes[t.inside_95]} / {yes[t.inside_95_widened]}" if t.quantiles else "n/a"
        lines.append(f"| {r.stress_fitted} | {d.strain} | {d.phi} | {d.pressure} | {cells} | "
                     f"{r.misfit:.2f} | {t.relative_rise:+.1%} | {inside} | {r.mean_packing_fraction:.3f} |")
    paper = model.Params()
    lines.append("| Table 2 | | | | " + " | ".join(f"{getattr(paper, n):+.4g}" for n in NAMES) + " | | | | |")
    return "\n".join(lines) + "\n"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration.definitions", description=__doc__.splitlines()[0])
    selection.add_arguments(parser)
    parser.add_argument("--out", help="output folder (default: the fit's of the same weighting and cycles)")
    add_weight_argument(parser)
    args = parser.parse_args(argv)
    chosen = selection.from_arguments(args)
    out = io.check_writable_dir(args.out or table_folder(chosen, args.weight))
    rows = compare_definitions(preset_fit_runs(chosen), args.weight)
    label = weighted_label(chosen.label, args.weight)
    print(f"wrote {io.write_table(out, 'definitions', [r.to_dict() for r in rows], markdown(rows, label))} and "
          "definitions.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
