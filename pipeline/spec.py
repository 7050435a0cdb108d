"""DEM run specification: presets from ``config/dem.toml``, overrides, validation, names and paths.

One source of truth for the Couette experiment's parameters, below every stage. ``resolve`` gives the validated,
frozen :class:`dem.core.spec.DemSpec` of one run (one typed field per key of ``config/dem.toml``); its ``to_dict`` is
the ``spec.json`` the scenes read.
Units: lengths in mean diameters d, stresses in the wall normal stress p, densities in the grain
density rho (time in d sqrt(rho/p)); strain is t * gamma_dot; angles in degrees.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from decimal import Decimal
from pathlib import Path

from dem.core.contact import tangential_damping_number
from dem.core.protocol import grain_count, sample_strains
from dem.core.spec import INTEGER_KEYS, DemSpec, same_spec

from . import engines
from .config import PRESETS_FILE, load_presets
from .engines import DEFAULT_ENGINE, ENGINES
from .errors import SpecError
from .paths import RESULTS_DIR

__all__ = ["DEFAULT_ENGINE", "ENGINES", "DemSpec", "resolve", "same_spec"]
#: keys that must be > 0 (everything else numeric must be >= 0 or is checked specifically)
POSITIVE_KEYS = {
    "width_d", "gap_d", "diameter_min_d", "diameter_max_d", "fill_packing_fraction", "overlap_ratio",
    "kt_over_kn", "restitution", "inertial_number", "period_strain", "sample_strain", "profile_bin_d",
    "dt_safety", "control_time", "control_every_steps", "compaction_tolerance", "compaction_hold_time",
    "compaction_max_time", "stress_alarm", "stress_alarm_strain", "checkpoint_steps", "n_cycles",
}


def parse_overrides(items: list[str] | tuple[str, ...]) -> dict[str, float]:
    """``["key=value", ...]`` -> ``{key: float}``; a malformed item is a :class:`SpecError`."""
    out = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise SpecError(f"override {item!r} is not of the form key=value")
        if not _NUMBER.fullmatch(text.strip()):
            raise SpecError(f"override {key}={text.strip()!r} is not a number")
        out[key] = float(text)
    return out


def _check_values(values: dict, candidate) -> None:
    """Every value a number, finite, whole where it must be and within its sign; then the bounds between values
    and those physics sets (``_physical_problems``), read from ``candidate``, the spec these values make. Every
    problem at once, in one :class:`SpecError`."""
    problems = []
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            problems.append(f"{key}={value!r} is not a number")
        elif not math.isfinite(value):
            problems.append(f"{key}={value!r} is not finite")
        elif key in INTEGER_KEYS and value != int(value):
            problems.append(f"{key}={value!r} must be an integer")
        elif key in POSITIVE_KEYS and value <= 0:
            problems.append(f"{key}={value!r} must be > 0")
        elif value < 0:
            problems.append(f"{key}={value!r} must be >= 0")
    if not problems:
        problems += _relation_problems(candidate) + _physical_problems(candidate)
    if problems:
        raise SpecError("; ".join(problems))


def _relation_problems(v: DemSpec) -> list[str]:
    """Bounds between the values of one spec."""
    problems = []
    if v.width_d != int(v.width_d) or int(v.width_d) % 2:
        problems.append(f"width_d={v.width_d!r} must be an even integer (the wall pattern repeats every 2d)")
    if v.diameter_min_d >= v.diameter_max_d:
        problems.append(f"diameter_min_d={v.diameter_min_d!r} must be < diameter_max_d")
    if v.diameter_max_d >= v.width_d / 2:
        problems.append(f"diameter_max_d={v.diameter_max_d!r} must be < width_d/2 = {v.width_d / 2:g}: a grain of half "
                        "the periodic cell or more meets its own image")
    if 2 * v.region_margin_d >= v.gap_d:
        problems.append(f"region_margin_d={v.region_margin_d!r} leaves no central region")
    if v.restitution >= 1:
        problems.append(f"restitution={v.restitution!r} must be < 1")
    if v.friction_deg >= 90:
        problems.append(f"friction_deg={v.friction_deg!r} must be < 90")
    if v.sample_strain >= v.period_strain / 2:
        problems.append(f"sample_strain={v.sample_strain!r} must be < period_strain/2")
    ratio = v.sample_strain / v.dense_sample_strain if v.dense_sample_strain else 0
    if v.dense_window_strain > 0 and not (ratio >= 2 and abs(ratio - round(ratio)) < 1e-6):
        problems.append(f"dense_sample_strain={v.dense_sample_strain!r} must divide sample_strain="
                        f"{v.sample_strain!r} at least twice when dense_window_strain > 0")
    if v.dense_window_strain >= v.period_strain / 2:
        problems.append(f"dense_window_strain={v.dense_window_strain!r} must be < period_strain/2")
    if v.contact_track_strain > v.sample_strain:
        problems.append(f"contact_track_strain={v.contact_track_strain!r} must be <= sample_strain="
                        f"{v.sample_strain!r} (the contacts are tracked at every sample too), or 0 for none")
    return problems


#: a grain in up to ~12 contacts has a stiffness ~12 k_n: explicit integration is stable for
#: dt < 2 sqrt(m / 12 k_n) = 0.58 sqrt(m_min / k_n)
MAX_DT_SAFETY = 0.5
#: c_t dt / m_t of the lightest pair (``dem.core.contact.tangential_damping_number``): measured on the tiny cell,
#: the contacts' energy balance closes up to 2.97 and the run blows up at 3.96 (restitution 0.1)
MAX_TANGENTIAL_DAMPING = 3.0
MAX_OVERLAP_RATIO = 0.01  # delta/d: grains stay quasi-rigid
RANDOM_CLOSE_PACKING = 0.64
QUASI_STATIC_I = 1e-2  # above this inertial number the flow is no longer quasi-static
MAX_SEED = 2**31 - 1
MIN_SAMPLE_STRAIN = 5e-4  # every sample is a pass over the contacts and a row of profiles
MIN_PROFILE_BIN_D = 0.25
#: the most grains a run may create, and about what each costs the engine (bodies, contacts, collider; Yade's
#: paper cell, 5 714 grains, holds about 40 MB): a cell of 7e8 grains would ask for hundreds of GiB
MAX_GRAINS, BYTES_PER_GRAIN = 2_000_000, 8 * 1024
MIN_TRACK_STRAIN = 2.5e-5  # every tracking point is a pass over the contacts (tens of steps in the quick cells)


def _physical_problems(v: DemSpec) -> list[str]:
    """Bounds that physics sets, each with its reason."""
    problems = []
    if v.dt_safety > MAX_DT_SAFETY:
        problems.append(f"dt_safety={v.dt_safety!r} is past the stability limit of the contact oscillation "
                        f"(a grain in ~12 contacts needs dt_safety <= {MAX_DT_SAFETY})")
    damping = tangential_damping_number(v)
    if v.restitution < 1 and damping > MAX_TANGENTIAL_DAMPING:
        problems.append(f"restitution={v.restitution!r} with dt_safety={v.dt_safety!r} damps the "
                        f"lightest pair's tangential contact too hard for the time step (c_t dt/m_t = {damping:.2f} > "
                        f"{MAX_TANGENTIAL_DAMPING}): lower dt_safety or raise the restitution")
    if v.overlap_ratio > MAX_OVERLAP_RATIO:
        problems.append(f"overlap_ratio={v.overlap_ratio!r} is not a small overlap (grains must stay "
                        f"quasi-rigid: delta/d <= {MAX_OVERLAP_RATIO})")
    if v.fill_packing_fraction > RANDOM_CLOSE_PACKING:
        problems.append(f"fill_packing_fraction={v.fill_packing_fraction!r} is above random close packing "
                        f"({RANDOM_CLOSE_PACKING}): the grains cannot fit in the gap")
    if v.seed > MAX_SEED:
        problems.append(f"seed={v.seed!r} must be <= {MAX_SEED}")
    if v.diameter_max_d > v.width_d / 2:
        problems.append(f"diameter_max_d={v.diameter_max_d!r} must be <= width_d/2 (a grain would touch its "
                        "own periodic image)")
    if v.gap_d < 2 * v.diameter_max_d:
        problems.append(f"gap_d={v.gap_d!r} must hold at least two of the largest grains")
    if v.restitution < 0.01:
        problems.append(f"restitution={v.restitution!r} must be >= 0.01 (e -> 0 is overdamped)")
    grains = grain_count(v)
    if grains < 10:
        problems.append(f"fill_packing_fraction={v.fill_packing_fraction!r} gives {grains:.0f} grains: at "
                        "least 10 are needed")
    if grains > MAX_GRAINS:
        problems.append(f"width_d={v.width_d!r}, gap_d={v.gap_d!r} and fill_packing_fraction="
                        f"{v.fill_packing_fraction!r} give {grains:.3g} grains, more than {MAX_GRAINS:.0e} (about "
                        f"{MAX_GRAINS * BYTES_PER_GRAIN / 2**30:.0f} GiB of memory in the engine)")
    if v.sample_strain < MIN_SAMPLE_STRAIN:
        problems.append(f"sample_strain={v.sample_strain!r} must be >= {MIN_SAMPLE_STRAIN} (a sample costs "
                        "a pass over every contact; dense_sample_strain samples finer after each change)")
    if v.dense_window_strain > 0 and v.dense_sample_strain < MIN_SAMPLE_STRAIN / 2:
        problems.append(f"dense_sample_strain={v.dense_sample_strain!r} must be >= {MIN_SAMPLE_STRAIN / 2}")
    if 0 < v.contact_track_strain < MIN_TRACK_STRAIN:
        problems.append(f"contact_track_strain={v.contact_track_strain!r} must be >= {MIN_TRACK_STRAIN} (each "
                        "tracking point is a pass over every contact), or 0 for no contact budget")
    if v.profile_bin_d < MIN_PROFILE_BIN_D:
        problems.append(f"profile_bin_d={v.profile_bin_d!r} must be >= {MIN_PROFILE_BIN_D} d (a profile "
                        "bin thinner than a quarter grain holds no average)")
    if v.checkpoint_steps < 1000:
        problems.append(f"checkpoint_steps={v.checkpoint_steps!r} must be >= 1000 (a checkpoint costs a save)")
    return problems


#: the longest run name (its file's stem): a rotation strain of many digits would make a name no file system takes
MAX_NAME_CHARS = 96


_NUMBER = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")


def parse_number(name: str, text) -> float:
    """A plain decimal number (``1_80`` and ``0x10`` are refused, unlike ``float``)."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value = float(text)
    elif isinstance(text, str) and _NUMBER.fullmatch(text.strip()):
        value = float(text)
    else:
        raise SpecError(f"{name}={text!r} is not a number")
    if not math.isfinite(value):
        raise SpecError(f"{name}={text!r} is not a finite number")
    return value


def exact_text(value: float) -> str:
    """Every digit of ``value`` (the shortest decimal that reads back as the same float), never in exponent form."""
    return format(Decimal(repr(float(value))), "f")


def run_name(theta_deg: float, rotate_at: float, default_rotate_at: float) -> str:
    """File stem of a run, with every digit of its angle and rotation strain, so that two specs never share
    it: ``theta090``, ``theta092.5``, ``theta000.01``, ``thetam045``, ``theta090_rot0.10``, ``theta090_rot0.101``."""
    whole, _, fraction = exact_text(abs(theta_deg)).partition(".")
    theta = f"{int(whole):03d}" + (f".{fraction}" if fraction.strip("0") else "")
    name = f"theta{'m' if theta_deg < 0 else ''}{theta}"
    if rotate_at != default_rotate_at:
        two = f"{rotate_at:.2f}"
        name += f"_rot{two if float(two) == rotate_at else exact_text(rotate_at)}"
    return name


def resolve(theta_deg, preset: str = "quick", rotate_at=None, overrides: dict | None = None,
            presets_file: Path = PRESETS_FILE, allow_inertial: bool = False, engine: str = DEFAULT_ENGINE) -> DemSpec:
    """Validate everything and return the run's :class:`DemSpec`; raises :class:`SpecError`.

    ``theta_deg``: rotation of the second half-period's shear direction about e2, in degrees
    (positive turns e1 towards e3). ``rotate_at``: strain within each period at which the direction
    turns from e1 to theta (default: half the period, Fig. 1). ``allow_inertial`` admits inertial
    numbers past the quasi-static regime. ``engine``: the DEM engine (``pipeline.engines``); a run of another engine
    than the reference goes to ``<preset>-<engine>[-<hash>]/``.
    """
    if engine not in ENGINES:
        raise SpecError(f"engine={engine!r} is not a DEM engine here (known: {', '.join(ENGINES)})")
    theta = parse_number("theta", theta_deg)
    if not -180 <= theta <= 180:
        raise SpecError(f"theta={theta_deg!r} must lie in [-180, 180] degrees (other angles repeat these)")
    if theta == -180:
        theta = 180.0  # the same reversal: one run, one name
    presets = load_presets(presets_file)
    if preset not in presets:
        raise SpecError(f"unknown preset {preset!r} (known: {', '.join(presets)})")
    overrides = dict(overrides or {})
    unknown = sorted(set(overrides) - set(presets[preset]))
    if unknown:
        raise SpecError(f"unknown override key(s) {', '.join(unknown)} (see {presets_file.name})")
    # a preset's own value is no override: the same run, in the same folder, with or without it
    overrides = {k: v for k, v in overrides.items() if not _same_value(v, presets[preset][k])}
    values = {**presets[preset], **overrides}
    candidate = DemSpec(preset=preset, engine=engine, theta_deg=theta, rotate_at_strain=0.0, name="", folder="",
                        overrides=overrides, **values)
    _check_values(values, candidate)
    if candidate.inertial_number > QUASI_STATIC_I and not allow_inertial:
        raise SpecError(f"inertial_number={candidate.inertial_number!r} is past the quasi-static regime "
                        f"(I <= {QUASI_STATIC_I}); pass --allow-inertial (ALLOW_INERTIAL=1) to run it anyway")
    period = candidate.period_strain
    default_rotate_at = period / 2
    if rotate_at is None:
        rotate_at = default_rotate_at
    rotate_at = parse_number("rotate_at", rotate_at)
    if not 0 < rotate_at < period:
        raise SpecError(f"rotate_at={rotate_at!r} must lie strictly between 0 and period_strain={period}")
    name = run_name(theta, rotate_at, default_rotate_at)
    if len(name) > MAX_NAME_CHARS:
        raise SpecError(f"theta={theta_deg!r} and rotate_at={rotate_at!r} name the run with {len(name)} characters "
                        f"(at most {MAX_NAME_CHARS}): give them with fewer digits")
    return DemSpec.from_dict({**candidate.to_dict(), "rotate_at_strain": rotate_at, "name": name,
                              "folder": run_folder(preset, engine, overrides)})


def filing_problems(stored: dict, spec: DemSpec) -> list[str]:
    """How a run file's spec (``stored`` as written, ``spec`` as read) disagrees with the name and folder it is
    filed under by its own values: its name from its angle and rotation (``run_name``), its folder from its preset,
    engine and overrides (``run_folder``), and each override its stated value. Values it does not override are not
    compared with today's preset: presets gain keys and change defaults, and a run is what its spec says it was."""
    problems = []
    name = run_name(spec.theta_deg, spec.rotate_at_strain, spec.period_strain / 2)
    if name != spec.name:
        problems.append(f"its angle and rotation make it {name}, not {spec.name}")
    folder = run_folder(spec.preset, spec.engine, spec.overrides)
    if folder != spec.folder:
        problems.append(f"its preset, engine and overrides file it in {folder}, not {spec.folder}")
    for key, value in spec.overrides.items():
        if key in stored and not _same_value(stored[key], value):
            problems.append(f"{key}={stored[key]!r} but its override says {value!r}")
    return problems


def _same_value(given, preset_value) -> bool:
    try:
        return float(given) == float(preset_value)
    except (TypeError, ValueError):
        return False  # not a number: _check_values names it


def run_folder(preset: str, engine: str = DEFAULT_ENGINE, overrides: dict | None = None) -> str:
    """The folder of a preset's runs: ``<preset>`` in Yade, ``<preset>-<engine>`` in another engine, and
    ``-<hash>`` after either for runs with overrides (the first 8 hex digits of SHA-1 of their sorted JSON)."""
    folder = preset if engines.engine(engine).name == DEFAULT_ENGINE else f"{preset}-{engine}"
    if overrides:
        digest = hashlib.sha1(json.dumps(overrides, sort_keys=True).encode()).hexdigest()[:8]
        folder = f"{folder}-{digest}"
    return folder


def output_path(spec: DemSpec, results_dir: Path = RESULTS_DIR) -> Path:
    """The run's HDF5 file: ``results/<folder>/dem/<name>.h5``."""
    return results_dir / spec.folder / "dem" / f"{spec.name}.h5"


def work_dir(spec: DemSpec, results_dir: Path = RESULTS_DIR) -> Path:
    """Scratch folder of a run (spec, checkpoints, raw samples, log) beside its HDF5 file."""
    return output_path(spec, results_dir).with_suffix(".run")


#: numbers stored per sample: the scalars and tensors of the central region (about 60) and, per profile bin,
#: velocity, packing fraction, stress, fabric and contacts (23)
SAMPLE_NUMBERS_FIXED, SAMPLE_NUMBERS_PER_BIN = 60, 23


def cost(spec: DemSpec) -> dict:
    """What a run costs, from its spec alone: the steps of shear (the preceding half period and the cycles at
    dt = dt_safety sqrt(m_min/k_n), m_min the smallest grain's mass), its samples, and their size in MB
    (compaction adds a few per cent of steps, unknown before it ends)."""
    d_min = spec.diameter_min_d
    dt = spec.dt_safety * math.sqrt(math.pi / 6 * d_min**3 * spec.overlap_ratio)  # k_n = p d / delta = 1/ratio
    strain = spec.pre_strain + spec.n_cycles * spec.period_strain
    samples = len(sample_strains(spec))
    bins = max(1, round(spec.gap_d / spec.profile_bin_d))
    numbers = SAMPLE_NUMBERS_FIXED + SAMPLE_NUMBERS_PER_BIN * bins
    return {"steps": strain / (spec.inertial_number * dt), "samples": samples,
            "megabytes": samples * numbers * 8 / 1e6, "grains": grain_count(spec)}
