"""The fidelity table as Markdown (``results/fidelity/table.md``), from the dict that ``table.build`` computes."""

from __future__ import annotations

import numpy as np

import model

from ...calibration.identifiability import combination
from .recommend import MAX_RUNS
from .table import FITTED, combo_name


def markdown(table: dict) -> str:
    lines = ["# The fidelity ladder", "",
             f"Each row: one setting (an axis of `{table.get('ladder', 'config/fidelity.toml')}` moved from the "
             f"`{table.get('preset', 'reduced')}` preset). μ is the "
             "steady τ:D'/(p|D'|) (τ12/p along the shear), over the last 0.3 strain before each change of direction; "
             "*shift* is the row minus the reference (the seeds' ensemble at that angle), ± both errors combined, a "
             "run's error being the larger of its windows' standard error and the seeds' scatter per run. "
             "The fit is the global fit on that run alone (± from its own noise). CPU-hours of the DEM loop, "
             "one thread.", ""]
    for theta, ref in table["references"].items():
        mu = ref["steady"]["mu"]
        lines += [f"## θ = {theta}°: reference {ref['runs']} run(s), μ = {mu['mean']:.4f} ± {mu['standard_error']:.4f}",
                  "", "| axis | setting | CPU-h | steps/s | grains | μ | shift of μ | |A| | Φ central | Φ gap | "
                  "band/nominal | C | n | m | b1 | b2 | RMSE τ12 own / Table 2 |", "|" + "---|" * 17]
        shown = set()
        for r in table["rows"]:
            if f"{r['theta_deg']:g}" != theta or (r["folder"], r["name"]) in shown:
                continue  # the preset's own run sits on every axis: shown once, on the first
            shown.add((r["folder"], r["name"]))
            s, c = r["steady"], r["cost"]
            fit = r["fit"] or {}
            params = " | ".join(f"{fit[n]:+.3g}" if n in fit else "" for n in ("C", "n", "m", "b1", "b2"))
            rmse = r["rmse_tau12"]
            lines.append(
                f"| {r['axis']} | {r['setting']} | {c['cpu_hours']:.2f} | {c['steps_per_second'] or 0:.0f} | "
                f"{c['grains']} | "
                f"{s['mu']['mean']:.4f} ± {s['mu']['standard_error']:.4f} | {s['mu']['shift']:+.4f} ± "
                f"{s['mu']['shift_se']:.4f} | {s['A_norm']['mean']:.4f} | {s['phi_central']['mean']:.3f} | "
                f"{s['phi_gap']['mean']:.3f} | {r['bulk_over_nominal']:.2f} | {params} | "
                + (f"{rmse.get('own fit', np.nan):.3f} / {rmse.get('Table 2', np.nan):.3f}" if rmse else "") + " |")
        if rec := table.get("recommendation", {}).get(theta):
            lines += recommendation_lines(rec, table.get("extrapolations", {}).get(theta, {}))
        for axis, line in table.get("extrapolations", {}).get(theta, {}).items():
            lines += [f"Extrapolation along `{axis}` to the paper's {line['keys'][0]} = {line['target']:g} "
                      f"(a weighted line in {'1/' if line['transform'] == 'inverse' else ''}{line['keys'][0]}; "
                      "runs at one value pooled):", "",
                      "| quantity | points (value: mean ± se, runs) | slope | at the paper's value | χ²/dof | "
                      "Table 2 |", "|---|---|---|---|---|---|"]
            for name, q in line["quantities"].items():
                if name not in ("mu", *FITTED):
                    continue  # the combinations have a table of their own
                pts = "; ".join(f"{p['x']:g}: {p['mean']:.3g} ± {p['standard_error']:.2g} ({p['runs']})"
                                for p in q["points"])
                chi = f"{q['chi2_per_dof']:.2f}" if q["chi2_per_dof"] is not None else "— (two values: untested)"
                paper = f"{getattr(model.PAPER, name):.3g}" if hasattr(model.PAPER, name) else ""
                lines.append(f"| {name} | {pts} | {q['slope']:+.3g} | {q['at_target']:.3g} ± {q['at_target_se']:.2g} "
                             f"| {chi} | {paper} |")
            lines.append("")
        if found := table.get("combinations", {}).get(theta):
            lines += combination_lines(found, table.get("extrapolations", {}).get(theta, {}))
        if paper := table.get("paper_definitions", {}).get(theta):
            lines += paper_definition_lines(paper)
        ens = table.get("ensembles", {}).get(theta)
        if ens:
            lines += [f"Small cells against the reference cell at equal CPU time: {ens['small_runs']} seeds of "
                      f"the small cell ({ens['cpu_hours_small']:.2f} CPU-h each) against {ens['reference_runs']} of "
                      f"the reference ({ens['cpu_hours_reference']:.2f} CPU-h each); one reference run's time buys "
                      f"{ens['small_runs_per_reference_run']:.1f} small runs. Expected error = sqrt(bias² + sd²/k).",
                      "", "| quantity | small-cell bias | sd per run, small / reference | error: small ensemble / "
                      "one reference run | better |", "|---|---|---|---|---|"]
            for name, q in ens["quantities"].items():
                lines.append(f"| {name} | {q['bias']:+.3g} ± {q['bias_se']:.2g} | {q['sd_small']:.3g} / "
                             f"{q['sd_reference']:.3g} | {q['error_small_ensemble']:.3g} / "
                             f"{q['error_reference_run']:.3g} | {q['better']} |")
            lines.append("")
        if top := table.get("top", {}).get(theta):
            lines += top_lines(top)
    return "\n".join(lines) + "\n"


def top_lines(top: dict) -> list[str]:
    """The top rung (the paper's cell) against each extrapolation it checks, quantity by quantity."""
    lines = []
    for axis, rows in top["checks"].items():
        lines += [f"The top rung, the paper's cell ({top['data_set']}, {top['runs']} run(s)), against the "
                  f"extrapolation along `{axis}`: did the smaller cells predict it? z = difference / combined "
                  "standard error" + (" (one run: its own noise, a seed's scatter left out)" if top["runs"] == 1
                                      else "") + ".", "",
                  "| quantity | paper cell | extrapolated | z | within 95 % |", "|---|---|---|---|---|"]
        for name, q in rows.items():
            lines.append(f"| {name} | {q['paper_cell']:.4g} ± {q['paper_cell_se']:.2g} | {q['extrapolated']:.4g} ± "
                         f"{q['extrapolated_se']:.2g} | {q['z']:+.2f} | {'yes' if q['within_95'] else 'no'} |")
        lines.append("")
    return lines


def _cost(c: dict, cores: int) -> str:
    if not c["runs"]:
        return f"not met: {c['why']}"
    return (f"{c['runs']} run(s), {c['cpu_hours']:.1f} CPU-h (wall {c['wall_hours_here']:.1f} h here, "
            f"{c['wall_hours_node']:.1f} h on {cores} cores)")


def recommendation_lines(rec: dict, extrapolations: dict) -> list[str]:
    """The recommendation as Markdown: per quantity and target, the cheapest setting and the preset's own
    cost, and how far the reference sits from the paper's setting along each extrapolated axis."""
    if not rec["quantities"]:
        return []
    levels, cores = [f"{x:g}" for x in rec["levels"]], rec["node_cores"]
    lines = ["", f"**The cheapest setting for a target error** against the reference (expected error "
             f"sqrt(bias² + its variance + SD²/k) of the mean of k runs, at most {MAX_RUNS}; wall time here "
             f"with {rec['jobs_here']} runs side by side and on a node of {cores} cores, one run per core at "
             "this machine's rate). The last column is the reference's distance from the paper's setting where "
             "the ladder extrapolates: it is not in the errors, and no setting here removes it.", "",
             "| quantity | reference (SD per run) | " + " | ".join(
                 f"±{float(x):.0%}: cheapest | ±{float(x):.0%}: the preset" for x in levels)
             + " | paper's setting − reference |", "|" + "---|" * (3 + 2 * len(levels))]
    for name, q in rec["quantities"].items():
        preset = next((c for c in q["candidates"] if c["setting"] == "preset"), None)
        cells = []
        for x in levels:
            best = q["cheapest"][x]
            cells += [f"`{best['setting']}`: {_cost(best, cores)}" if best else "none",
                      _cost(preset["levels"][x], cores) if preset else ""]
        away = "; ".join(
            f"{axis}: {e['quantities'][name]['at_target'] - q['reference']:+.3g} ± "
            f"{np.hypot(e['quantities'][name]['at_target_se'], q['reference_se']):.2g}"
            + (" (untested)" if e["quantities"][name]["chi2_per_dof"] is None else "")
            for axis, e in extrapolations.items() if name in e["quantities"])
        lines.append(f"| {name} | {q['reference']:.3g} ± {q['reference_se']:.2g} ({q['sd_per_run']:.2g}) | "
                     + " | ".join(cells) + f" | {away} |")
    return [*lines, ""]


def combination_lines(found: dict, extrapolations: dict) -> list[str]:
    """What one reversal fixes, as Markdown: each combination's scatter per run, the reference's value and
    where each extrapolation carries it, as ratios to Table 2's value of the same product."""
    def ratio(log_value: float, log_se: float, paper: float) -> str:
        return f"×{np.exp(log_value - paper):.2f} ± {log_se:.0%}"

    lines = [f"**What one reversal fixes**: products ∏|θ|^v of the fitted parameters of one sign, the "
             f"eigen-directions of the {found['seeds']} seeds' scatter in ln|θ|, best fixed first (scatter per run "
             "measured out of sample, leaving each seed out; in-sample beside it). Each value is our product "
             "over Table 2's value of it (± the relative standard error).", "",
             "| combination | scatter per run (in sample) | reference / Table 2 |" + "".join(
                 f" along {axis}, at {e['keys'][0]} = {e['target']:g} |" for axis, e in extrapolations.items()),
             "|" + "---|" * (3 + len(extrapolations))]
    for k, c in enumerate(found["combinations"]):
        cells = []
        for e in extrapolations.values():
            q = e["quantities"].get(combo_name(k))
            cells.append("" if not q else ratio(q["at_target"], q["at_target_se"], c["table2"])
                         + (" (untested)" if q["chi2_per_dof"] is None else ""))
        lines.append(f"| {combination(c['direction'])} | {c['sd_per_run']:.1%} ({c['in_sample_sd']:.1%}) | "
                     f"{ratio(c['mean'], c['standard_error'], c['table2'])} |" + "".join(f" {x} |" for x in cells))
    return [*lines, ""]


def paper_definition_lines(paper: dict) -> list[str]:
    """The reference seeds' fits in the definitions the paper's numbers match, against Table 2: each
    parameter, then the combinations."""
    fit = paper["reference"]["fit"]
    lines = [f"**In the paper's definitions** (nominal strain, Φ of the gap; the same {paper['seeds']} seeds "
             "refitted): each parameter's ensemble mean against Table 2, in the seeds' standard errors, then "
             "the products the seeds' fits fix in these terms.", "",
             "| | " + " | ".join(fit) + " |", "|" + "---|" * (len(fit) + 1),
             "| seeds' mean ± se | " + " | ".join(f"{q['mean']:.3g} ± {q['standard_error']:.2g}"
                                                    for q in fit.values()) + " |",
             "| Table 2 | " + " | ".join(f"{getattr(model.PAPER, n):.3g}" for n in fit) + " |",
             "| (mean − Table 2) / se | " + " | ".join(
                 f"{(q['mean'] - getattr(model.PAPER, n)) / q['standard_error']:+.1f}" if q["standard_error"] > 0
                 else "" for n, q in fit.items()) + " |", ""]
    return lines + combination_lines(paper, {})[2:]
