"""Which runs a data stage (fit, compare, figures) reads: a *data set*, the runs of one preset in one engine that
share one set of overrides (their seeds may differ), and its folder of outputs.

The data set of ``--preset P`` alone: the preset as it is in Yade where it has a reversal run, else the one
``config/datasets.toml`` declares for it, which is also the one to make where neither has a run yet (the
paper cell's is LAMMPS's at I = 1e-3). ``--engine`` and ``--set`` choose another. Its outputs go to
``results/<folder>/`` with ``<folder>`` the folder of its runs (``<preset>[-<engine>][-<hash of the overrides>]``),
so a fit is never mixed with another data set's.

Standard library only: ``pipeline.targets`` asks it, in Debian's python3, before any virtualenv exists.
"""

from __future__ import annotations

import argparse
import dataclasses
import tomllib
from pathlib import Path

from .. import spec as run_spec
from ..errors import PipelineError
from ..paths import CONFIG_DIR, DATA_ROOTS, check_folder_name, first_existing

DATASETS_FILE = CONFIG_DIR / "datasets.toml"

#: presets from the most faithful to the paper's cell down
PRESETS_BY_FIDELITY = ("paper", "reduced", "quick")

#: overrides that tell seeds of one data set apart rather than data sets
SEED_KEYS = frozenset({"seed"})


@dataclasses.dataclass(frozen=True)
class DataSet:
    """The runs of ``preset`` in ``engine`` with ``overrides`` (besides their seeds)."""

    preset: str
    engine: str = run_spec.DEFAULT_ENGINE
    overrides: tuple[tuple[str, float], ...] = ()
    #: cycles of each run left out, the first ones (``SKIP_CYCLES``: a packing still compacting in them); its outputs
    #: stay in the data set's folder (a fit records it among its options)
    skip_cycles: int = 0

    @property
    def folder(self) -> str:
        """The folder of its runs at their first seed, and of its outputs: ``<preset>[-<engine>][-<hash>]``."""
        return run_spec.run_folder(self.preset, self.engine, dict(self.overrides))

    @property
    def label(self) -> str:
        """``paper (lammps, inertial_number=0.001)``: what a report names."""
        skipped = [f"cycles from {self.skip_cycles + 1} on"] if self.skip_cycles else []
        return f"{self.preset} ({', '.join([self.engine, *self.settings, *skipped])})"

    @property
    def settings(self) -> list[str]:
        """Its overrides as ``key=value`` words, each value the shortest text that reads back as the same number."""
        return [f"{k}={int(v) if v.is_integer() and abs(v) < 1e15 else repr(v)}" for k, v in self.overrides]

    def matches(self, engine: str, overrides: dict) -> bool:
        """Whether a run of ``engine`` with ``overrides`` belongs to this data set (any seed)."""
        rest = {k: float(v) for k, v in overrides.items() if k not in SEED_KEYS}
        return engine == self.engine and rest == dict(self.overrides)


def data_set(preset: str, engine: str | None = None, overrides: dict | None = None,
             roots: tuple[Path, ...] = DATA_ROOTS, datasets_file: Path | None = None) -> DataSet:
    """The data set of ``preset`` (validated like a run: unknown keys and bad values are one-line errors). Without
    ``engine`` and ``overrides``: the preset as it is in Yade if it has a reversal run, else its declared data set
    (where ``engine`` is not given or names the declared one's engine), which is also the one to make where neither
    has a run; seeds are dropped."""
    check_folder_name(preset)
    given = {k: float(v) for k, v in (overrides or {}).items() if k not in SEED_KEYS}
    # validates, and drops a preset's own values: they are no overrides
    chosen = run_spec.resolve(180, preset, overrides=given, engine=engine or run_spec.DEFAULT_ENGINE).overrides
    if overrides:
        return DataSet(preset, engine or run_spec.DEFAULT_ENGINE, tuple(sorted(chosen.items())))
    candidates = [DataSet(preset, engine or run_spec.DEFAULT_ENGINE)]
    declared = declared_data_set(preset, datasets_file)
    if declared is not None and engine in (None, declared.engine):
        candidates.append(declared)
    return next((c for c in candidates if has_reversal(c, roots)), candidates[-1])


def declared_data_set(preset: str, datasets_file: Path | None = None) -> DataSet | None:
    """The data set ``config/datasets.toml`` (or ``datasets_file``) declares for ``preset``, if any."""
    datasets_file = datasets_file or DATASETS_FILE
    try:
        with open(datasets_file, "rb") as fh:
            table = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise PipelineError(f"cannot read {datasets_file}: {exc}") from None
    entry = table.get(preset)
    if entry is None:
        return None
    unknown = sorted(set(entry) - {"engine", "set"})
    if unknown:
        raise PipelineError(f"{datasets_file.name}: [{preset}] has unknown key(s) {', '.join(unknown)}")
    engine = entry.get("engine", run_spec.DEFAULT_ENGINE)
    overrides = {k: float(run_spec.parse_number(k, v)) for k, v in entry.get("set", {}).items()}
    run_spec.resolve(180, preset, overrides=overrides, engine=engine)  # validates the declaration
    return DataSet(preset, engine, tuple(sorted(overrides.items())))


def has_reversal(chosen: DataSet, roots: tuple[Path, ...] = DATA_ROOTS) -> bool:
    """Whether the data set's first seed has a reversal run (``<folder>/dem/theta180.h5``) here or committed."""
    return first_existing(Path(chosen.folder) / "dem" / "theta180.h5", roots) is not None


def most_faithful_preset(roots: tuple[Path, ...] = DATA_ROOTS) -> str:
    """The most faithful preset whose default data set has a reversal run, in results/ or the committed data;
    ``quick`` (the demo's) when there is none."""
    for preset in PRESETS_BY_FIDELITY:
        if has_reversal(data_set(preset, roots=roots), roots):
            return preset
    return "quick"


def add_arguments(parser: argparse.ArgumentParser, preset_help: str = "preset whose runs to read") -> None:
    """``--preset``, ``--engine`` and ``--set`` (repeatable): the data set of a stage's command line."""
    parser.add_argument("--preset", help=f"{preset_help} (default: the most faithful one with a reversal run)")
    parser.add_argument("--engine", choices=run_spec.ENGINES,
                        help="the DEM engine whose runs to read (default: see config/datasets.toml)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="the overrides the runs share, as given to `make dem` (repeatable; seeds ignored)")
    parser.add_argument("--skip-cycles", type=skip_cycles, default=0, metavar="K",
                        help="leave out each run's first K cycles (a packing still compacting in them); default 0")


def skip_cycles(text: str) -> int:
    """``--skip-cycles``'s value: a whole number of cycles, 0 or more."""
    if not text.strip().isdigit():
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number of cycles (0, 1, ...)")
    return int(text)


def from_arguments(args: argparse.Namespace) -> DataSet:
    """The data set the parsed ``add_arguments`` options name; the preset said when it was chosen here."""
    preset = args.preset
    if preset is None:
        preset = most_faithful_preset()
        print(f"preset: {preset} (the most faithful one with a reversal run; --preset / PRESET= to choose)")
    chosen = data_set(preset, args.engine, run_spec.parse_overrides(args.set))
    return dataclasses.replace(chosen, skip_cycles=args.skip_cycles)
