"""The DEM run file: the raw samples and their provenance, one self-describing HDF5 file per run.

Layout (schema ``granular-backstress/dem-run`` v3; H5MD in spirit: a version at the root, a ``unit``
on every dataset):

``/`` attrs ``schema``, ``schema_version``, ``creator``, ``created``, ``conventions``
``/provenance`` attrs: preset, theta_deg, seed, engine and its version (and ``yade_version`` for a Yade run), git
commit, commands, timestamps, spec
``/parameters`` attrs: every spec value, plus the contact constants and the time step; ``grain_diameter``
``/raw/...`` the samples as taken, named and unit-tagged by ``config/raw_schema.toml`` [samples]
``/contacts/...`` the contact budget of every sample (``dem/core/budget.py``; [contacts]), in runs that track their
contacts (version 3 on; a file without it reads with ``DemRun.contacts`` None); version 4 adds the near pairs, the
gain and loss by load and the continuous persistence (``dem/core/neighbours.py``), and names version 3's
``persistence`` ``persistence_touching`` (read under the new name from either)

Nothing derived is stored: series and cycles are computed when the file is read
(``pipeline.dataset.derived``), with the definitions the reader chooses, so a run never depends on
the version of the analysis. Version-1 files (which also stored ``/series`` and ``/cycle``) are
read the same way; their derived groups are ignored.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import json
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from dem.core.protocol import on_grid, sample_strains
from dem.core.schema import contact_fields, contact_fields_of, sample_fields
from dem.core.spec import LEGACY_ENGINE, DemSpec
from model import json_text
from model.cli import printable

from ..errors import DemFileError
from ..io import atomic_path, h5_file
from . import derived
from .contacts import check_contacts
from .reader import RunFileReader

SCHEMA = "granular-backstress/dem-run"
SCHEMA_VERSION = 4
READABLE_VERSIONS = (1, 2, 3, 4)
CONVENTIONS = ("stress tension-positive, normalised by the controlled wall normal stress p; tau = sigma' "
               "(deviator); walls normal to e2; shear direction cos(phi) e1 + sin(phi) e3, phi from e1 towards "
               "e3; strain t*gamma_dot from the start of the first period; fabric A = <n n> - I/3 (Eq. 8)")
#: the spec values every reader needs


def read_raw(path: Path) -> tuple[dict, dict]:
    """The scene's ``raw.npz``: ``(arrays, meta)``; a damaged file is a :class:`DemFileError`."""
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
        meta = json.loads(str(arrays.pop("meta_json")))
    except (OSError, ValueError, KeyError, EOFError) as exc:
        raise DemFileError(f"{path} is not a readable raw sample file ({type(exc).__name__}); "
                           "rerun with FRESH=1") from None
    return arrays, meta


def _dataset(group, name, data, unit):
    ds = group.create_dataset(name, data=data)
    ds.attrs["unit"] = unit
    return ds


def write_h5(raw_path: Path, out: Path, provenance: dict) -> None:
    """Write ``out`` atomically (temporary file, then rename) from the scene's ``raw.npz``."""
    raw, meta = read_raw(raw_path)
    try:
        spec = DemSpec.from_dict(meta["spec"])
    except (TypeError, ValueError) as exc:
        raise DemFileError(f"{raw_path}: its spec is not a run spec ({exc})") from None
    fields = sample_fields()
    missing = sorted(set(fields) - set(raw))
    if missing:
        raise DemFileError(f"{raw_path} lacks the raw field(s) {', '.join(missing)}")
    tracked = sorted(set(contact_fields()) & set(raw))
    if tracked and len(tracked) < len(contact_fields()):
        raise DemFileError(f"{raw_path} has part of the contact budget only (lacks "
                           f"{', '.join(sorted(set(contact_fields()) - set(raw)))})")
    # every cycle complete on the grid?
    grid = grid_samples(raw["strain"], spec)
    derived.cycle_indices(raw["strain"][grid], spec.period_strain, spec.sample_strain, spec.n_cycles)
    with atomic_path(out) as tmp, h5_file(tmp) as f:
        f.attrs.update(schema=SCHEMA, schema_version=SCHEMA_VERSION, creator="granular-backstress",
                       created=dt.datetime.now().isoformat(timespec="seconds"), conventions=CONVENTIONS)
        prov = f.create_group("provenance")
        prov.attrs.update(
            preset=spec.preset, theta_deg=spec.theta_deg, rotate_at_strain=spec.rotate_at_strain,
            seed=spec.seed, engine=meta.get("engine", LEGACY_ENGINE),
            engine_version=str(meta.get("engine_version", meta.get("yade_version", ""))),
            git_commit=provenance.get("git_commit", "unknown"),
            started=provenance.get("started", ""), finished=provenance.get("finished", ""),
            sessions=json.dumps(provenance.get("sessions", [])), spec_json=json.dumps(meta["spec"], sort_keys=True),
            overrides=json.dumps(spec.overrides, sort_keys=True),
        )
        if meta.get("yade_version"):  # a Yade run's (the reference engine's files have always named it)
            prov.attrs["yade_version"] = meta["yade_version"]
        params = f.create_group("parameters")
        params.attrs.update({k: v for k, v in meta["spec"].items()
                             if isinstance(v, (int, float)) and not isinstance(v, bool)})
        params.attrs.update(
            kn_pd=meta["kn"], kt_pd=meta["kt"], cn=meta["cn"], ct=meta["ct"], dt=meta["dt"],
            n_grains=meta["n_grains"], n_wall_spheres=meta["n_wall_spheres"], gap0_d=meta["gap0"],
            wall_speed=meta["wall_speed"], gamma_dot_nominal=meta["gamma_dot_nominal"], iterations=meta["iterations"],
            callback_seconds=meta["callback_seconds"], loop_seconds=meta["loop_seconds"],
        )
        for key in ("cpu_seconds", "track_seconds"):  # counted from 2026-11-24 and 2026-11-28 on
            if key in meta:
                params.attrs[key] = meta[key]
        _dataset(params, "grain_diameter", 2 * np.asarray(meta["grain_radius"]), "d")
        g_raw = f.create_group("raw")
        for key, info in fields.items():
            _dataset(g_raw, key, raw[key], info["unit"])
        if tracked:
            g_contacts = f.create_group("contacts")
            for key, info in contact_fields().items():
                _dataset(g_contacts, key, raw[key], info["unit"])


def grid_samples(strain, spec) -> np.ndarray:
    """Mask of the samples on the regular grid (every ``sample_strain``); the others are the dense samples
    after each change of direction (``dense_sample_strain``). The scene takes one sample per target of
    ``dem.core.protocol.sample_strains``, in order, so the k-th sample is the k-th target's, however late within its
    controller interval it landed (a coarse time step can put it further from its target than the dense spacing);
    samples beyond the targets are told by their strain (``on_grid``)."""
    step = spec.sample_strain
    targets = sample_strains(spec)
    by_target = [abs((t + spec.pre_strain) / step - round((t + spec.pre_strain) / step)) < 1e-6
                 for t in targets[:len(strain)]]
    return np.array(by_target + [on_grid(float(s), spec) for s in strain[len(targets):]], dtype=bool)


@dataclass(frozen=True)
class DemRun:
    """One DEM run: its raw samples, spec, parameters and provenance; series and cycle derived on demand,
    with ``definitions`` (:class:`pipeline.dataset.derived.Definitions`; ``with_definitions`` for others).

    ``raw`` holds the samples on the regular grid (every ``sample_strain``: what the cycle averages and
    the fits read); ``raw_all`` every sample, the dense ones after each change of direction included; ``contacts``
    the contact budget of every sample (``config/raw_schema.toml`` [contacts]), None for a run that did not track
    its contacts.
    """

    path: Path
    spec: DemSpec
    parameters: dict
    provenance: dict
    raw: dict
    units: dict
    grain_diameter: np.ndarray = field(repr=False, default=None)
    definitions: derived.Definitions = derived.DEFAULT
    raw_all: dict = field(repr=False, default=None)
    contacts: dict | None = field(repr=False, default=None)

    @property
    def theta_deg(self) -> float:
        return self.spec.theta_deg

    @property
    def engine(self) -> str:
        """The DEM engine that ran it (a file from before specs named their engine is Yade's)."""
        return self.spec.engine

    @property
    def is_reversal(self) -> bool:
        """The second half period turns the shear direction by 180 degrees (the paper's reversal)."""
        return math.isclose(abs(self.spec.theta_deg), 180.0, abs_tol=1e-9)

    @property
    def default_rotation(self) -> bool:
        """The direction turns at half the period (Fig. 1), not at another strain (Fig. 7)."""
        return math.isclose(self.spec.rotate_at_strain, self.spec.period_strain / 2, abs_tol=1e-9)

    @property
    def overrides(self) -> dict:
        return dict(self.spec.overrides)

    @property
    def sessions(self) -> list[dict]:
        """The sessions that ran it (when, the command, its ranks and threads, the commit), oldest first."""
        return sessions(self.provenance)

    @property
    def cpu_seconds(self) -> float:
        """The run's loop in CPU-seconds (``cpu_seconds``)."""
        return cpu_seconds(self.parameters, self.sessions)

    def with_definitions(self, definitions: derived.Definitions) -> DemRun:
        """The same run read with other definitions of strain, Phi and p (series and cycle recomputed)."""
        return self if definitions == self.definitions else dataclasses.replace(self, definitions=definitions)

    def without_first_cycles(self, k: int) -> DemRun:
        """The run as if its first ``k`` cycles had been part of its preparation (a packing still compacting in
        them: ``SKIP_CYCLES``): the samples from ``pre_strain`` before cycle k's start on, the nominal strain counted
        from that start, ``n_cycles - k`` cycles in its spec. ``k`` = 0 is the run itself."""
        if not 0 <= k < self.spec.n_cycles:
            raise ValueError(f"skip_cycles={k} leaves no cycle of {self.path.name}'s {self.spec.n_cycles}")
        if k == 0:
            return self
        start = k * self.spec.period_strain

        def trimmed(raw):
            keep = raw["strain"] >= start - self.spec.pre_strain - 1e-9
            out = {key: value[keep] for key, value in raw.items()}
            out["strain"] = out["strain"] - start
            return out

        spec = dataclasses.replace(self.spec, n_cycles=self.spec.n_cycles - k)
        contacts = None
        if self.contacts is not None:
            keep = self.raw_all["strain"] >= start - self.spec.pre_strain - 1e-9
            contacts = {key: value[keep] for key, value in self.contacts.items()}
        return dataclasses.replace(self, spec=spec, raw=trimmed(self.raw), raw_all=trimmed(self.raw_all),
                                   contacts=contacts)

    @cached_property
    def series(self) -> dict:
        return derived.model_series(self.raw, self.parameters, self.definitions, self.grain_diameter)

    @cached_property
    def series_all(self) -> dict:
        """:attr:`series` over every sample, the dense ones after each change of direction included."""
        return derived.model_series(self.raw_all, self.parameters, self.definitions, self.grain_diameter)

    @cached_property
    def cycle(self) -> dict:
        return derived.run_cycle(self)


def _check_raw(path: Path, raw: dict) -> None:
    """The basic fields finite, and strain rising sample by sample (the schema's shapes: ``RunFileReader``)."""
    for key in ("strain", "time", "direction_deg", "fabric", "stress_contact", "stress_kinetic", "packing_fraction"):
        if not np.all(np.isfinite(raw[key])):
            raise DemFileError(f"{path}: /raw/{key} has non-finite values")
    if np.any(np.diff(raw["strain"]) <= 0):
        raise DemFileError(f"{path}: /raw/strain does not rise from sample to sample")


def _check_cycles(path: Path, raw: dict, spec: DemSpec, grid: np.ndarray) -> None:
    """The samples on the regular grid make whole cycles of the spec's protocol."""
    try:
        derived.cycle_indices(raw["strain"][grid], spec.period_strain,
                              spec.sample_strain, spec.n_cycles)
    except ValueError as exc:
        raise DemFileError(f"{path}: {exc}") from None


def sessions(provenance: dict) -> list[dict]:
    """A file's sessions from its ``/provenance`` attributes, oldest first."""
    text = provenance.get("sessions", "[]")
    if not isinstance(text, str) or not text:
        return []
    try:
        found = json_text.loads(text, "its /provenance attribute 'sessions'")
    except ValueError as exc:
        raise DemFileError(str(exc)) from None
    return found if isinstance(found, list) and all(isinstance(s, dict) for s in found) else []


def cpu_seconds(parameters: dict, run_sessions: list[dict]) -> float:
    """A run's loop in CPU-seconds: counted with each session's cores where the file has it
    (``parameters/cpu_seconds``); else the loop's wall time times the most cores a session used, an upper
    bound where a run changed its ranks or threads (``cpu_seconds_counted`` tells which)."""
    if cpu_seconds_counted(parameters):
        return float(parameters["cpu_seconds"])
    most = max((s.get("ranks", 1) * s.get("threads", 1) for s in run_sessions), default=1)
    return float(parameters["loop_seconds"]) * most


def cpu_seconds_counted(parameters: dict) -> bool:
    return "cpu_seconds" in parameters


#: most profile bins across the gap a run file may declare
MAX_BINS = 10_000


def schema_shape(info: dict, n: int, bins: int) -> tuple:
    """A field's full shape in a file of ``n`` samples and ``bins`` profile bins (``config/raw_schema.toml``)."""
    return (n, *(bins + 1 if d == "bins+1" else bins if d == "bins" else d for d in info["shape"]))


def run_provenance(path) -> tuple[dict, dict, DemSpec]:
    """A run file's ``/provenance`` and ``/parameters`` attributes and its spec, read through ``RunFileReader``."""
    with RunFileReader(path) as reader:
        return _header(reader)


def _header(reader: RunFileReader) -> tuple[dict, dict, DemSpec]:
    root = reader.attributes("/")
    if not isinstance(root.get("schema"), str) or root["schema"] != SCHEMA:
        reader.refuse("/", f"is not a DEM run file (schema {printable(root.get('schema'))})")
    version = root.get("schema_version", -1)
    if not isinstance(version, (int, np.integer)) or int(version) not in READABLE_VERSIONS:
        reader.refuse("/", f"has schema version {printable(version)}; this code reads {READABLE_VERSIONS}")
    prov, params = reader.attributes("/provenance"), reader.attributes("/parameters")
    stored = reader.json_attribute(prov, "/provenance", "spec_json")
    try:
        spec = DemSpec.from_dict(stored)
    except (TypeError, ValueError, AttributeError) as exc:
        reader.refuse("its spec", f"is not a run spec ({printable(exc)})")
    return prov, params, spec


def load(path) -> DemRun:
    """Read a DEM run file (schema v1 to v4) through ``RunFileReader``, checked against the schema before any
    sample is read (links, storage, types, shapes, units, size), then for finite values and whole cycles, and the
    contact budget's values by their kinds (``pipeline.dataset.contacts``)."""
    with RunFileReader(path) as reader:
        path = reader.path
        prov, params, spec = _header(reader)
        n = reader.samples("/raw/strain")
        edges = reader.check_dataset("/raw/profile_edges", (n, None), sample_fields()["profile_edges"]["unit"])
        bins = edges.shape[1] - 1
        if not 0 < bins <= MAX_BINS:
            reader.refuse("/raw/profile_edges", f"declares {bins} bins (1 to {MAX_BINS})")
        checked = {("raw", k): reader.check_dataset(f"/raw/{k}", schema_shape(info, n, bins), info["unit"])
                   for k, info in sample_fields().items()}
        tracked = reader.has("/contacts")
        if tracked:
            version = int(reader.attributes("/")["schema_version"])
            checked |= {("contacts", k): reader.check_dataset(f"/contacts/{stored}", schema_shape(info, n, bins),
                                                              info["unit"])
                        for k, (stored, info) in contact_fields_of(version).items()}
        has_diameters = reader.has("/parameters/grain_diameter")
        if has_diameters:
            grains = params.get("n_grains")
            checked[("parameters", "grain_diameter")] = reader.check_dataset(
                "/parameters/grain_diameter", (int(grains) if isinstance(grains, (int, np.integer)) else -1,), "d")
        data = reader.read(checked)
    raw = {k: v for (group, k), v in data.items() if group == "raw"}
    contacts = {k: v for (group, k), v in data.items() if group == "contacts"} if tracked else None
    diameters = data.get(("parameters", "grain_diameter"))
    units = {f"raw/{k}": info["unit"] for k, info in sample_fields().items()}
    if "gamma_dot_nominal" not in params:
        raise DemFileError(f"{path}: the parameters lack gamma_dot_nominal")
    _check_raw(path, raw)
    if contacts is not None:
        check_contacts(path, contacts, raw["fabric"])
    grid = grid_samples(raw["strain"], spec)
    _check_cycles(path, raw, spec, grid)
    return DemRun(path, spec, params, prov, {k: v[grid] for k, v in raw.items()}, units, diameters, raw_all=raw,
                  contacts=contacts)
