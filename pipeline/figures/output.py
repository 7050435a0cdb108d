"""Writing a figure atomically (``pipeline.io``), headless."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from ..io import atomic_path


def save(fig, out: Path, dpi: int = 110) -> Path:
    """Lay out ``fig``, write it to ``out`` through a temporary file, close it; returns ``out``."""
    fig.tight_layout()
    with atomic_path(out) as tmp:
        fig.savefig(tmp, dpi=dpi)
    plt.close(fig)
    return out
