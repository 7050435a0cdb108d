"""Profile likelihood of the global fit (``make fit-profile``): each parameter held on a grid, the rest refitted.

``python -m pipeline.calibration.profile [--preset P] [--points 9] [--span 8]`` reads the preset's runs
as ``make fit`` does, fits them, then for every parameter of the global fit refits the others with it
held at ``points`` values across +-``span`` Jacobian standard errors, and writes
``results/<preset>/fit/profiles.json``: for each parameter the grid, the chi^2 rise above the best fit,
and the intervals where the rise stays below one (68 %) and four (95 %) times the best fit's reduced
chi^2 — the misfit treated as inflated noise, as the Jacobian errors do, but along the real, curved
valley instead of its tangent. An interval the grid does not close is reported as open.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import model

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset.lookup import other_angles, preset_runs, reversal_seeds
from ..errors import CalibrationError, PipelineError
from ..paths import check_folder_name, preset_output
from . import global_fit

LEVELS = {"68": 1.0, "95": 4.0}  # chi^2 rise, in units of the best fit's reduced chi^2


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


def profiles(data: list, best: global_fit.GlobalFit, points: int = 9, span: float = 8.0, progress=None) -> dict:
    """The profile of every parameter of ``best`` (see the module docstring)."""
    dof = sum(2 * len(d.strain) * len(global_fit.COMPONENTS) for d in data) - len(best.names)
    chi2_min = best.reduced_chi2 * dof
    out, done, total = {}, 0, points * len(best.names)
    for k, name in enumerate(best.names):
        grid = best.values[k] + span * best.standard_errors[k] * np.linspace(-1, 1, points)
        free = tuple(n for n in best.names if n != name)
        rise = []
        for value in grid:
            try:
                fit = global_fit.refine(data, best.params.replace(**{name: float(value)}), free)
                rise.append(fit.reduced_chi2 * (dof + 1) - chi2_min)
            except (CalibrationError, model.ParameterError):
                rise.append(np.inf)
            done += 1
            if progress:
                progress(done, total)
        rise = np.maximum(np.array(rise), 0.0)
        out[name] = {"best": float(best.values[k]), "jacobian_se": float(best.standard_errors[k]),
                     "grid": grid.tolist(), "chi2_rise": rise.tolist(),
                     "intervals": {level: interval(grid, rise, factor * best.reduced_chi2)
                                   for level, factor in LEVELS.items()}}
    return {"reduced_chi2": best.reduced_chi2, "dof": dof, "levels": LEVELS, "parameters": out}


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration.profile", description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="reduced")
    parser.add_argument("--points", type=int, default=9, help="values per parameter (default 9)")
    parser.add_argument("--span", type=float, default=8.0, help="half-width in Jacobian standard errors (default 8)")
    parser.add_argument("--out", help="output folder (default results/<preset>/fit)")
    args = parser.parse_args(argv)
    preset = check_folder_name(args.preset)
    if args.points < 3 or not (np.isfinite(args.span) and args.span > 0):
        raise PipelineError(f"points={args.points} must be >= 3 and span={args.span} > 0")
    out = io.check_writable_dir(args.out or preset_output(preset, "fit"))
    runs = [*reversal_seeds(preset), *other_angles(preset_runs(preset))]
    if not runs:
        raise PipelineError(f"no run of preset {preset!r}")
    data = [global_fit.CycleData.from_run(r) for r in runs]
    best = global_fit.refine(data, model.Params())
    tic = time.time()

    def progress(done, total):
        rate = done / (time.time() - tic)
        print(f"profile {done}/{total} ({done / total:.0%}), {rate:.2f} fits/s, ETA {(total - done) / rate:.0f} s",
              flush=True)

    result = profiles(data, best, args.points, args.span, progress)
    io.write_json(out / "profiles.json", result)
    for name, p in result["parameters"].items():
        low, high = p["intervals"]["68"]
        text = lambda v: "open" if v is None else f"{v:+.4g}"  # noqa: E731
        print(f"{name:>4s} = {p['best']:+.4g}: 68 % profile interval [{text(low)}, {text(high)}] "
              f"(Jacobian +-{p['jacobian_se']:.2g})")
    print(f"wrote {out / 'profiles.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
