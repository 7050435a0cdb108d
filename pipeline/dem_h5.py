"""DEM run files: raw samples (``raw.npz`` from ``dem/couette.py``) -> one self-describing HDF5 file.

Layout (H5MD in spirit: a version at the root, a group per observable, a ``unit`` on every dataset):

``/`` attrs ``schema``, ``schema_version``, ``creator``, ``conventions``
``/provenance`` attrs: preset, theta_deg, seed, Yade version, git commit, commands, timestamps, spec
``/parameters`` attrs: every spec value, plus the contact constants and the time step
``/raw/...`` the time series as sampled (walls, central region, ``profiles/``)
``/series/...`` model-ready per-sample series (``pipeline.dem_analysis.model_series``)
``/cycle/...`` the cycle-averaged periodic cycle (mean and ``*_sem``, preceding half period excluded)

Units: lengths d, stresses p (the controlled wall normal stress), time d*sqrt(rho/p), forces p*d^2.
"""

from __future__ import annotations

import datetime as dt
import json
import os
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from . import dem_analysis

SCHEMA = "granular-backstress/dem-run"
SCHEMA_VERSION = 1
CONVENTIONS = ("stress tension-positive, normalised by the controlled wall normal stress p; tau = sigma' "
               "(deviator); walls normal to e2; shear direction cos(phi) e1 + sin(phi) e3, phi from e1 towards "
               "e3; strain t*gamma_dot from the start of the first period; fabric A = <n n> - I/3 (Eq. 8)")

TIME = "d*sqrt(rho/p)"
RATE = "sqrt(p/rho)/d"
RAW_UNITS = {
    "iteration": "1", "time": TIME, "strain": "1", "direction_deg": "deg", "gap": "d", "region": "d",
    "top_position": "d", "bottom_position": "d", "top_velocity": "d*sqrt(p/rho)", "bottom_velocity": "d*sqrt(p/rho)",
    "top_force": "p*d^2", "bottom_force": "p*d^2", "wall_stress_error_mean": "1", "wall_stress_error_max": "1",
    "stress_contact": "p", "stress_kinetic": "p", "fabric": "1", "contacts": "1", "grains": "1", "coordination": "1",
    "packing_fraction": "1", "velocity_gradient": RATE,
    "profile_edges": "d", "profile_velocity": "d*sqrt(p/rho)", "profile_packing_fraction": "1", "profile_stress": "p",
    "profile_fabric": "1", "profile_contacts": "1",
}
SERIES_UNITS = {
    "strain_nominal": "1", "strain_bulk": "1", "shear_rate_bulk": RATE, "D_dev_nominal": "gamma_dot",
    "D_dev_measured": RATE, "A": "1", "tau_over_p": "1", "mean_stress_over_p": "1", "S": "1",
    "packing_fraction": "1", "w_shear": "p*gamma_dot", "w_vol": "p*gamma_dot",
}
CYCLE_KEYS = ("strain_bulk", "A", "tau_over_p", "mean_stress_over_p", "S", "packing_fraction", "w_shear", "w_vol",
              "shear_rate_bulk")


class DemFileError(ValueError):
    """A DEM file or raw sample file that cannot be read as this schema."""


def read_raw(path: Path) -> tuple[dict, dict]:
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files}
    meta = json.loads(str(arrays.pop("meta_json")))
    return arrays, meta


def _dataset(group, name, data, unit):
    ds = group.create_dataset(name, data=data)
    ds.attrs["unit"] = unit
    return ds


def write_h5(raw_path: Path, out: Path, provenance: dict) -> None:
    """Write ``out`` atomically (temporary file, then rename) from the scene's ``raw.npz``."""
    raw, meta = read_raw(raw_path)
    spec = meta["spec"]
    series = dem_analysis.model_series(raw, meta)
    cycle = dem_analysis.cycle_average(raw["strain"], {k: series[k] for k in CYCLE_KEYS}, spec["period_strain"],
                                       spec["sample_strain"], spec["n_cycles"])
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        f.attrs.update(schema=SCHEMA, schema_version=SCHEMA_VERSION, creator="granular-backstress",
                       created=dt.datetime.now().isoformat(timespec="seconds"), conventions=CONVENTIONS)
        prov = f.create_group("provenance")
        prov.attrs.update(
            preset=spec["preset"], theta_deg=spec["theta_deg"], rotate_at_strain=spec["rotate_at_strain"],
            seed=spec["seed"], yade_version=meta["yade_version"], git_commit=provenance.get("git_commit", "unknown"),
            started=provenance.get("started", ""), finished=provenance.get("finished", ""),
            sessions=json.dumps(provenance.get("sessions", [])), spec_json=json.dumps(spec, sort_keys=True),
            overrides=json.dumps(spec["overrides"], sort_keys=True),
        )
        params = f.create_group("parameters")
        params.attrs.update({k: v for k, v in spec.items() if isinstance(v, (int, float)) and not isinstance(v, bool)})
        params.attrs.update(
            kn_pd=meta["kn"], kt_pd=meta["kt"], cn=meta["cn"], ct=meta["ct"], dt=meta["dt"],
            n_grains=meta["n_grains"], n_wall_spheres=meta["n_wall_spheres"], gap0_d=meta["gap0"],
            wall_speed=meta["wall_speed"], gamma_dot_nominal=meta["gamma_dot_nominal"], iterations=meta["iterations"],
            callback_seconds=meta["callback_seconds"], loop_seconds=meta["loop_seconds"],
        )
        _dataset(params, "grain_diameter", 2 * np.asarray(meta["grain_radius"]), "d")
        g_raw = f.create_group("raw")
        for key, unit in RAW_UNITS.items():
            _dataset(g_raw, key, raw[key], unit)
        g_series = f.create_group("series")
        for key, unit in SERIES_UNITS.items():
            _dataset(g_series, key, series[key], unit)
        g_cycle = f.create_group("cycle")
        g_cycle.attrs.update(n_cycles=spec["n_cycles"], period_strain=spec["period_strain"])
        _dataset(g_cycle, "strain", cycle["strain"], "1")
        for key in CYCLE_KEYS:
            _dataset(g_cycle, key, cycle[key], SERIES_UNITS[key])
            _dataset(g_cycle, key + "_sem", cycle[key + "_sem"], SERIES_UNITS[key])
    os.replace(tmp, out)


@dataclass(frozen=True)
class DemRun:
    """One DEM run as arrays: ``raw``, ``series`` and ``cycle`` dicts, plus its parameters and provenance."""

    path: Path
    spec: dict
    parameters: dict
    provenance: dict
    raw: dict
    series: dict
    cycle: dict
    units: dict

    @property
    def theta_deg(self) -> float:
        return self.spec["theta_deg"]


def load(path) -> DemRun:
    """Read a DEM run file written by :func:`write_h5`."""
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise DemFileError(f"cannot open {path}: {exc}") from None
    with f:
        if f.attrs.get("schema") != SCHEMA:
            raise DemFileError(f"{path} is not a DEM run file (schema {f.attrs.get('schema')!r})")
        if f.attrs["schema_version"] != SCHEMA_VERSION:
            raise DemFileError(f"{path} has schema version {f.attrs['schema_version']}, expected {SCHEMA_VERSION}")
        units = {}
        groups = {}
        for name in ("raw", "series", "cycle"):
            groups[name] = {k: ds[()] for k, ds in f[name].items()}
            units.update({f"{name}/{k}": ds.attrs["unit"] for k, ds in f[name].items()})
        prov = dict(f["provenance"].attrs)
        params = dict(f["parameters"].attrs)
        spec = json.loads(prov["spec_json"])
    return DemRun(path, spec, params, prov, groups["raw"], groups["series"], groups["cycle"], units)
