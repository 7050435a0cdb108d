"""Synthetic DEM run files made by the model (known truth), for the unit tests."""

from dem.rawfile import write_raw
from pipeline.dataset.dem_file import load, write_h5

from .synthetic import synthetic_raw


def synthetic_file(folder, theta=180.0, name="run", **kw):
    """Write ``folder/<name>.h5`` from the model's cycle (see ``synthetic_raw``); returns its path."""
    raw, meta = synthetic_raw(theta, **kw)
    write_raw(folder / f"{name}.npz", raw, meta)
    write_h5(folder / f"{name}.npz", folder / f"{name}.h5", {"git_commit": "test", "sessions": []})
    return folder / f"{name}.h5"


def synthetic_run(folder, theta=180.0, name="run", **kw):
    """The loaded ``DemRun`` of :func:`synthetic_file`."""
    return load(synthetic_file(folder, theta, name, **kw))
