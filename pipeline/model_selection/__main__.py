"""``python -m pipeline.model_selection``: ``make models`` (see the package's text)."""

from __future__ import annotations

import sys
from pathlib import Path

import model

from .. import io, schema
from ..calibration import global_fit
from ..cli import Parser, Progress, one_line_errors
from ..dataset import selection
from ..dataset.derived import PAPER_DEFINITIONS
from ..errors import CalibrationError
from ..paths import preset_output
from .curves import curves
from .inputs import law_list, other_data_sets, read
from .judge import judge
from .scores import BEYOND_NOISE_Z, judged
from .splits import TRAIN_ANGLES, splits
from .text import markdown


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.model_selection",
                    description=sys.modules[__package__].__doc__.splitlines()[0])
    selection.add_arguments(parser, "preset whose runs judge the variants")
    parser.add_argument("--across", action="append", default=[], metavar="PRESET[:ENGINE]",
                        help="another data set to predict from this one and back (repeatable; default: the most "
                             "faithful other preset with a reversal run; none: no other)")
    parser.add_argument("--laws", type=law_list, default=list(model.params.VARIANTS), metavar="LAW,LAW...",
                        help="the fabric laws judged (default every one; Eq. 13's, rk2025, is always judged, first)")
    parser.add_argument("--out", type=Path, help="output folder (default results/<data set>/models)")
    args = parser.parse_args(argv)
    chosen = selection.from_arguments(args)
    runs = read(chosen)
    if not any(r.is_reversal for r in runs):
        raise CalibrationError(f"no reversal run of {chosen.label}: make one with `make dem THETA=180 ...`")
    others = other_data_sets(chosen, args.across)
    out = io.check_writable_dir(args.out or preset_output(chosen.folder, "models"))
    variants = args.laws
    progress = Progress("models: fits", len(variants) * (1 + len(splits(runs)) + len(others)))

    print(f"runs: {chosen.label}; across: {', '.join(others) or 'none'}", flush=True)
    stress, weight = global_fit.STRESS_DEFAULT, global_fit.WEIGHT_DEFAULT
    results, not_fitted = [], {}
    for v in variants:
        try:
            results.append(judge(v, runs, others, stress, weight, progress.step))
        except CalibrationError as exc:  # this law cannot be fitted on these runs: the others are still judged
            if v == variants[0]:
                raise CalibrationError(f"Eq. 13's law (the one the others are judged against): {exc}") from None
            not_fitted[v] = str(exc)
            progress.done += progress.total // len(variants)  # its fits, none made
            print(f"models: {v} not fitted on every run ({exc}): left out", flush=True)
    judgements = judged(results)
    made_from = schema.MadeFrom.of([r.path for r in (*runs, *(r for rs in others.values() for r in rs))],
                                   {"laws": variants, "across": list(others), "stress": stress, "weight": weight,
                                    "data_set": chosen.folder, "definitions": PAPER_DEFINITIONS.label()})
    summary = schema.ModelsSummary(chosen.folder, stress, weight, list(TRAIN_ANGLES), BEYOND_NOISE_Z, results,
                                   not_fitted, judgements, made_from.to_dict())
    with io.atomic_paths(*(out / n for n in ("models.json", "models.md", "models.h5"))) as (js, md, h5):
        io.write_bytes(js, schema.models_json(summary))
        io.write_bytes(md, markdown(chosen.label, results, judgements, not_fitted).encode())
        schema.write_models_h5(h5, curves(runs, results), made_from)
    for r in results:
        io.write_params(out / f"params-{r.variant}.json", r.params,
                        {"fit": "global (pipeline.model_selection: every run of the default protocol)",
                         "misfit": r.misfit})
    print("\n".join(j.line() for j in judgements))
    print(f"wrote {out / 'models.md'}, models.json, models.h5 and params-<variant>.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
