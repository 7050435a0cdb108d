"""The choices the paper leaves open, as every file that applied them records them."""

from __future__ import annotations

import dataclasses

from .. import choices
from .base import Record


@dataclasses.dataclass(frozen=True)
class Definitions(Record):
    """The choices the paper leaves open, applied when a run is read (README, "Definitions").

    ``strain``: ``"bulk"`` (rates per unit strain of the central band, measured: s . dv/dy) or
    ``"nominal"`` (the paper's t*gamma_dot with gamma_dot = 2U/H0, H0 between the walls' inner planes).
    ``phi``: ``"central"`` (solid fraction of the central region) or ``"gap"`` (all grains' volume over
    W^2 (H - d), the cell between the walls' surfaces; H is the gap between the inner planes).
    ``pressure``: ``"target"`` (tau/p with the controlled p) or ``"wall"`` (tau divided by the wall
    normal stress measured over each sampling interval).
    """

    WHAT = "definitions"
    CHOICES = {"strain": choices.STRAINS, "phi": choices.PHIS, "pressure": choices.PRESSURES}

    strain: str = "bulk"
    phi: str = "central"
    pressure: str = "target"

    def __post_init__(self):
        for name, allowed in self.CHOICES.items():
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name}={getattr(self, name)!r} is not one of {', '.join(allowed)}")

    def label(self) -> str:
        return f"strain {self.strain}, Phi {self.phi}, p {self.pressure}"

    def slug(self) -> str:
        """``bulk-central-target``: the definitions in a file name."""
        return f"{self.strain}-{self.phi}-{self.pressure}"
