"""The files the stages hand each other, declared once: ``params.json`` (``params``), ``fit.json`` (``fit``),
``metrics.json`` and ``compare.h5`` (``metrics``), ``models.json`` and ``models.h5`` (``models``).

Each has a typed object, a writer and a reader; the readers check the file's version and keys and refuse a file that
is not one in one line. A file written before versions were recorded reads as version 1. ``params.json`` stays what
``model.Params.from_json`` and continuum codes read: the parameters, with what fitted them under ``metadata``.
A result nested in a file is a record of its own (``base.Record``).
"""

from .base import Each, MadeFrom, Record, read_json_object
from .definitions import Definitions
from .fit import (
    FIT_VERSION,
    Bootstrap,
    CandidateRun,
    Combination,
    CrossCheck,
    Estimates,
    FitOptions,
    FitRow,
    FitSummary,
    GlobalRefinement,
    Identifiability,
    Jackknife,
    NoiseSummary,
    OwnReversal,
    ParameterInterval,
    ResidualCell,
    Sensitivity,
    SpreadOverAngles,
    Stepwise,
    StepwiseBootstrap,
    StepwiseEstimate,
    StepwiseRun,
    Table2Test,
    check_fitted,
    read_fit,
    read_fit_rows,
    write_fit,
)
from .metrics import (
    COMPARE_SCHEMA,
    COMPARE_VERSION,
    METRICS_VERSION,
    OUR_FIT,
    TABLE2,
    AfterChanges,
    CutRelaxation,
    DriftRow,
    ErrorRange,
    ErrorRow,
    Errors,
    MemoryRow,
    Metrics,
    Overshoot,
    OvershootRow,
    ParamSets,
    Relaxation,
    Reversal,
    SecondLaw,
    SeedSpread,
    Strains,
    Trend,
    check_compare,
    check_compared,
    read_metrics,
    stamp_compare,
)
from .models import (
    MODELS_SCHEMA,
    MODELS_VERSION,
    AcrossScore,
    HeldOut,
    Judgement,
    LawScore,
    ModelsSummary,
    SplitScore,
    models_json,
    read_models,
    read_models_h5,
    write_models_h5,
)
from .params import PARAMS_METADATA_VERSION, ParamsFile, read_params, write_params

__all__ = [
    "COMPARE_SCHEMA", "COMPARE_VERSION", "FIT_VERSION", "METRICS_VERSION", "MODELS_SCHEMA", "MODELS_VERSION", "OUR_FIT",
    "PARAMS_METADATA_VERSION", "TABLE2", "AcrossScore", "AfterChanges", "Bootstrap", "CandidateRun", "Combination",
    "CrossCheck", "CutRelaxation", "Definitions", "DriftRow", "Each", "ErrorRange", "ErrorRow", "Errors", "Estimates",
    "FitOptions", "FitRow", "FitSummary", "GlobalRefinement", "HeldOut", "Identifiability", "Jackknife", "Judgement",
    "LawScore", "MadeFrom", "MemoryRow", "Metrics", "ModelsSummary", "NoiseSummary", "Overshoot", "OvershootRow",
    "OwnReversal", "ParamSets", "ParameterInterval", "ParamsFile", "Record", "Relaxation", "ResidualCell", "Reversal",
    "SecondLaw", "SeedSpread", "Sensitivity", "SplitScore", "SpreadOverAngles", "Stepwise", "StepwiseBootstrap",
    "StepwiseEstimate", "StepwiseRun", "Strains", "Table2Test", "Trend", "check_compare", "check_compared",
    "check_fitted", "models_json", "read_fit", "read_fit_rows", "read_json_object", "read_metrics", "read_models",
    "read_models_h5", "read_params", "stamp_compare", "write_fit", "write_models_h5", "write_params",
]
