"""The cheapest setting for a target error: which ladder setting, how many runs, what it costs.

A *setting* is the runs at one angle that share their overrides apart from the seed (the seed axis is
the preset itself). For a quantity q (the steady τ12/p, ``mu``, or a fitted parameter) the error of
the mean of k runs of a setting, measured against the reference (the preset's seeds' ensemble), is
expected to be

    E_k = sqrt(b² + σ_b² + s² / k),

b the setting's measured bias (its runs' mean minus the reference's; zero for the preset), σ_b the
standard error of that bias (what we do not know about it counts against the setting), and s the
scatter of one run (the setting's own seeds' SD with three or more runs, else the preset's). A target
relative error ε is met by the smallest k with E_k ≤ ε |q_ref|; when b² + σ_b² alone exceeds it, or k
would pass ``MAX_RUNS``, no number of runs of that setting meets it. The reference is not the
paper's setting: how far it sits from it is what the ladder's extrapolations measure, reported beside.
"""

from __future__ import annotations

import math

import numpy as np

QUANTITIES = ("mu", "C", "n", "m", "b1", "b2")
LEVELS = (0.10, 0.05)
MAX_RUNS = 100  # beyond this a quantity counts as not determined by the setting


def settings(entries: list[tuple], theta: float) -> dict[str, list[dict]]:
    """The runs at ``theta`` grouped by setting (overrides without the seed; ``preset`` for none)."""
    groups: dict[str, dict] = {}
    for _, _, s in entries:
        if s["theta_deg"] != theta:
            continue
        key = " ".join(f"{k}={v:g}" for k, v in sorted(s["overrides"].items()) if k != "seed") or "preset"
        groups.setdefault(key, {})[(s["folder"], s["name"])] = s
    return {k: list(v.values()) for k, v in groups.items()}


def values_of(runs: list[dict], name: str) -> np.ndarray:
    """The steady τ12/p (``mu``) or a fitted parameter of each run that has it."""
    if name == "mu":
        return np.array([s["steady"]["mu"]["mean"] for s in runs])
    return np.array([s["fit"]["values"][name] for s in runs if (s.get("fit") or {}).get("values", {}).get(name)
                     is not None])


def runs_for(error_floor_sq: float, sd: float, budget: float) -> int | None:
    """The fewest runs with error_floor² + sd²/k ≤ budget², or None when none (or more than MAX_RUNS)."""
    room = budget**2 - error_floor_sq
    if room <= 0:
        return None
    k = max(1, math.ceil(sd**2 / room - 1e-12))
    return k if k <= MAX_RUNS else None


def recommend(entries: list[tuple], theta: float, ref: dict, jobs_here: int = 2, node_cores: int = 32) -> dict:
    """For each quantity and target level: every setting's runs and cost to meet it, and the cheapest.

    ``ref`` is ``table.reference`` of the preset's seeds. Costs: CPU-hours (runs × the setting's mean
    CPU-hours per run, as measured here, two runs side by side), and wall hours here (``jobs_here``
    runs at a time) and on a cluster node of ``node_cores`` cores (one run per core, at this machine's
    per-run rate)."""
    groups = settings(entries, theta)
    out = {"levels": list(LEVELS), "node_cores": node_cores, "jobs_here": jobs_here, "quantities": {}}
    for name in QUANTITIES:
        ref_q = ref["steady"]["mu"] if name == "mu" else ref["fit"].get(name)
        ref_sd = ref["steady"]["mu"].get("sd_per_run") if name == "mu" else ref["fit_sd"].get(name)
        if not ref_q or ref_sd is None or not np.isfinite(ref_sd):
            continue
        truth, truth_se = ref_q["mean"], ref_q["standard_error"]
        candidates = []
        for key, runs in groups.items():
            vals = values_of(runs, name)
            if len(vals) == 0:
                continue
            sd = float(np.std(vals, ddof=1)) if len(vals) >= 3 and key != "preset" else ref_sd
            if name == "mu":  # one run is never surer than its own windows say
                sd = max(sd, *(s["steady"]["mu"]["standard_error"] for s in runs))
            bias, bias_se = ((0.0, 0.0) if key == "preset"
                             else (float(vals.mean() - truth), float(np.hypot(sd / np.sqrt(len(vals)), truth_se))))
            cpu = float(np.mean([s["cost"]["cpu_hours"] for s in runs]))
            per_level = {}
            for level in LEVELS:
                budget = level * abs(truth)
                floor = bias**2 + bias_se**2
                k = runs_for(floor, sd, budget)
                why = ("its bias (or what is unknown of it) alone exceeds the target" if floor >= budget**2
                       else f"more than {MAX_RUNS} runs")
                per_level[f"{level:g}"] = {"runs": None, "why": why} if k is None else {
                    "runs": k, "cpu_hours": k * cpu, "wall_hours_here": math.ceil(k / jobs_here) * cpu,
                    "wall_hours_node": math.ceil(k / node_cores) * cpu,
                    "expected_error": float(np.sqrt(floor + sd**2 / k) / abs(truth))}
            candidates.append({"setting": key, "runs_measured": len(vals), "bias": bias, "bias_se": bias_se,
                               "sd_per_run": sd, "cpu_hours_per_run": cpu, "levels": per_level})
        cheapest = {}
        for level in LEVELS:
            met = [c for c in candidates if c["levels"][f"{level:g}"]["runs"]]
            best = min(met, key=lambda c: c["levels"][f"{level:g}"]["cpu_hours"], default=None)
            cheapest[f"{level:g}"] = best and {"setting": best["setting"], **best["levels"][f"{level:g}"]}
        out["quantities"][name] = {"reference": truth, "reference_se": truth_se, "sd_per_run": ref_sd,
                                   "cheapest": cheapest, "candidates": candidates}
    return out
