"""``python -m pipeline.figures [--preset P] [--engine E] [--set K=V]`` (``make figures``): Figs. 3-9, the memory
after a turn and report.md.

Reads ``results/<folder>/compare/compare.h5`` and ``metrics.json`` (``make compare``) and
``results/<folder>/fit/fit.h5`` and ``fit.json`` (``make fit``), ``<folder>`` the data set's
(``pipeline.dataset.selection``); draws and formats, computes nothing.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from types import SimpleNamespace

import h5py

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..errors import PipelineError
from ..paths import preset_output
from . import cycles, laws, memory, profiles, report, reversal


def read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise PipelineError(f"{path} not found: run `make compare` (or `make fit`) first") from None
    except (OSError, ValueError) as exc:
        raise PipelineError(f"{path} is not readable JSON ({exc})") from None


def draw(compare_dir: Path, fit_dir: Path, out: Path) -> list[Path]:
    """Every figure and the report from the comparison and calibration outputs."""
    metrics = read_json(compare_dir / "metrics.json")
    io.check_writable_dir(out)
    fit_json = read_json(fit_dir / "fit.json") if (fit_dir / "fit.json").exists() else None
    sets = {label: SimpleNamespace(**values) for label, values in metrics["param_sets"].items()}
    fitted, paper = sets["our fit"], sets["Table 2"]
    preset = metrics["preset"]
    figures = out / "figures"
    made = []
    try:
        f = h5py.File(compare_dir / "compare.h5", "r")
    except OSError as exc:
        raise PipelineError(f"cannot read {compare_dir / 'compare.h5'}: run `make compare` first ({exc})") from None
    with f:
        runs = [f["runs"][k] for k in f["runs"]]
        default = [g for g in runs if g.attrs["default_rotation"]]
        rotated = [g for g in runs if not g.attrs["default_rotation"]]
        made.append(cycles.plot(default, figures / "fig5_6_cycles.png", f"{preset}: Figs. 5-6"))
        if rotated:
            made.append(cycles.plot(rotated, figures / "fig7_rotations.png", f"{preset}: Fig. 7"))
        if "memory" in f:
            made.append(memory.plot([f["memory"][k] for k in f["memory"]], list(sets), figures / "memory.png",
                                    f"{preset}: the fabric's memory of the old shear direction after a turn"))
        if "reversal" in f:
            parts = [f["reversal"][k] for k in f["reversal"]]
            made.append(reversal.backstress_figure(parts, fitted.C, figures / "fig8_backstress.png"))
        reversal_runs = [g for g in runs if g.attrs["is_reversal"]]
        if reversal_runs:
            made.append(reversal.work_figure(reversal_runs, "our fit", figures / "fig9_work_rates.png"))
        n_runs = len(runs)
    if (fit_dir / "profiles.json").exists():
        result = read_json(fit_dir / "profiles.json")
        if profiles.belongs_to(result, fit_json):
            made.append(profiles.plot(result, paper, figures / "profiles.png"))
        else:
            print(f"{fit_dir / 'profiles.json'} profiles another fit than fit.json: not drawn (make fit-profile)")
    fit_h5 = fit_dir / "fit.h5"
    if fit_h5.exists():
        made.append(laws.fabric_law(fit_h5, fitted, paper, figures / "fig3_fabric_law.png"))
        made.append(laws.flow_rule(fit_h5, fitted, paper, figures / "fig4_flow_rule.png"))
    fit_from = read_json(fit_dir / "fit_from.json") if (fit_dir / "fit_from.json").exists() else None
    if fit_from and not report.same_weighting(fit_from, fit_json):
        print(f"{fit_dir / 'fit_from.json'} weighs the runs otherwise than fit.json: left out of the report "
              "(make fit-from with the fit's WEIGHT)")
        fit_from = None
    made.append(report.write(metrics, fit_json, out / "report.md", n_runs, fit_from))
    return made


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.figures", description=__doc__.splitlines()[0])
    selection.add_arguments(parser)
    parser.add_argument("--compare", type=Path, help="comparison folder (default results/<data set folder>/compare)")
    parser.add_argument("--fit", type=Path, help="calibration folder (default results/<data set folder>/fit)")
    parser.add_argument("--out", type=Path, help="output folder (default results/<data set folder>, or the "
                        "comparison folder given: another comparison's figures never replace the data set's)")
    args = parser.parse_args(argv)
    folder = selection.from_arguments(args).folder
    made = draw(args.compare or preset_output(folder, "compare"), args.fit or preset_output(folder, "fit"),
                args.out or args.compare or preset_output(folder))
    for path in made:
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
