"""``models.png``, the figure of ``make models``, drawn from ``models.h5``: the memory of the old shear direction
after the turns of 120 and 150 degrees (each fabric law fitted without those angles) and the first 0.05 strain after
the reversal (each law fitted on every run), the DEM's cycle mean against each variant.

``python -m pipeline.figures.models [--preset P] [--engine E] [--set K=V] [--models DIR]``
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib.pyplot as plt

from .. import schema
from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..errors import PipelineError
from ..paths import preset_output
from .output import legend_of_all, save


def plot(path: Path, out: Path, title: str) -> Path:
    memory, jump = schema.read_models_h5(path, "memory"), schema.read_models_h5(path, "jump")
    panels = [*memory, *jump[:1]]
    if not panels:
        raise PipelineError(f"{path}: no run at 120, 150 or 180 degrees to draw")
    fig, axes = plt.subplots(1, len(panels), figsize=(3.2 * len(panels) + 0.6, 3.4), squeeze=False)
    for ax, g in zip(axes[0], panels, strict=True):
        is_jump = g.name.startswith("/jump")
        ax.plot(g["strain"][()], g["dem"][()], "o", color="0.3", ms=2.5, label="DEM (cycle mean)")
        for k, (variant, values) in enumerate(g["model"].items()):
            ax.plot(g["strain"][()], values[()], ("k-", "C3--", "C0-.", "C2:")[k % 4], lw=1.2, label=variant)
        ax.axhline(0.0, color="0.6", lw=0.5)
        if is_jump:
            ax.set_title(f"{g.attrs['run']} seed {g.attrs['seed']}: after the reversal (fit on all)", fontsize=9)
            ax.set_ylabel("A along the old direction / steady")
        else:
            ax.set_title(f"seed {g.attrs['seed']}: turn of {g.attrs['theta']:g}° (not fitted)", fontsize=9)
            ax.set_ylabel("old direction's part left")
        ax.set_xlabel("strain after the change")
    legend_of_all(axes[0][0], axes[0], fontsize=7)
    fig.suptitle(title, fontsize=10)
    return save(fig, out)


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.figures.models", description=__doc__.splitlines()[0])
    selection.add_arguments(parser)
    parser.add_argument("--models", type=Path, help="make models' folder (default results/<data set>/models)")
    args = parser.parse_args(argv)
    chosen = selection.from_arguments(args)
    folder = args.models or preset_output(chosen.folder, "models")
    made = plot(folder / "models.h5", folder / "models.png", f"fabric laws against the DEM: {chosen.label}")
    print(f"wrote {made}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
