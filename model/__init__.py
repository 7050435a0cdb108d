"""Kinematic-hardening model of transient fabric and stress in quasi-static granular flow.

Rojas & Kamrin, Soft Matter (2025), Sections 3.2, 3.3 and 5; conventions in ``model.kinematics``.
"""

from .kernel_cache import keyed_by_sources, rebuilding_when_damaged

with keyed_by_sources():
    from . import laws
    from .equations import hardening_variable_stack
    from .kinematics import (
        PERIOD_STRAIN,
        ROTATE_AT_STRAIN,
        History,
        HistoryError,
        Segment,
        deviator,
        modulus,
        periodic_cycle,
        reversal,
        rotation_about_e2,
        shear_direction,
        shear_segment,
        shear_velocity_gradient,
        spin,
        steady_shear,
        stretching,
    )
    from .material_point import Update, update, update_inputs
    from .params import PAPER, ParameterError, Params
    from .solver import Result, SolverError, integrate, periodic, predict, reversal_start_rate, steady_state

integrate, periodic, predict, steady_state, update, reversal_start_rate = map(
    rebuilding_when_damaged, (integrate, periodic, predict, steady_state, update, reversal_start_rate))

__all__ = [
    "PAPER", "PERIOD_STRAIN", "ROTATE_AT_STRAIN", "History", "HistoryError", "ParameterError", "Params", "Result",
    "Segment", "SolverError", "deviator", "laws", "hardening_variable_stack", "integrate", "modulus", "periodic",
    "periodic_cycle", "predict", "reversal", "reversal_start_rate", "rotation_about_e2", "shear_direction",
    "shear_segment", "shear_velocity_gradient", "spin", "steady_shear", "steady_state", "stretching", "Update",
    "update", "update_inputs",
]
