"""Two data sets side by side, seed against seed: Yade against LAMMPS on one preset (``make engines``, the engines'
cross-validation) or the reduced cell against the paper's (``make cells``).

``python -m pipeline.studies.versus --a SIDE --b SIDE [--out DIR] [--no-fit]``, a SIDE being
``preset[/engine][/key=value...]`` (``reduced/yade``, ``paper``: the preset's data set,
``pipeline.dataset.selection``). Reads each side's runs, every seed: the reversals (theta = 180), the theta = 90
runs and, where both sides have them, the theta = 150 runs, at the default rotation. Per run, with the fidelity
study's measures (``pipeline.studies.fidelity.summary``): the steady values before each change of direction (tau12/p
as ``mu``, |A|, A12 as ``A_aligned``, Phi of the central band and of the gap), the central band's strain per nominal
strain, the fabric's shear component after each change as a fraction of its value before it (``make jump``'s
measure) at gamma = 0.0005 ... 0.5 (below 0.005 from the runs with dense samples), for runs that tracked their
contacts what the contact budget shows at 0.005, 0.05 and 0.2 strain (``budget.change_measures``: persistence, the
fraction followed, the strong network's share of it, the packing's rise), and, for the reversals, the global fit on
the run alone in the paper's definitions.

Each quantity's mean over a side's runs, its standard error from their scatter (seeds are independent; for the
steady values and the fit never below the runs' own errors, ``welch.own_floor``), and the
difference in combined standard errors, ``z = (B - A) / sqrt(se_A^2 + se_B^2)``. With a few seeds per side z is a
Welch t statistic, not a normal one: the sides agree on a quantity when |z| is below Welch's two-sided 95 %
critical value at the Welch-Satterthwaite degrees of freedom (about 2.2 with six seeds each, 4.3 with two and
two). Of twenty quantities that truly agree, about one falls outside by chance. A side with one run has no
scatter of its own; against a side of several runs it is tested as a new draw from that side
(``one_against_many``); two sides of one run each are shown untested. Writes ``<name>.md`` and
``<name>.json`` into ``--out`` (``results/<name>/``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import scipy.stats

from .. import io
from ..cli import Parser, one_line_errors
from ..dataset import selection
from ..dataset.derived import Definitions, bulk_over_nominal
from ..dataset.lookup import seed_runs
from ..errors import PipelineError
from ..paths import RESULTS_DIR
from ..spec import ENGINES, parse_overrides
from . import welch
from .budget import change_measures
from .fidelity.summary import PAPER_DEFINITIONS, own_fit, steady_values
from .jump import mean_and_error, run_profiles

TRANSIENT_GAMMAS = (0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5)
STEADY = {"mu": "τ12/p", "A_norm": "|A|", "A_aligned": "A12", "phi_central": "Φ band", "phi_gap": "Φ gap"}
FIT_NAMES = ("C", "n", "a1", "a2", "b1", "b2")
#: the angles compared always (the reversals and 90 degrees), and where both sides ran it (150: the slow memory)
ALWAYS, WHERE_BOTH = ("180", "90"), ("150",)
#: two-sided level of the agreement test
LEVEL = 0.95


def run_parts(run) -> tuple[dict, list, list]:
    """What both tables read of a run: its steady values (``steady_values``), its changes' profiles and their contact
    budgets (``budget.change_measures``; none for a run that did not track its contacts)."""
    return steady_values(run), run_profiles(run, TRANSIENT_GAMMAS), change_measures(run)


def budget_names(changes: list[dict]) -> list[str]:
    """The budget's quantities any change of a run has, in their order."""
    return list(dict.fromkeys(name for values in changes for name in values))


def run_measures(run, fit: bool, parts: tuple[dict, list]) -> tuple[dict, dict]:
    """One run's measures (see the module's doc), each a number (NaN where the run cannot give it), and the run's
    own errors of those it has them for (the steady values: their windows' standard error; the fit's: its own);
    ``parts``: its ``run_parts``."""
    steady, profiles, changes = parts
    out = {label: steady[key]["mean"] for key, label in STEADY.items()}
    own = {label: steady[key]["standard_error"] for key, label in STEADY.items()}
    out["band strain / nominal"] = bulk_over_nominal(run.with_definitions(Definitions(strain="bulk")))
    for k, g in enumerate(TRANSIENT_GAMMAS):
        out[f"A fraction at γ = {g:g}"] = _mean([p["fabric"][k] for p in profiles])
    for name in budget_names(changes):
        out[name] = _mean([values.get(name, math.nan) for values in changes])
    if fit:
        result = own_fit(run.with_definitions(PAPER_DEFINITIONS))
        for name in FIT_NAMES:
            out[f"fit {name}"] = result.get("values", {}).get(name, math.nan)
            own[f"fit {name}"] = (result.get("standard_errors") or {}).get(name)
    return out, own


def _mean(values) -> float:
    finite = [v for v in values if np.isfinite(v)]
    return float(np.mean(finite)) if finite else math.nan


#: the cycles compared one by one: a packing still compacting differs from cycle to cycle, so cycle k of one side
#: meets cycle k of the other, and the later cycles pooled
CYCLE_GROUPS = {"cycle 1": lambda c: c == 0, "cycles 2 on": lambda c: c >= 1}


def run_events(parts: tuple[dict, list]) -> dict[str, list[tuple[int, float]]]:
    """Per quantity, a run's values event by event (from its ``run_parts``), each with its cycle (0, 1, ...): the
    steady values over each cycle's two windows (0.3 strain before each change that ends a part of it) and the A
    fractions at each of its two changes of direction."""
    windows, profiles, changes = parts
    out = {label: [(j // 2, w) for j, w in enumerate(windows[key]["windows"][1:])]  # [0]: the preceding half period
           for key, label in STEADY.items()}
    for k, g in enumerate(TRANSIENT_GAMMAS):
        out[f"A fraction at γ = {g:g}"] = [(j // 2, p["fabric"][k]) for j, p in enumerate(profiles)]
    for name in budget_names(changes):
        out[name] = [(j // 2, values.get(name, math.nan)) for j, values in enumerate(changes)]
    return out


def within_run(one: list[float], many: list[list[float]]) -> tuple[float, float, float, int]:
    """One run's events against several runs', by the scatter of events about their own run's mean (the
    change-to-change or window-to-window scatter, with many degrees of freedom): z of the one run's mean against the
    many runs' mean of events, taking the runs' means as alike but for that scatter, its two-sided critical value at
    the scatter's degrees of freedom, and F, the many runs' own scatter of means over what the events' scatter makes
    of it (about 1 where the runs differ by no more than their events do: the test is then sound), and the degrees
    of freedom."""
    groups = [np.asarray([v for v in g if np.isfinite(v)]) for g in many]
    groups = [g for g in groups if len(g)]
    x = np.asarray([v for v in one if np.isfinite(v)])
    dof = sum(len(g) - 1 for g in groups)
    if not len(x) or dof < 1:
        return math.nan, math.nan, math.nan, dof
    s2 = sum(float(np.sum((g - g.mean()) ** 2)) for g in groups) / dof
    total = sum(len(g) for g in groups)
    mean = sum(float(g.sum()) for g in groups) / total
    z = (x.mean() - mean) / math.sqrt(s2 / len(x) + s2 / total) if s2 > 0 else math.nan
    means = [g.mean() for g in groups]
    f = (float(np.var(means, ddof=1)) / (s2 / np.mean([len(g) for g in groups]))
         if len(groups) > 1 and s2 > 0 else math.nan)
    return float(z), float(scipy.stats.t.ppf(0.5 + LEVEL / 2, dof)), f, dof


def cycle_groups(parts: dict) -> dict:
    """``parts[theta][side label]`` (each run's ``run_parts``) compared cycle by cycle (``CYCLE_GROUPS``): per angle
    and group, the rows of ``compare`` on each run's mean over the group's events, beside ``within_run``'s test
    where one side has one run."""
    out = {}
    for theta, by_side in parts.items():
        labels = list(by_side)
        events = {label: [run_events(p) for p in by_side[label]] for label in labels}
        for group, keep in CYCLE_GROUPS.items():
            chosen = {label: [{q: [v for c, v in ev[q] if keep(c)] for q in ev} for ev in events[label]]
                      for label in labels}
            chosen = {label: [ev for ev in evs if any(len(v) for v in ev.values())] for label, evs in chosen.items()}
            if not all(chosen.values()):
                continue
            measures = {label: [{q: _mean(v) for q, v in ev.items()} for ev in evs] for label, evs in chosen.items()}
            cycles = {label: [max(1, len(ev[next(iter(STEADY.values()))]) // 2) for ev in evs]
                      for label, evs in chosen.items()}
            rows = compare(measures, cycles)
            for row in rows:
                if row.get("borrowed"):
                    one = chosen[row["borrowed"]][0][row["quantity"]]
                    many = [ev[row["quantity"]] for ev in chosen[_other(labels, row["borrowed"])]]
                    z, critical, f, dof = within_run(one, many)
                    row["z_within"] = z if row["borrowed"] == labels[1] else -z
                    row["critical_within"], row["f_runs"], row["dof_within"] = critical, f, dof
            out[f"{theta}, {group}"] = {"seeds": {label: len(m) for label, m in measures.items()}, "rows": rows}
    return out


def side(text: str) -> selection.DataSet:
    """``preset[/engine][/key=value...]`` -> its data set (without an engine or overrides, the preset's own)."""
    preset, *rest = text.split("/")
    engine = rest.pop(0) if rest and rest[0] in ENGINES else None
    if rest and "=" not in rest[0]:
        raise PipelineError(f"side {text!r}: {rest[0]!r} is neither an engine ({', '.join(ENGINES)}) nor key=value")
    return selection.data_set(preset, engine, parse_overrides(rest))


def compare(measures: dict, cycles: dict, own: dict | None = None) -> list[dict]:
    """Per quantity: each side's mean, standard error and runs, and z (``measures`` holds two sides, A then B,
    each a list of its runs' measure dicts; ``cycles`` the same sides' cycles per run; ``own`` their runs' own
    errors, where known, below which a side's standard error from its scatter is not taken). A side of one run
    against a side of several is tested as a new draw from the other side (``one_against_many``)."""
    rows = []
    names = list(next(iter(m for m in measures.values() if m))[0]) if any(measures.values()) else []
    labels = list(measures)
    for name in names:
        row = {"quantity": name}
        for label in labels:
            row[label] = dict(zip(("mean", "se", "n"), mean_and_error([m[name] for m in measures[label]]),
                                  strict=True))
            floor = welch.own_floor([e.get(name) for e in own[label]]) if own else math.nan
            if row[label]["n"] > 1 and floor > row[label]["se"]:
                row[label]["se"] = floor
        a, b = row[labels[0]], row[labels[1]]
        single = [label for label in labels if row[label]["n"] == 1 and row[_other(labels, label)]["n"] > 1]
        if single:
            one, many = row[single[0]], row[_other(labels, single[0])]
            widen = math.sqrt(max(1.0, min(cycles[_other(labels, single[0])]) / max(cycles[single[0]])))
            row["z"], row["critical"] = one_against_many(one["mean"], many, widen, sign=1 if one is b else -1)
            row["borrowed"] = single[0]
        else:
            combined = math.hypot(a["se"], b["se"])
            row["z"] = (b["mean"] - a["mean"]) / combined if combined > 0 else math.nan
            row["critical"] = welch.critical(a["se"], a["n"] - 1, b["se"], b["n"] - 1, LEVEL)
        row["agree"] = bool(abs(row["z"]) < row["critical"]) if math.isfinite(row["z"]) else None
        rows.append(row)
    return rows


def _other(labels: list, label: str) -> str:
    return labels[1] if label == labels[0] else labels[0]


def one_against_many(value: float, many: dict, widen: float = 1.0, sign: int = 1) -> tuple[float, float]:
    """z and the two-sided critical value for one run's ``value`` against the mean of ``many`` runs (mean, se, n),
    taken as a new draw: its scatter is the other side's standard deviation per run s = se sqrt(n) (the seeds'
    scatter, or where ``welch.own_floor`` raised se, what the runs' own errors give), times ``widen`` (the square
    root of how many more cycles each of the many runs averages), so z = (value - mean) / sqrt((widen s)^2 + s^2 / n),
    against Student's t at n - 1 degrees of freedom (a prediction interval).
    ``sign`` -1 gives z as (mean - value), the table's B - A when the one run is side A."""
    sd = many["se"] * math.sqrt(many["n"])
    error = math.hypot(widen * sd, many["se"])
    if not (error > 0 and math.isfinite(error)):
        return math.nan, math.nan
    return sign * (value - many["mean"]) / error, float(scipy.stats.t.ppf(0.5 + LEVEL / 2, many["n"] - 1))


def summarise(runs: dict, fits: bool = True) -> dict:
    """The comparison of ``runs[theta][side label]`` (lists of runs; two sides, A then B), the reversals' own
    fits with ``fits``."""
    groups, labels, parts = {}, [], {}
    for theta, by_side in runs.items():
        labels = list(by_side)
        parts[theta] = {label: [run_parts(r) for r in by_side[label]] for label in labels}
        measured = {label: [run_measures(r, fits and theta == "180", p) for r, p in zip(by_side[label],
                                                                                        parts[theta][label],
                                                                                        strict=True)]
                    for label in labels}
        measures = {label: [values for values, _ in runs] for label, runs in measured.items()}
        own = {label: [errors for _, errors in runs] for label, runs in measured.items()}
        cycles = {label: [r.spec.n_cycles for r in by_side[label]] for label in labels}
        groups[theta] = {"seeds": {e: len(m) for e, m in measures.items()}, "rows": compare(measures, cycles, own)}
    return {"sides": labels, "gammas": list(TRANSIENT_GAMMAS), "level": LEVEL, "groups": groups,
            "cycle_groups": cycle_groups(parts)}


def cell(m: dict) -> str:
    if not m["n"]:
        return ""
    return f"{m['mean']:.4g}" + (f" ± {m['se']:.2g}" if np.isfinite(m["se"]) else "") + f" ({m['n']})"


def markdown(summary: dict) -> str:
    a, b = summary["sides"]
    lines = [f"# {a} against {b}", "",
             f"Per quantity: each side's mean over its runs ± the standard error "
             f"from their scatter (runs in brackets; for the steady values and the fit never below what the runs' "
             f"own errors give their mean), and z = ({b} − {a}) / combined standard error; the sides "
             f"agree at these seeds where |z| is below Welch's two-sided {summary['level']:.0%} critical value t* "
             "(about one quantity in twenty falls outside by chance). A side of one run against a side of several "
             "(z marked †) is tested as a new draw from the other side: its scatter is the other side's seed-to-seed "
             "standard deviation, widened by the square root of how many more cycles the other side's runs average "
             "(a prediction interval, Student's t at the other side's runs − 1 degrees of freedom); two sides of one "
             "run each are not tested. Steady values over the 0.3 strain before "
             "each change of direction; A fraction: the fabric's shear component after a change over its value "
             "before it; fit: the global fit on each reversal alone, in the paper's definitions (nominal strain, Φ "
             "of the gap)."]
    for theta, group in summary["groups"].items():
        lines += ["", f"## θ = {theta}° ({group['seeds'][a]} and {group['seeds'][b]} runs)", ""] + table(group, a, b)
    if summary.get("cycle_groups"):
        lines += ["", "## Cycle by cycle", "",
                  "Cycle k of one side against cycle k of the other, and each run's later cycles pooled (a packing "
                  "still compacting differs from cycle to cycle): each run's mean over the group's events (the two "
                  "steady windows and the two changes of direction of each cycle), without the fit and the band "
                  "strain. Where one side has one run, z within (‡) tests it by the events' own scatter about their "
                  "run's mean (windows or changes, many degrees of freedom, in brackets), taking the runs as alike "
                  "but for it; F is the runs' scatter of means over what that scatter makes of it (≈ 1: sound; "
                  "well above 1: the seeds differ more than their events do, and only z† holds)."]
        for name, group in summary["cycle_groups"].items():
            lines += ["", f"### θ = {name} ({group['seeds'][a]} and {group['seeds'][b]} runs)", ""]
            lines += table(group, a, b)
    return "\n".join(lines) + "\n"


def table(group: dict, a: str, b: str) -> list[str]:
    """A group's rows as a markdown table; the within-run test's columns where a row has it."""
    within = any("z_within" in r for r in group["rows"])
    head = f"| quantity | {a} | {b} | z | t* | agree |" + (" z within ‡ | t* | F |" if within else "")
    lines = [head, "|---" * head.count(" | ") + "|---|"]
    for r in group["rows"]:
        z = f"{r['z']:+.2f}" + ("†" if r.get("borrowed") else "") if math.isfinite(r["z"]) else ""
        agree = {True: "yes", False: "**no**", None: ""}[r["agree"]]
        critical = f"{r['critical']:.2f}" if math.isfinite(r["critical"]) else ""
        line = f"| {r['quantity']} | {cell(r[a])} | {cell(r[b])} | {z} | {critical} | {agree} |"
        if within:
            zw, cw, f = (r.get(k, math.nan) for k in ("z_within", "critical_within", "f_runs"))
            mark = "**" if math.isfinite(zw) and abs(zw) >= cw else ""
            line += (f" {mark}{zw:+.2f}{mark} ({r['dof_within']}) | {cw:.2f} | {f:.2g} |" if math.isfinite(zw)
                     else " | | |")
        lines.append(line)
    return lines


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.versus", description=__doc__.splitlines()[0])
    parser.add_argument("--a", required=True, help="one side: preset[/engine][/key=value...] (e.g. reduced/yade)")
    parser.add_argument("--b", required=True, help="the other side (e.g. reduced/lammps, or paper)")
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "versus")
    parser.add_argument("--no-fit", action="store_true", help="leave out the reversals' own fits (minutes)")
    args = parser.parse_args(argv)
    sides = [side(args.a), side(args.b)]
    if sides[0] == sides[1]:
        raise PipelineError(f"--a {args.a} and --b {args.b} are the same data set ({sides[0].label})")
    out = io.check_writable_dir(args.out)
    runs = {theta: {s.label: seed_runs(s, float(theta)) for s in sides} for theta in ALWAYS + WHERE_BOTH}
    runs = {theta: by_side for theta, by_side in runs.items() if theta in ALWAYS or all(by_side.values())}
    none = [s for s in sides if not any(r.is_reversal for r in runs["180"][s.label])]
    if none:
        raise PipelineError(f"{none[0].label} has no reversal run: make dem THETA=180 PRESET={none[0].preset} "
                            f"ENGINE={none[0].engine}" + (f" SET=\"{' '.join(none[0].settings)}\"" if none[0].settings
                                                          else ""))
    summary = {"a": sides[0].label, "b": sides[1].label, **summarise(runs, fits=not args.no_fit)}
    print(f"wrote {io.write_table(out, out.name, summary, markdown(summary))} and {out.name}.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
