"""The data card's inventory of committed runs (``make data-card``): one row per run file, read from the file's
own provenance, so the card cannot drift from the files.

``python -m pipeline.dataset.card [--check] [--root data/reference] [--card data/reference/README.md]`` rewrites the
table between the card's two markers and the SHA-256 of every run file into ``MANIFEST.sha256`` beside it
(``pipeline/dataset/manifest.py``: what the stages check a committed file against), or with ``--check`` exits 1 when
either is out of date.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from dem.core.spec import DemSpec

from ..cli import Parser, one_line_errors
from ..errors import DemFileError, PipelineError
from ..io import atomic_path, sha256, write_bytes
from ..paths import ROOT, globbed
from . import drift, manifest
from .dem_file import cpu_seconds, cpu_seconds_counted, load, run_provenance, sessions

BEGIN = "<!-- inventory: written by make data-card from the files themselves; do not edit by hand -->"
END = "<!-- inventory end -->"
HEADER = ("| file | engine | θ | rotation | seed | other overrides | cycles | grains | M steps | loop h | CPU h "
          "| sessions (ranks) | commits | finished | MB | SHA-256 |")
#: the checksum's hex digits the card keeps: enough to tell a changed file, short enough to read
SHA_DIGITS = 16


def describe(path: Path, root: Path) -> dict:
    """One run file's inventory row, from its ``/provenance`` and ``/parameters`` attributes."""
    prov, params, spec = run_provenance(path)
    engine = spec.engine
    version = prov.get("engine_version", prov.get("yade_version", ""))  # files before engines were named: Yade
    runs = sessions(prov)
    commits = [str(prov.get("git_commit", "unknown"))] + [str(s["git_commit"]) for s in runs if "git_commit" in s]
    overrides = {k: v for k, v in spec.overrides.items() if k != "seed"}
    cores = {s.get("ranks", 1) * s.get("threads", 1) for s in runs}  # one count: loop x cores is exact
    return {"file": str(path.relative_to(root)), "engine": f"{engine} {version}".strip(),
            "theta_deg": float(spec.theta_deg), "rotate_at": float(spec.rotate_at_strain),
            "seed": spec.seed,
            "overrides": " ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in
                                  sorted(overrides.items())),
            "cycles": int(spec.n_cycles), "grains": int(params.get("n_grains", 0)),
            "steps": int(params.get("iterations", 0)), "loop_hours": float(params["loop_seconds"]) / 3600,
            "cpu_hours": cpu_seconds(params, runs) / 3600,
            "cpu_exact": cpu_seconds_counted(params) or len(cores) < 2,
            "sessions": len(runs), "ranks": sorted({int(s.get("ranks", 1)) for s in runs}) or [1],
            "commits": list(dict.fromkeys(c[:7] + ("-dirty" if c.endswith("-dirty") else "") for c in commits)),
            "finished": str(prov.get("finished", ""))[:10], "megabytes": path.stat().st_size / 1e6,
            "sha256": sha256(path)[:SHA_DIGITS]}


def inventory(root: Path) -> str:
    """The markdown table of every ``<folder>/dem/*.h5`` under ``root``, sorted by path."""
    paths = globbed(root, "*/dem/*.h5")
    if not paths:
        raise PipelineError(f"{root}: no run files (<folder>/dem/*.h5)")
    lines = [HEADER, "|" + "---|" * HEADER.count(" | ") + "---|"]
    for row in (describe(p, root) for p in paths):
        cpu = ("" if row["cpu_exact"] else "≤ ") + f"{row['cpu_hours']:.2f}"
        lines.append(f"| `{row['file']}` | {row['engine']} | {row['theta_deg']:g} | {row['rotate_at']:g} | "
                     f"{row['seed']} | {row['overrides']} | {row['cycles']} | {row['grains']} | "
                     f"{row['steps'] / 1e6:.2f} | {row['loop_hours']:.2f} | {cpu} | {row['sessions']} "
                     f"({', '.join(map(str, row['ranks']))}) | {', '.join(row['commits'])} | {row['finished']} | "
                     f"{row['megabytes']:.1f} | `{row['sha256']}` |")
    return "\n".join(lines + ["", *drift_table(paths, root)])


def drift_table(paths: list[Path], root: Path) -> list[str]:
    """Every run's cycles one by one (``pipeline.dataset.drift``): the gap per cycle and the quantities that
    drift."""
    lines = [f"Drift over the cycles (`pipeline/dataset/drift.py`: 0.3 strain before each change, p < {drift.LEVEL}):",
             "", "| file | gap per cycle (d) | drifting: slope per cycle ± error (p) |", "|---|---|---|"]
    for path in paths:
        trends = drift.drift(load(path))
        gaps = " ".join(f"{g:.2f}" for g in trends["gap"].per_cycle)
        lines.append(f"| `{path.relative_to(root)}` | {gaps} | {drift.describe(trends).replace('|', chr(92) + '|')} |")
    return lines


def in_progress(root: Path) -> list[str]:
    """A line per run in progress committed under ``root`` (``<folder>/dem/<name>.run/``: spec, checkpoint, the
    samples so far), with how far it got (its ``status.json``): ``make dem`` with its values takes it up."""
    lines = []
    for run_dir in sorted(root.glob("*/dem/*.run")):
        try:
            spec = DemSpec.from_dict(json.loads((run_dir / "spec.json").read_text()))
            status = json.loads((run_dir / "status.json").read_text())
        except (OSError, ValueError, TypeError) as exc:
            raise DemFileError(f"{run_dir}: not a run in progress ({exc})") from None
        given = " ".join(f"{k}={v:g}" for k, v in sorted(spec.overrides.items()))
        lines.append(f"- `{run_dir.relative_to(root)}/`: {spec.engine}, preset {spec.preset}, θ = {spec.theta_deg:g}"
                     + (f", {given}" if given else "") + f"; {status.get('percent', 0):g} % done (strain "
                     f"{status.get('strain', float('nan')):+.3f}): `make dem THETA={spec.theta_deg:g} "
                     f"PRESET={spec.preset} ENGINE={spec.engine}" + (f' SET="{given}"' if given else "")
                     + "` goes on from its checkpoint")
    return ["", "Runs in progress, committed to go on elsewhere:", "", *lines] if lines else []


def with_inventory(card: str, table: str, card_path: Path) -> str:
    """``card`` with the text between its markers replaced by ``table``."""
    if card.count(BEGIN) != 1 or card.count(END) != 1 or card.index(BEGIN) > card.index(END):
        raise PipelineError(f"{card_path}: needs the two markers, once each and in order: {BEGIN!r} ... {END!r}")
    head, rest = card.split(BEGIN)
    return f"{head}{BEGIN}\n{table}\n{END}{rest.split(END, 1)[1]}"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.dataset.card", description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=ROOT / "data" / "reference")
    parser.add_argument("--card", type=Path, default=None, help="the data card (default: ROOT/README.md)")
    parser.add_argument("--check", action="store_true", help="exit 1 if the card's table is out of date")
    args = parser.parse_args(argv)
    card_path = args.card or args.root / "README.md"
    try:
        card = card_path.read_text()
    except OSError as exc:
        raise PipelineError(f"cannot read {card_path}: {exc.strerror}") from None
    updated = with_inventory(card, "\n".join([inventory(args.root), *in_progress(args.root)]), card_path)
    if args.check:
        stale = manifest.stale(args.root)
        if updated != card or stale:
            print(f"{card_path}: the inventory or {manifest.MANIFEST} is out of date: make data-card "
                  f"({'; '.join(stale[:3]) or 'the table'})", file=sys.stderr)
            return 1
        print(f"{card_path}: the inventory and {manifest.MANIFEST} match the files")
        return 0
    with atomic_path(card_path, committed=True) as tmp:
        write_bytes(tmp, updated.encode())
    listed = manifest.write(args.root)
    print(f"wrote the inventory of {listed} runs into {card_path}, their SHA-256 into {args.root / manifest.MANIFEST}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
