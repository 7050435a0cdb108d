"""Writing a figure atomically (``pipeline.io``), headless; what several figures share."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib.pyplot as plt

from ..io import atomic_path, write_bytes


def save(fig, out: Path, dpi: int = 110) -> Path:
    """Lay out ``fig``, write it to ``out`` through a temporary file, close it; returns ``out``."""
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=dpi, format=out.suffix.lstrip(".") or "png")
    plt.close(fig)
    with atomic_path(out) as tmp:
        write_bytes(tmp, buffer.getbuffer())  # an error names the file
    return out


def strain_label(group) -> str:
    """The strain axis of a ``compare.h5`` group: the measure the fit used (files before it was recorded: bulk)."""
    measure = group.file.attrs.get("strain_measure", "bulk")
    return r"nominal strain $t\dot\gamma$" if measure == "nominal" else r"bulk strain $t\dot\gamma$"


def legend_of_all(ax, panels, **kw) -> None:
    """A legend on ``ax`` with every entry of ``panels``, each label once (a panel need not have them all)."""
    entries = {}
    for panel in panels:
        for handle, label in zip(*panel.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    ax.legend(entries.values(), entries.keys(), **kw)
