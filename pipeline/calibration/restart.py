"""The global fit past the reversal jump, side by side (``make fit-from``).

``python -m pipeline.calibration.restart [--preset P] [--engine E] [--set K=V] [--fit-from 0,0.005,0.01]
[--exponents 0.5,...,1] [--weight runs|angles]``
refits the preset's runs in the paper's definitions (nominal strain, Phi of the gap, the controlled p) with
the model restarted from the DEM's state gamma0 past each change of direction (``Cycle.restarted``), for
each gamma0, and then, at the first gamma0 > 0, with the persistence exponent k of Eq. 12 held at each value
given (a profile of k). Writes ``fit_from.md`` and ``fit_from.json`` beside the fit: parameters with their
standard errors from the noise, the misfit, chi^2, the share of chi^2 in the first 0.05 strain after a
change, Table 2 tested on the same data, and whether the model's own reversal runs with the row's parameters;
and each row's parameters in ``fit_from/from<gamma0>-k<k>-runs<n>.json``, which
``python -m pipeline.comparison --params`` compares with the DEM.
"""

from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np

import model

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..dataset.derived import PAPER_DEFINITIONS, states_after_changes
from ..errors import PipelineError
from ..schema import FitRow, OwnReversal
from . import global_fit
from .definitions import NAMES, fit_row, own_reversal, preset_fit_runs
from .options import add_weight_argument, table_folder, weighted_label

FIT_FROM = (0.0, 0.002, 0.005, 0.01)
EXPONENTS = (0.5, 0.625, 0.75, 0.875, 1.0)
#: each row's parameters, as ``python -m pipeline.comparison --params`` reads them
PARAMS_FOLDER = "fit_from"


def on_grid(run, fit_from: float) -> bool:
    k = fit_from / run.spec.sample_strain
    return abs(k - round(k)) <= 1e-6


def settings(runs: list, fit_from=FIT_FROM, exponents=EXPONENTS) -> list[tuple]:
    """(gamma0, k, runs) per row: each gamma0 at k = 3/4 on every run; a gamma0 between the sampling grid's
    points only on the runs with dense samples there, and beside it the first gamma0 > 0 on the grid on the
    same runs (to compare like with like); then a profile of k at the first gamma0 > 0 on the grid."""
    rows = []
    grid = [g for g in fit_from if g > 0 and all(on_grid(r, g) for r in runs)]
    for g in fit_from:
        if all(on_grid(r, g) for r in runs):
            rows.append((g, 0.75, runs))
            continue
        dense = [r for r in runs if on_grid(r, g) or states_after_changes(r, g) is not None]
        if not dense:
            print(f"fit from {g:g}: skipped, no run has samples {g:g} past each change of direction", flush=True)
            continue
        rows.append((g, 0.75, dense))
        if grid and len(dense) < len(runs):
            rows.append((grid[0], 0.75, dense))
    if grid:
        rows += [(grid[0], k, runs) for k in exponents if k != 0.75]
    return rows


def table(runs: list, fit_from=FIT_FROM, exponents=EXPONENTS, definitions=PAPER_DEFINITIONS,
          weight: str = global_fit.WEIGHT_DEFAULT) -> list[FitRow]:
    """One fit per ``settings`` row, with the number of runs it used (weighted by ``weight`` among them)."""
    todo = settings(runs, fit_from, exponents)
    rows, tic = [], time.time()
    for done, (g, k, used) in enumerate(todo, start=1):
        rows.append(dataclasses.replace(fit_row(used, definitions, g, k, weight=weight), runs=len(used)))
        r = rows[-1]
        eta = (time.time() - tic) / done * (len(todo) - done)
        print(f"[{done}/{len(todo)}, {done / len(todo):.0%}] fit from {g:g}, k = {k:g}, {len(used)} runs: misfit "
              f"{r.misfit:.3f}, chi^2 {r.chi2:.0f}, Table 2 chi^2 {r.table2.relative_rise:+.1%}; "
              f"ETA {eta:.0f} s", flush=True)
    return rows


def markdown(rows: list[FitRow], label: str) -> str:
    shown = NAMES[:7]
    lines = [f"# The global fit past the reversal jump: `{label}`", "",
             "Paper's definitions (nominal strain, Φ of the gap, τ over the controlled p). *γ0*: the model restarts "
             "from the DEM's cycle-mean A and Φ this far past each change of direction and is fitted to what "
             "follows (0: the converged periodic cycle, all samples). *k*: the persistence exponent of Eq. 12, "
             "held. *runs*: how many runs the row fits (a γ0 between the 0.005 grid's points needs the dense "
             "samples after each change; the first γ0 on the grid is refitted on the same runs beside it). "
             "± one standard error from the DEM's measured noise; (open): not determined. *early χ²*: the "
             "share of χ² within 0.05 strain after a change (a uniform misfit: 7 %). Table 2 is tested on its "
             "flow rule and fabric law on the same samples. χ² compares rows of one γ0 (the samples differ "
             "between γ0). *own reversal*: the model's θ = 180° cycle run with the row's parameters from its "
             "own state, not the DEM's: a1 + a2 |A|, the rate at which the fabric leaves the reversal "
             "(positive: it first grows along its old direction), and the peak |A| over the cycle per the steady "
             "|A|, or 'fails' where the cycle cannot be computed; such parameters are unfit for a continuum code.",
             "",
             "| γ0 | k | runs | " + " | ".join(shown)
             + " | misfit | χ² | early χ² | Table 2: χ² rise | in 95 % region | own reversal |",
             "|" + "---|" * (len(shown) + 9)]
    yes = {True: "yes", False: "no", None: "n/a"}
    for r in rows:
        p, se, t = r.params, r.standard_errors, r.table2
        cells = " | ".join(f"{p[n]:+.4g} ± {se[n]:.2g}" if se[n] is not None and np.isfinite(se[n])
                           and r.status.get(n) != "not determined" else f"{p[n]:+.4g} (open)" for n in shown)
        inside = yes[t.inside_95] if t.quantiles else "n/a"
        lines.append(f"| {r.fit_from:g} | {r.persistence_exponent:g} | {r.runs} | {cells} | "
                     f"{r.misfit:.3f} | {r.chi2:.0f} | {r.chi2_share_after_changes:.0%} | "
                     f"{t.relative_rise:+.1%} | {inside} | {own_reversal_cell(r.own_reversal)} |")
    paper = model.Params()
    lines.append("| Table 2 | 0.75 | | " + " | ".join(f"{getattr(paper, n):+.4g}" for n in shown) + " | | | | | | "
                 + own_reversal_cell(own_reversal(paper)) + " |")
    return "\n".join(lines) + "\n"


def own_reversal_cell(own: OwnReversal) -> str:
    """``definitions.own_reversal`` in a table cell."""
    if own.start_rate is None:
        return "no steady state"
    peak = "fails" if own.peak_over_steady is None else f"peak {own.peak_over_steady:.2f}"
    return f"{own.start_rate:+.2g}, {peak}"


def _numbers(name: str, text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise PipelineError(f"--{name} {text!r} is not a comma-separated list of numbers") from None
    bad = [v for v in values if not (np.isfinite(v) and 0 <= v < 2)]
    if bad:
        raise PipelineError(f"--{name}: {bad[0]!r} must lie in [0, 2)")
    return values


def row_params_name(row: FitRow) -> str:
    """``from<gamma0>-k<k>-runs<n>.json``: the row's gamma0, persistence exponent and number of runs."""
    return f"from{row.fit_from:g}-k{row.persistence_exponent:g}-runs{row.runs}.json"


def write_row_params(out, row: FitRow):
    """The row's parameters (every model parameter, its k included) in ``out/fit_from/``, so that a row past the
    jump can be compared with the DEM and run in a continuum code; its metadata say how it was fitted and whether
    the model's own reversal runs with it."""
    metadata = {"fit": "global past the jump (pipeline.calibration.restart)", "fit_from": row.fit_from,
                "runs": row.runs, "weight": row.weight, "definitions": row.definitions.to_dict(),
                "own_reversal": row.own_reversal.to_dict()}
    return io.write_params(out / PARAMS_FOLDER / row_params_name(row), row.model_params, metadata)


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration.restart", description=__doc__.splitlines()[0])
    selection.add_arguments(parser)
    parser.add_argument("--fit-from", default=",".join(f"{g:g}" for g in FIT_FROM), help="gamma0 values (strain)")
    parser.add_argument("--exponents", default=",".join(f"{k:g}" for k in EXPONENTS), help="k values profiled")
    parser.add_argument("--out", help="output folder (default: the fit's of the same weighting and cycles)")
    add_weight_argument(parser)
    args = parser.parse_args(argv)
    fit_from, exponents = _numbers("fit-from", args.fit_from), _numbers("exponents", args.exponents)
    chosen = selection.from_arguments(args)
    out = io.check_writable_dir(args.out or table_folder(chosen, args.weight))
    rows = table(preset_fit_runs(chosen), fit_from, exponents, weight=args.weight)
    for row in rows:
        write_row_params(out, row)
    label = weighted_label(chosen.label, args.weight)
    print(f"wrote {io.write_table(out, 'fit_from', [r.to_dict() for r in rows], markdown(rows, label))}, "
          "fit_from.json and each "
          f"row's parameters in {out / PARAMS_FOLDER}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
