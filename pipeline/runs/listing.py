"""``make runs``: every DEM run in results/ and the committed data, with its overrides, state and summary.

A run's folder is ``<preset>`` or ``<preset>-<hash of its overrides>``; this listing names what each one holds.
``python -m pipeline.runs.listing [--json]``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ..cli import Parser, one_line_errors
from ..dataset import drift
from ..dataset.dem_file import load, run_provenance
from ..errors import DemFileError, PipelineError
from ..paths import DATA_ROOTS, ROOT
from .state import read_json, run_state

SUMMARIES = ROOT / "data" / "fidelity"  # the fidelity ladder's committed run summaries


def overrides_of(h5: Path, run_dir: Path) -> dict | None:
    """The run's overrides, from its file's provenance or its folder's ``spec.json`` (None: unreadable)."""
    if h5.exists():
        try:
            return dict(run_provenance(h5)[2].overrides)
        except DemFileError:
            return None
    stored = read_json(run_dir / "spec.json")
    return None if stored is None else stored.get("overrides")


def runs(roots: tuple[Path, ...] = DATA_ROOTS, summaries: Path = SUMMARIES) -> list[dict]:
    """One row per run (results/ before the committed data where both hold one): where it is, its overrides,
    state and detail, and its fidelity summary if one is committed; then the committed summaries whose run
    is not here (state ``summary only``)."""
    rows, seen = [], set()
    for root in roots:
        found = {(p.parent, p.name.removesuffix(p.suffix)) for pattern in ("*/dem/*.h5", "*/dem/*.run")
                 for p in root.glob(pattern)}
        for dem_dir, name in sorted(found):
            folder = dem_dir.parent.name
            if (folder, name) in seen:
                continue
            seen.add((folder, name))
            h5, run_dir = dem_dir / f"{name}.h5", dem_dir / f"{name}.run"
            state, detail = run_state(run_dir, h5)
            if state == "done":
                detail = cycles_detail(h5)
            summary = summaries / folder / f"{name}.json"
            rows.append({"folder": folder, "name": name, "where": _shown(root), "overrides": overrides_of(h5, run_dir),
                         "state": state, "detail": detail, "summary": _shown(summary) if summary.exists() else ""})
    for summary in sorted(summaries.glob("*/*.json")):
        folder, name = summary.parent.name, summary.stem
        if (folder, name) not in seen:
            values = read_json(summary) or {}
            rows.append({"folder": folder, "name": name, "where": "", "overrides": values.get("overrides"),
                         "state": "summary only", "detail": "", "summary": _shown(summary)})
    return rows


def cycles_detail(h5: Path) -> str:
    """``drift: ...``: the quantities that drift over a finished run's cycles (``pipeline.dataset.drift``)."""
    try:
        return f"drift: {drift.describe(drift.drift(load(h5)))}"
    except PipelineError as exc:
        return f"unreadable: {exc}"


def _shown(path: Path) -> str:
    """A path relative to the repository where it lies inside it."""
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def text(rows: list[dict]) -> str:
    def show(o):
        return "?" if o is None else (" ".join(f"{k}={v:g}" for k, v in sorted(o.items())) or "(the preset)")

    widths = [max([len(h)] + [len(c) for c in col]) for h, col in (
        ("run", [f"{r['folder']}/{r['name']}" for r in rows]), ("overrides", [show(r["overrides"]) for r in rows]),
        ("state", [r["state"] for r in rows]))]
    lines = [f"{'run':<{widths[0]}}  {'overrides':<{widths[1]}}  {'state':<{widths[2]}}  where / summary / detail"]
    for r in rows:
        extra = "; ".join(x for x in (r["where"], r["summary"], r["detail"]) if x)
        lines.append(f"{r['folder'] + '/' + r['name']:<{widths[0]}}  {show(r['overrides']):<{widths[1]}}  "
                     f"{r['state']:<{widths[2]}}  {extra}")
    return "\n".join(lines)


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.runs.listing", description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = parser.parse_args(argv)
    rows = runs()
    print(json.dumps(rows, indent=1) if args.json else text(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
