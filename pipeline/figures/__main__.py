"""``python -m pipeline.figures [--preset P] [--engine E] [--set K=V]`` (``make figures``): Figs. 3-9, the memory
after a turn and report.md.

Reads ``results/<folder>/compare/compare.h5`` and ``metrics.json`` (``make compare``) and
``results/<folder>/fit/fit.h5`` and ``fit.json`` (``make fit``), ``<folder>`` the data set's
(``pipeline.dataset.selection``); draws and formats, computes nothing.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..paths import preset_output
from .draw import draw


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
