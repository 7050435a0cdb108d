"""The driver's persistent state: everything a run needs to go on from a checkpoint besides the engine's own
(saved as JSON with each checkpoint). Units: d = p = rho = 1, time in d sqrt(rho/p), strain t*gamma_dot."""

import dataclasses


@dataclasses.dataclass
class RunState:
    """Where the run is (``phase``: compaction, shear, done, failed), the wall controller's and the sampler's
    bookkeeping, the time spent, and what the engine built (grain ids, the walls' inner planes, the contact
    constants; the engine-specific entries are None in the other engine)."""

    next_checkpoint: int  # the iteration of the next regular checkpoint
    first_grain: int  # the first grain's id; grains are first_grain .. first_grain + n_grains - 1
    n_grains: int
    bottom_inner_offset: float  # from a wall's first sphere to its inner plane (the rough layer's centre plane)
    top_inner_offset: float
    kn: float  # contact constants (dem.core.contact.contact_constants)
    kt: float
    cn: float
    ct: float
    phase: str = "compaction"
    hold_since: float | None = None  # compaction: the start of the window the wall stress is judged over
    hold_sum: float = 0.0
    hold_n: int = 0
    t_shear0: float | None = None  # the time shear started (strain -pre_strain)
    gap0: float | None = None  # the gap H0 when shear started, d
    wall_speed: float | None = None  # U = gamma_dot H0 / 2
    next_sample: int = 0  # index into protocol.sample_strains
    next_track: int = 0  # index into protocol.track_strains (the contact budget's tracking points)
    alarm_strain: float = 0.0  # strain the wall stress has been off target in a row
    samples_file: str | None = None  # the samples saved beside the last checkpoint
    err_sum: float = 0.0  # the wall stress error since the last sample: sum, count, largest
    err_n: int = 0
    err_max: float = 0.0
    track_seconds: float = 0.0  # the contact budget's tracking points between samples (gather and track)
    callback_seconds: float = 0.0  # our Python in the loop, the loop, the process's CPU
    loop_seconds: float = 0.0
    cpu_seconds: float = 0.0
    top: list | None = None  # Yade: the walls' clump ids and member ids
    bottom: list | None = None
    n_wall_spheres: int | None = None  # LAMMPS: wall atoms come first
    dt: float | None = None  # LAMMPS: the time step (Yade keeps its own, O.dt)

    @classmethod
    def from_dict(cls, data: dict) -> "RunState":
        """The state of a checkpoint; an entry it does not know, or a missing one without a default, is a
        ``ValueError``. A state written before ``cpu_seconds`` was counted takes the loop's seconds."""
        names = {f.name for f in dataclasses.fields(cls)}
        data = {"cpu_seconds": data.get("loop_seconds", 0.0), **data}  # a state from before it was counted
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValueError(f"not a run state: unknown entries {unknown}")
        try:
            return cls(**data)
        except TypeError as exc:
            raise ValueError(f"not a run state: {exc}") from None

    def to_dict(self) -> dict:
        """JSON-able, without the other engine's entries."""
        return {k: v for k, v in dataclasses.asdict(self).items()
                if not (v is None and k in ("top", "bottom", "n_wall_spheres", "dt"))}
