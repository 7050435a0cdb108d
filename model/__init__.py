"""Kinematic-hardening model of transient fabric and stress in quasi-static granular flow.

Rojas & Kamrin, Soft Matter (2025), Sections 3.2, 3.3 and 5; conventions in ``model.kinematics``.
"""

from .kinematics import (
    History,
    HistoryError,
    Segment,
    periodic_cycle,
    reversal,
    rotation_about_e2,
    shear_segment,
    shear_velocity_gradient,
    steady_shear,
)
from .params import PAPER, ParameterError, Params
from .solver import Result, SolverError, integrate, periodic, predict, steady_state

__all__ = [
    "PAPER", "History", "HistoryError", "ParameterError", "Params", "Result", "Segment", "SolverError",
    "integrate", "periodic", "periodic_cycle", "predict", "reversal", "rotation_about_e2",
    "shear_segment", "shear_velocity_gradient", "steady_shear", "steady_state",
]
