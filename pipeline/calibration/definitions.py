"""The global fit under every definition the paper leaves open, side by side (``make fit-definitions``).

``python -m pipeline.calibration.definitions [--preset P] [--out DIR]`` refits the preset's runs with
each strain measure (bulk, nominal) x packing fraction (central, gap) x pressure (target, wall) and
writes ``definitions.md`` and ``definitions.json`` beside the fit: the parameters, the reduced chi^2
of the best fit and of Table 2 on the same data, and the mean packing fraction.
"""

from __future__ import annotations

import dataclasses
import itertools
import sys

import numpy as np

import model

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset.derived import Definitions
from ..dataset.lookup import other_angles, preset_runs, reversal_seeds
from ..errors import PipelineError
from ..paths import check_folder_name, preset_output
from . import global_fit

NAMES = ("C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")


def reduced_chi2(data: list, params: model.Params) -> float:
    r = global_fit.residuals(np.array([getattr(params, n) for n in global_fit.FREE]), data, params)
    return float(np.sum(r**2) / max(r.size - len(global_fit.FREE), 1))


def compare_definitions(runs: list) -> list[dict]:
    rows = []
    for strain, phi, pressure in itertools.product(*Definitions.CHOICES.values()):
        definitions = Definitions(strain, phi, pressure)
        data = [global_fit.CycleData.from_run(r.with_definitions(definitions)) for r in runs]
        refined = global_fit.refine(data, model.Params())
        dilatancy = global_fit.refine_dilatancy(data, refined.params)
        rows.append({"definitions": dataclasses.asdict(definitions),
                     "params": {n: getattr(dilatancy.params, n) for n in NAMES},
                     "reduced_chi2": refined.reduced_chi2, "reduced_chi2_table2": reduced_chi2(data, model.Params()),
                     "mean_packing_fraction": float(np.mean(np.concatenate([d.phi for d in data])))})
        print(f"{definitions.label()}: reduced chi2 {refined.reduced_chi2:.2f}", flush=True)
    return rows


def markdown(rows: list[dict], preset: str) -> str:
    head = "| strain | Φ | p | " + " | ".join(NAMES) + " | χ²_red | χ²_red Table 2 | mean Φ |"
    lines = [f"# The global fit under each definition: preset `{preset}`", "",
             "Standard errors are left out: the χ² is dominated by model misfit, not noise (README).", "",
             head, "|" + "---|" * (len(NAMES) + 6)]
    for r in rows:
        d, p = r["definitions"], r["params"]
        chi2 = f"{r['reduced_chi2']:.2f} | {r['reduced_chi2_table2']:.2f} | {r['mean_packing_fraction']:.3f}"
        lines.append(f"| {d['strain']} | {d['phi']} | {d['pressure']} | "
                     + " | ".join(f"{p[n]:+.4g}" for n in NAMES) + f" | {chi2} |")
    paper = model.Params()
    lines.append("| Table 2 | | | " + " | ".join(f"{getattr(paper, n):+.4g}" for n in NAMES) + " | | | |")
    return "\n".join(lines) + "\n"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.calibration.definitions", description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="reduced")
    parser.add_argument("--out", help="output folder (default results/<preset>/fit)")
    args = parser.parse_args(argv)
    preset = check_folder_name(args.preset)
    out = io.check_writable_dir(args.out or preset_output(preset, "fit"))
    runs = [*reversal_seeds(preset), *other_angles(preset_runs(preset))]
    if not runs:
        raise PipelineError(f"no run of preset {preset!r}")
    rows = compare_definitions(runs)
    io.write_json(out / "definitions.json", rows)
    io.write_text(out / "definitions.md", markdown(rows, preset))
    print(f"wrote {out / 'definitions.md'} and definitions.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
