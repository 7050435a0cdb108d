"""The contact budget after a change of direction, from ``budget.json`` (``pipeline.studies.budget``): per protocol,
the fraction of the fabric followed (the memory of the old direction after a turn, the shear part after a reversal)
against the strain after the change, with what the contacts exchanged (made and lost), kept and crossing the region's
border add to it from the change on (solid) and what Eq. 13's input, recovery and spin add on the same measured
states (dashed); below, who holds it: the strong and weak networks and the contacts present since the change, by how
the new shear loads them.

``python -m pipeline.figures.budget --folder <data set>`` reads ``results/<data set>/budget/budget.json`` and writes
``budget.png`` beside it (``make budget`` draws it after writing the file: ``draw``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .. import schema  # noqa: E402
from ..cli import Parser, one_line_errors  # noqa: E402
from ..errors import PipelineError  # noqa: E402
from ..paths import preset_output  # noqa: E402
from .output import save  # noqa: E402

#: the protocols a reader looks at first (the smallest turn, the right angle, the large turn, the reversal)
FIRST = ("30°", "90°", "150°", "180°")
#: made and lost apart depend on the tracking spacing; their sum, the exchange, does not
TERMS = {"exchange": "C3", "kept": "C2", "crossed": "0.6"}
EQ13 = {"input": "C0", "recovery": "C3", "spin": "C2"}
HOLDERS = {"strong": ("k", "-"), "weak": ("0.5", "-"), "survivors_compressed": ("C0", ":"),
           "survivors_neutral": ("C1", ":"), "survivors_stretched": ("C3", ":")}


def plot(record: dict, out: Path) -> Path:
    groups = {g["label"]: g for g in record["groups"]}
    shown = [groups[k] for k in FIRST if k in groups] or list(groups.values())[:4]
    fig, axes = plt.subplots(2, len(shown), figsize=(3.3 * len(shown) + 0.6, 6.4), sharex=True, squeeze=False)
    for k, g in enumerate(shown):
        c = g["curves"]
        gamma = np.asarray(c["gamma"])
        keep = gamma > 0
        top, bottom = axes[0][k], axes[1][k]
        top.plot(gamma[keep], np.asarray(c["A"])[keep], "k-", lw=2, label="DEM fabric")
        for name, colour in TERMS.items():
            top.plot(gamma[keep], np.asarray(c[name])[keep], "-", color=colour, lw=1, label=f"+ {name}")
        for name, colour in EQ13.items():
            top.plot(gamma[keep], np.asarray(c[name])[keep], "--", color=colour, lw=1, label=f"+ Eq. 13 {name}")
        bottom.plot(gamma[keep], np.asarray(c["A"])[keep], "k-", lw=2, label="all contacts")
        for name, (colour, style) in HOLDERS.items():
            bottom.plot(gamma[keep], np.asarray(c[name])[keep], style, color=colour, lw=1.2,
                        label=name.replace("_", " "))
        for ax in (top, bottom):
            ax.set_xscale("log")
            ax.axhline(0.0, color="0.7", lw=0.5)
        what = "memory of the old direction" if c["component"] == "memory" else "shear part"
        top.set_title(f"{g['label']}: {what} ({g['events']} changes)", fontsize=9)
        bottom.set_xlabel("strain after the change")
    axes[0][0].set_ylabel("fraction, and each term's sum from the change")
    axes[1][0].set_ylabel("fraction held by")
    axes[0][-1].legend(fontsize=6, loc="best")
    axes[1][-1].legend(fontsize=6, loc="best")
    fig.suptitle(f"The contact budget after a change of direction: {record['data_set']}", fontsize=10)
    return save(fig, out)


def draw(folder: Path) -> Path:
    """``budget.png`` from ``folder/budget.json``."""
    source = folder / "budget.json"
    if not source.is_file():
        raise PipelineError(f"no {source}: run make budget first")
    record = schema.read_json_object(source, "contact budget", "budget")
    if "made_from" not in record:
        raise PipelineError(f"{source} does not record what made it (an older budget): make budget again")
    schema.MadeFrom.from_dict(record["made_from"], source).require_unchanged(f"{source} read runs", "budget")
    return plot(record, folder / "budget.png")


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.figures.budget", description=__doc__.splitlines()[0])
    parser.add_argument("--folder", required=True, help="the data set's folder under results/ (reduced-lammps, ...)")
    args = parser.parse_args(argv)
    print(f"wrote {draw(preset_output(args.folder, 'budget'))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
