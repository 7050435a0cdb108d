"""``make compare``: the model against a data set's DEM runs -> ``results/<its folder>/compare/``.

``python -m pipeline.comparison [--preset P] [--engine E] [--set K=V] [--params FILE] [--seed N] [--out DIR]`` predicts
every run's cycle with Table 2 and with the fitted parameters (``fit/params.json``), reading the runs in the
definitions of strain, Phi and p that the parameters were fitted in (their file's metadata), and writes, atomically:
``compare.h5`` (per run: the DEM's cycle mean and standard error, and each parameter set's model
cycle at the same samples, in the fit's strain measure; the DEM's cycle mean at the protocol's other seeds; the
reversal split into backstress and isotropic part) and ``metrics.json`` (the normalised errors per run and parameter
set and their range over seeds, the backstress share, the packing fraction, the second-law check and the relaxation
strains after the reversal). The figures and the report read these files; they compute nothing.
"""

from __future__ import annotations

import sys
from pathlib import Path

import model

from .. import io, schema
from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..dataset.lookup import other_seeds_of, preset_runs, runs_at_seed
from ..errors import DemFileError
from ..paths import preset_output
from .compare import compare, fitted_in, smoothed_reversals


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.comparison", description=__doc__.splitlines()[0])
    selection.add_arguments(parser)
    parser.add_argument("--params", type=Path, help="fitted parameters (default results/<folder>/fit/params.json)")
    parser.add_argument("--seed", type=int, help="compare the runs of this seed (default: the data set's own "
                        "folder's, its first seed)")
    parser.add_argument("--out", type=Path, help="output folder (default results/<data set folder>/compare, or "
                        "compare-seed<N>)")
    args = parser.parse_args(argv)
    chosen = selection.from_arguments(args)
    params_file = args.params or preset_output(chosen.folder, "fit", "params.json")
    schema.check_fitted(params_file)
    fit_json = Path(params_file).with_name("fit.json")
    fit_digest = None
    if fit_json.exists():  # a fit of ours: of this data set, these cycles (a set of one's own is taken as it is)
        fit_made_from = schema.read_fit(fit_json).made_from
        fit_made_from.require_same(str(fit_json), {"data_set": chosen.folder, "skip_cycles": chosen.skip_cycles},
                                   f"fit PRESET={chosen.preset}")
        fit_digest = fit_made_from.digest()
    fitted = io.read_params(params_file)
    definitions = fitted_in(params_file)
    print(f"reading the runs in the definitions {params_file.name} was fitted in: {definitions.label()}")
    runs = preset_runs(chosen) if args.seed is None else runs_at_seed(chosen, args.seed)
    if not runs:
        raise DemFileError(f"no DEM run of {chosen.label}: run `make dem PRESET={chosen.preset}` first")
    runs = [r.with_definitions(definitions) for r in runs]
    others = tuple(r.with_definitions(definitions) for r in other_seeds_of(chosen, runs))
    out = args.out or preset_output(chosen.folder, "compare" if args.seed is None else f"compare-seed{args.seed}")
    fit_h5 = smoothed_reversals(params_file, chosen.folder, definitions)
    label = chosen.label if args.seed is None else f"{chosen.label}, seed {args.seed}"
    made_from = schema.MadeFrom.of([params_file, *(r.path for r in (*runs, *others))],
                                   {"definitions": definitions.label(), "seed": args.seed, "data_set": chosen.label,
                                    "folder": chosen.folder, "skip_cycles": chosen.skip_cycles, "fit": fit_digest})
    compare(runs, {schema.TABLE2: model.Params(), schema.OUR_FIT: fitted}, fit_h5, out, chosen.preset, label, others,
            made_from)
    print(f"wrote {out / 'compare.h5'} and metrics.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
