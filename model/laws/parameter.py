"""A fabric law's own parameter, declared in its module (``model.laws``)."""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Parameter:
    """``name``; ``neutral``, the value at which the law is Eq. 13; ``start``, where a fit starts (inside the range,
    where the parameter moves the model); ``low``..``high``, the closed range in which the law keeps A bounded and
    its rates finite; ``meaning``, in a line; ``measured``, for a parameter read off the DEM before any fit, where
    it was read (a fit holds it at ``start``, its measured value; empty for a parameter the fit determines)."""

    name: str
    neutral: float
    start: float
    low: float
    high: float
    meaning: str
    measured: str = ""
