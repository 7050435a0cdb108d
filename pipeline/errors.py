"""The pipeline's errors: each carries a one-line message naming the bad value and what to do."""


class PipelineError(ValueError):
    """Bad input, or a stage that cannot work; the CLIs print the message and exit with status 2."""


class SpecError(PipelineError):
    """A bad DEM run specification, or a run folder that cannot be used."""


class DemFileError(PipelineError):
    """A DEM file that cannot be read as the schema says."""


class CalibrationError(PipelineError):
    """A calibration that cannot work."""
