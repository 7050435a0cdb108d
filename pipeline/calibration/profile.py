"""Profile likelihood of the global fit (``make fit-profile``): each parameter held on a grid, the rest refitted.

``python -m pipeline.calibration.profile [--preset P] [--engine E] [--set K=V] [--points 9] [--span 4]
[--names C,b2] [--strain ...] [--phi ...] [--weight runs|angles]``
reads the preset's runs as ``make fit`` does (with the definitions given), fits them, then for every parameter of
the global fit (or those ``--names`` gives) refits the others with it held at ``points`` values across +-``span``
standard errors, and writes ``profiles.json`` beside the fit (``profiles-<strain>-<phi>-<p>.json`` for other
definitions than the default, ``profiles[-...]-<names>.json`` for some parameters only): for each parameter the
grid, the chi^2 rise above the best fit (in units of the DEM's noise) and the 68 / 95 % intervals where the rise
stays below 1 / 3.84 times the parameter's noise factor ``V_kk / (H^-1)_kk`` (the sandwich variance over the white
one: how much the noise's correlation along strain inflates that parameter's variance). Along a curved valley the
interval follows the curve; a side the grid does not close is reported as open, and a flat profile (no rise
anywhere) marks a parameter the data do not determine.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

import model

from .. import io
from ..cli import Parser, Progress, one_line_errors
from ..dataset import selection
from ..dataset.derived import PAPER_DEFINITIONS
from ..dataset.lookup import fit_runs
from ..dataset.options import add_definition_arguments, definitions_from
from ..errors import CalibrationError, PipelineError
from . import global_fit
from .options import add_weight_argument, table_folder

LEVELS = {"68": 1.0, "95": 3.841459}  # chi^2_1 quantiles, times each parameter's noise factor


def interval(grid: np.ndarray, rise: np.ndarray, threshold: float) -> list:
    """``[low, high]`` where ``rise`` crosses ``threshold`` around its minimum; ``None`` for a side the grid
    does not close. Interpolated linearly in sqrt(rise), which is exact for a parabolic profile."""
    rise, threshold = np.sqrt(rise), np.sqrt(threshold)
    best = int(np.argmin(rise))
    bounds = []
    for side in (range(best, -1, -1), range(best, len(grid))):
        ends = list(side)
        crossing = None
        for a, b in zip(ends[:-1], ends[1:], strict=True):
            if rise[b] >= threshold > rise[a]:
                crossing = float(grid[a] + (threshold - rise[a]) * (grid[b] - grid[a]) / (rise[b] - rise[a]))
                break
        bounds.append(crossing)
    return bounds


def grid_for(value: float, se: float, points: int, span: float) -> np.ndarray:
    """``points`` values across +-``span`` standard errors, or +-100 % of the value where the error is infinite."""
    half = span * se if np.isfinite(se) else max(abs(value), 1e-3)
    return value + half * np.linspace(-1, 1, points)


def profiles(data: list, best: global_fit.GlobalFit, points: int = 9, span: float = 4.0, progress=None,
             names: tuple[str, ...] = ()) -> dict:
    """The profile of every parameter of ``best``, or of ``names`` (see the module docstring)."""
    chosen = [name for name in best.names if not names or name in names]
    out, done, total = {}, 0, points * len(chosen)
    for k, name in enumerate(best.names):
        if name not in chosen:
            continue
        grid = grid_for(best.values[k], best.standard_errors[k], points, span)
        free = tuple(n for n in best.names if n != name)
        rise = []
        for value in grid:
            try:
                fit = global_fit.refine(data, best.params.replace(**{name: float(value)}), free)
                rise.append(fit.chi2 - best.chi2)
            except (CalibrationError, model.ParameterError):
                rise.append(np.inf)
            done += 1
            if progress:
                progress(done, total)
        rise = np.maximum(np.array(rise), 0.0)
        with np.errstate(invalid="ignore"):
            factor = best.covariance[k, k] / best.white_covariance[k, k]
        factor = float(factor) if np.isfinite(factor) else 1.0
        out[name] = {"best": float(best.values[k]), "standard_error": float(best.standard_errors[k]),
                     "noise_factor": factor, "grid": grid.tolist(), "chi2_rise": rise.tolist(),
                     "intervals": {level: interval(grid, rise, q * factor) for level, q in LEVELS.items()}}
    return {"misfit": best.misfit, "levels": LEVELS, "parameters": out}


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration.profile", description=__doc__.splitlines()[0])
    selection.add_arguments(parser)
    parser.add_argument("--points", type=int, default=9, help="values per parameter (default 9)")
    parser.add_argument("--span", type=float, default=4.0, help="half-width in standard errors (default 4)")
    parser.add_argument("--names", default="", help="the parameters to profile, comma-separated (default: all)")
    parser.add_argument("--out", help="output folder (default: the fit's of the same weighting and cycles)")
    add_definition_arguments(parser)
    add_weight_argument(parser)
    args = parser.parse_args(argv)
    if args.points < 3 or not (np.isfinite(args.span) and args.span > 0):
        raise PipelineError(f"points={args.points} must be >= 3 and span={args.span} > 0")
    given = [n for n in args.names.split(",") if n]
    unknown = [n for n in given if n not in global_fit.FREE]
    if unknown:
        raise PipelineError(f"--names: {unknown[0]!r} is not a parameter the fit refines "
                            f"({', '.join(global_fit.FREE)})")
    names = tuple(n for n in global_fit.FREE if n in given)  # in the fit's order: one file name per set
    definitions = definitions_from(args)
    chosen = selection.from_arguments(args)
    out = io.check_writable_dir(args.out or table_folder(chosen, args.weight))
    runs = [r.with_definitions(definitions) for r in fit_runs(chosen)]
    if not runs:
        raise PipelineError(f"no run of {chosen.label}")
    data, noise = global_fit.prepare(runs, weight=args.weight)
    best = global_fit.refine(data, model.Params(), noise=noise)
    result = {"definitions": dataclasses.asdict(definitions), "weight": args.weight,
              **profiles(data, best, args.points, args.span, Progress("profile"), names)}
    stem = "profiles" if definitions == PAPER_DEFINITIONS else f"profiles-{definitions.slug()}"
    name = stem + "".join(f"-{n}" for n in names) + ".json"
    io.write_json(out / name, result)
    for key, p in result["parameters"].items():
        low, high = p["intervals"]["68"]
        text = lambda v: "open" if v is None else f"{v:+.4g}"  # noqa: E731
        print(f"{key:>4s} = {p['best']:+.4g}: 68 % profile interval [{text(low)}, {text(high)}] "
              f"(sandwich ±{p['standard_error']:.2g}, noise factor {p['noise_factor']:.1f})")
    print(f"wrote {out / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
