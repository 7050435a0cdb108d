"""A run's spec as every stage reads it: its identity and one typed field per key of ``config/dem.toml``.

``spec.json`` in a run folder and ``provenance/spec_json`` in a run file hold ``DemSpec.to_dict()``; ``from_dict``
reads them back, those written before a key existed included (``LEGACY_DEFAULTS``). Standard library only: the scenes
read it in Debian's python3. Validation against physics and the presets is ``pipeline.spec.resolve``'s.
Units as in ``config/dem.toml``: lengths in d, stresses in p, densities in rho, strain t*gamma_dot, angles in degrees.
"""

import dataclasses

SPEC_VERSION = 1
#: the reference engine, which a spec written before specs named their engine ran
LEGACY_ENGINE = "yade"
#: values of keys that files written before the keys existed lack: they ran without dense samples and without the
#: contact budget
LEGACY_DEFAULTS = {"engine": LEGACY_ENGINE, "dense_window_strain": 0.0, "dense_sample_strain": 0.0,
                   "contact_track_strain": 0.0}
#: keys read as whole numbers; every other value is a float
INTEGER_KEYS = frozenset({"n_cycles", "control_every_steps", "checkpoint_steps", "seed"})


@dataclasses.dataclass(frozen=True)
class DemSpec:
    """One run of the Couette experiment (Sec. 2, Fig. 1): which preset, engine, angle and rotation strain, where it
    goes, and every value of ``config/dem.toml`` (their meaning is documented there)."""

    preset: str
    engine: str
    theta_deg: float  # the second half-period's shear direction, about e2 (e1 towards e3)
    rotate_at_strain: float  # strain within each period at which the direction turns to theta
    name: str  # the run's file stem (theta090, theta090_rot0.10)
    folder: str  # its folder under results/: <preset>[-<engine>][-<hash of the overrides>]
    overrides: dict  # the values given beyond the preset's, {key: number}
    width_d: float
    gap_d: float
    diameter_min_d: float
    diameter_max_d: float
    fill_packing_fraction: float
    overlap_ratio: float
    kt_over_kn: float
    restitution: float
    friction_deg: float
    inertial_number: float
    period_strain: float
    pre_strain: float
    n_cycles: int
    sample_strain: float
    dense_window_strain: float
    dense_sample_strain: float
    contact_track_strain: float
    region_margin_d: float
    profile_bin_d: float
    dt_safety: float
    control_time: float
    control_every_steps: int
    compaction_tolerance: float
    compaction_hold_time: float
    compaction_max_time: float
    stress_alarm: float
    stress_alarm_strain: float
    checkpoint_steps: int
    seed: int

    @classmethod
    def from_dict(cls, data: dict) -> "DemSpec":
        """A spec from ``spec.json`` (or a run file's); a key it lacks, beyond ``LEGACY_DEFAULTS``, or one it does not
        know is a ``ValueError`` naming them."""
        given = {**LEGACY_DEFAULTS, **{k: v for k, v in data.items() if k != "spec_version"}}
        version = data.get("spec_version", SPEC_VERSION)
        if version != SPEC_VERSION:
            raise ValueError(f"spec_version {version!r} is not {SPEC_VERSION}")
        names = [f.name for f in dataclasses.fields(cls)]
        missing, unknown = sorted(set(names) - set(given)), sorted(set(given) - set(names))
        if missing or unknown:
            raise ValueError(f"not a run spec: missing {missing}, unknown {unknown}")
        return cls(**{k: _typed(k, given[k]) for k in names})

    @classmethod
    def value_keys(cls) -> tuple[str, ...]:
        """The keys of ``config/dem.toml``, in its order."""
        return tuple(f.name for f in dataclasses.fields(cls))[7:]

    @property
    def values(self) -> dict:
        """Every value of ``config/dem.toml`` for this run, ``{key: number}``."""
        return {k: getattr(self, k) for k in self.value_keys()}

    def to_dict(self) -> dict:
        """``spec.json``: the identity first, then every value."""
        return {"spec_version": SPEC_VERSION, "preset": self.preset, "engine": self.engine,
                "overrides": dict(self.overrides), "theta_deg": self.theta_deg,
                "rotate_at_strain": self.rotate_at_strain, "name": self.name, "folder": self.folder, **self.values}

    def label(self) -> str:
        """``<folder>/<name>``, as logs and listings name a run."""
        return f"{self.folder}/{self.name}"


def _typed(key: str, value):
    if key in INTEGER_KEYS:
        return int(value)
    if key in ("preset", "engine", "name", "folder"):
        return str(value)
    if key == "overrides":
        return dict(value)
    return float(value)


def read_spec(path) -> DemSpec:
    """The spec of a run folder's ``spec.json`` (``ValueError`` where it is not one)."""
    import json

    with open(path) as fh:
        return DemSpec.from_dict(json.load(fh))


def same_spec(stored, spec: DemSpec) -> bool:
    """Whether ``stored`` (a ``spec.json``'s, a checkpoint's or a run file's dict) is ``spec``'s; one that is no
    spec at all is not."""
    try:
        return isinstance(stored, dict) and DemSpec.from_dict(stored) == spec
    except (TypeError, ValueError):
        return False
