"""The ladder's runs summarised: each run's summary (computed once, committed under ``data/fidelity/``), and the
top rung's, gathered for ``table.build``; the table as CSV."""

from __future__ import annotations

import csv
import io as text_io
import json
import time
from pathlib import Path

from ... import io
from ...dataset.dem_file import load
from . import ladder, table
from .summary import VERSION, summarize


def _current(path: Path) -> dict | None:
    """The summary at ``path`` if there is one of this version (an older one is redone where its run is)."""
    if not path.exists():
        return None
    found = json.loads(path.read_text())
    return found if found.get("schema_version") == VERSION else None


def summaries(rungs: list, summary_dir: Path = ladder.SUMMARY_DIR, roots: tuple = ladder.DATA_ROOTS) -> list[tuple]:
    """(axis, setting, summary) for every rung that has a summary or a DEM file; new summaries are written,
    and a summary of an older version is written anew where the run's DEM file is at hand (else kept)."""
    entries, tic = [], time.time()
    cache = {r.relative: found for r in rungs if (found := _current(ladder.summary_path(r, summary_dir)))}
    todo = {r.relative for r in rungs if r.relative not in cache and ladder.dem_file(r, roots)}
    done = 0
    for r in rungs:
        path = ladder.summary_path(r, summary_dir)
        if r.relative not in cache:
            if r.relative not in todo and path.exists():
                cache[r.relative] = json.loads(path.read_text())  # an older version, its run not at hand
            elif (dem := ladder.dem_file(r, roots)) is not None:
                cache[r.relative] = summarize(load(dem))
                io.write_json(path, cache[r.relative], committed=True)
                done += 1
                rate = done / (time.time() - tic)
                print(f"summarised {r.relative} ({done}/{len(todo)}, {rate:.2f} runs/s)", flush=True)
            else:
                continue
        entries.append((r.axis, r.label, cache[r.relative]))
    return entries


def top_summaries(paths: list[Path], summary_dir: Path = ladder.SUMMARY_DIR) -> list[dict]:
    """The summaries of the top rung's runs (``data/fidelity/<folder>/<name>.json``), made where missing or
    of an older version."""
    out = []
    for path in paths:
        target = summary_dir / path.parts[-3] / f"{path.stem}.json"
        found = _current(target)
        if found is None:
            found = summarize(load(path))
            io.write_json(target, found, committed=True)
            print(f"summarised {path.parts[-3]}/{path.stem} (the top rung)", flush=True)
        out.append(found)
    return out


def csv_text(rows: list[dict]) -> str:
    out = text_io.StringIO()
    keys = ["axis", "setting", "theta_deg", "cpu_hours", "steps_per_second", "grains", "mu", "mu_se", "mu_shift",
            "mu_shift_se", "error", "A_norm", "phi_central", "phi_gap", "bulk_over_nominal", *table.FITTED]
    writer = csv.writer(out)
    writer.writerow(keys)
    for r in rows:
        s, c, fit = r["steady"], r["cost"], r["fit"] or {}
        writer.writerow([r["axis"], r["setting"], r["theta_deg"], c["cpu_hours"], c["steps_per_second"], c["grains"],
                         s["mu"]["mean"], s["mu"]["standard_error"], s["mu"]["shift"], s["mu"]["shift_se"],
                         r["error"], s["A_norm"]["mean"], s["phi_central"]["mean"], s["phi_gap"]["mean"],
                         r["bulk_over_nominal"], *(fit.get(n, "") for n in table.FITTED)])
    return out.getvalue()
