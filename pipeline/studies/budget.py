"""The contact budget after each change of direction (``make budget``): what the DEM's contacts do, set against Eq. 13.

``python -m pipeline.studies.budget [--preset P] [--engine E] [--set k=v ...] [--params FILE] [--out DIR]`` reads the
data set's runs that tracked their contacts (``dem/core/budget.py``; without ``--engine``, the preset's data set,
of either engine, with the most such runs) and, for every change of direction, over strain windows after it, measures:

- the fabric's rate of change per unit nominal strain, split into the contacts **made**, **lost** (and their sum, the
  **exchange**, which alone does not depend on the tracking spacing), **kept** (rotating) and **crossing** the
  region's border, against Eq. 13's **input** ``beta1 D'/(|D'| Lambda)``, **recovery**
  ``beta2 A/Lambda`` and the Jaumann **spin** evaluated on the measured fabric (``model.equations.eq13_terms``) with
  the data set's own fit of Eq. 13 (or ``--params``), each per unit strain (``|D'| = gamma_dot/sqrt2``);
- on two components, in units of the steady fabric before the change ``a0 = -s_old.A.e2``: the **shear** part
  ``-s_new.A.e2/a0`` (1 at steady state under the new shear, -1 right after a reversal) and the **memory**
  ``t.A.e2 / (-(t.s_old) a0)``, t the wall-plane direction normal to the new shear (the part of A the new shear does
  not make: 1 at the change, 0 once the old direction is forgotten; only where |sin(turn)| >= 0.25);
- at each window's end: the memory held by the strong and weak networks (each ``fraction x its fabric``) and by the
  contacts present since the change, by how the new shear loads them (compressed, neutral, stretched: their part of
  A); the persistence of the change's contacts by class; the rise of the packing fraction since the change;
- each class's survivors' mean normal force over all survivors' (their unloading);
- the loss rate of the change's contacts, -d ln(persistence)/d gamma (read at the samples: it does not depend on the
  tracking spacing), Eq. 10's S on the measured fabric, and the rate's product with Lambda(S) = S^k: were Eq. 13's
  persistence the contacts', the rate would scale as 1/Lambda and the product would stay level.

Events of one protocol (angle, rotation) are pooled over cycles, both turns of a cycle (the turn to theta and back
are mirror images where both start from a steady state) and seeds; each value is the mean over events with its
standard error. Runs that recorded their near pairs (file version 4 on) add where the memory lives and where the
contacts made come from (``pipeline.studies.near``). Writes ``budget.json`` (``BudgetGroup`` and ``NearGroup``
records), ``budget.md`` and, drawn from the file by
``pipeline.figures.budget``, ``budget.png``. ``--spacing RUN.h5 ...`` instead compares runs of one spec tracked at
different spacings (``spacing.md``).
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

import model
from dem.core.protocol import direction_changes
from model.equations import eq13_terms

from .. import io
from ..cli import Parser, one_line_errors
from ..comparison.metrics import MEMORY_MIN_SIN
from ..dataset import selection
from ..dataset.dem_file import load
from ..dataset.lookup import every_seed
from ..errors import PipelineError
from ..paths import preset_output
from ..spec import ENGINES
from . import law_terms

#: windows of nominal strain after a change: the jump (dense samples) first, then the slow memory
WINDOWS = ((0.0, 0.0005), (0.0005, 0.001), (0.001, 0.002), (0.002, 0.005), (0.005, 0.02), (0.02, 0.05),
           (0.05, 0.1), (0.1, 0.2), (0.2, 0.4))
#: the first window where the laws' own terms are set beside the DEM's (the jump's windows before it)
LAW_WINDOWS_FROM = 4
#: the state before a change: the mean over this much strain before it
BEFORE = 0.02
MEASURED = ("made", "lost", "kept", "crossed")
#: the columns of the measured terms: made and lost apart depend on the tracking spacing (a contact that opens and
#: closes between two tracking points is kept; one seen to is made and lost), their sum, the exchange, does not
COLUMNS = ("made", "lost", "exchange", "kept", "crossed")
EQ13 = ("input", "recovery", "spin")
CLASSES = ("compressed", "neutral", "stretched")
E2 = np.array([0.0, 1.0, 0.0])


@dataclasses.dataclass(frozen=True)
class Stat:
    """A mean over events and its standard error (None for one event)."""

    mean: float
    se: float | None
    n: int

    @classmethod
    def of(cls, values) -> Stat:
        v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
        if len(v) == 0:
            return cls(math.nan, None, 0)
        return cls(float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else None, len(v))

    def text(self, digits: int = 3, of: int | None = None) -> str:
        """``mean ± se``, and ``[n]`` where the mean used fewer than the ``of`` events of its group."""
        if not math.isfinite(self.mean):
            return "–" + (f" [{self.n}]" if of is not None and self.n != of else "")
        return (f"{self.mean:+.{digits}f}" + (f" ± {self.se:.{digits}f}" if self.se is not None else "")
                + (f" [{self.n}]" if of is not None and self.n != of else ""))


@dataclasses.dataclass(frozen=True)
class WindowBudget:
    """One strain window after the changes of one protocol: rates per unit strain of each term on the shear and the
    memory components (fractions of a0), and the state at the window's end."""

    lo: float
    hi: float
    shear: dict[str, Stat]  # MEASURED, "total", EQ13, "eq13_total": rates of the shear fraction
    memory: dict[str, Stat]  # the same on the memory fraction (empty where the turn has no normal part)
    state: dict[str, Stat]  # at the window's end: shear and memory fractions, networks, survivors, persistence, ...


@dataclasses.dataclass(frozen=True)
class BudgetGroup:
    """Every change of direction of one protocol (angle and rotation strain) in a data set."""

    label: str
    theta_deg: float
    rotate_at: float
    runs: list[str]
    events: int
    windows: list[WindowBudget]
    curves: dict[str, list[float]]  # cumulative fractions against strain after the change, mean over events
    laws: list[law_terms.LawTerms] = dataclasses.field(default_factory=list)  # each fitted law's own terms


def event_frame(phi_old: float, phi_new: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(s_new, t, t.s_old): the new shear direction, the wall-plane direction normal to it, and the old direction's
    share of t."""
    s_new, s_old = model.shear_direction(phi_new), model.shear_direction(phi_old)
    t = model.shear_direction(phi_new + 90.0)
    return s_new, t, float(t @ s_old)


def components(X: np.ndarray, s_new, t, a0: float, t_old: float) -> tuple[np.ndarray, np.ndarray]:
    """The shear and memory fractions of tensors X (..., 3, 3)."""
    shear = -np.einsum("i,...ij,j->...", s_new, X, E2) / a0
    if abs(t_old) < MEMORY_MIN_SIN:  # the turn's normal part is small (comparison.metrics)
        return shear, np.full(shear.shape, np.nan)
    return shear, np.einsum("i,...ij,j->...", t, X, E2) / (-t_old * a0)


@dataclasses.dataclass(frozen=True)
class Event:
    """One change of direction in a run's samples: the sample at the change (``at``), the samples of the ``BEFORE``
    strain before it and those after it up to the next change or the last window; its frame (``event_frame``) and
    ``a0``, the steady fabric's shear part before it (``-s_old.A.e2``)."""

    at: int
    before: np.ndarray
    after: np.ndarray
    phi_old: float
    s_new: np.ndarray
    t: np.ndarray
    t_old: float
    a0: float
    tol: float  # a quarter of the sample spacing after the change

    @property
    def idx(self) -> np.ndarray:
        """The sample at the change, then every one after it."""
        return np.concatenate([[self.at], self.after])

    def fraction0(self, X: np.ndarray) -> float:
        """The shear part ``-s_old.X.e2`` of tensors X (samples, 3, 3) averaged over the samples before the change."""
        return float(-model.shear_direction(self.phi_old) @ np.nanmean(X[self.before], axis=0) @ E2)


def find_event(run, change: float, end: float) -> Event | None:
    """The change at strain ``change`` (the next at ``end``) in ``run``'s samples; None where the run does not resolve
    it (no sample at it, none before or after it, no steady shear fabric before it)."""
    raw = run.raw_all
    strain = raw["strain"]
    at = int(np.argmin(np.abs(strain - change)))  # the sample at the change lands within a controller interval
    fine = run.spec.dense_sample_strain if run.spec.dense_window_strain > 0 else run.spec.sample_strain
    if abs(strain[at] - change) > 0.25 * fine or at == 0:
        return None
    before = np.flatnonzero((np.arange(len(strain)) < at) & (strain >= change - BEFORE - 1e-9))
    after = np.flatnonzero((np.arange(len(strain)) > at) & (strain <= min(end, change + WINDOWS[-1][1]) + 1e-9))
    if len(before) == 0 or len(after) == 0:
        return None
    phi_old, phi_new = float(raw["direction_deg"][at - 1]), float(raw["direction_deg"][at])
    s_new, t, t_old = event_frame(phi_old, phi_new)
    a0 = float(-model.shear_direction(phi_old) @ raw["fabric"][before].mean(axis=0) @ E2)
    if not a0 > 0:
        return None
    return Event(at, before, after, phi_old, s_new, t, t_old, a0, 0.25 * fine)


def run_events(run):
    """Every change of direction of ``run`` it resolves (``find_event``): of Fig. 7's turned runs, the turns to theta
    alone."""
    changes = direction_changes(run.spec)
    ends = changes[1:] + [run.raw_all["strain"][-1]]
    for change, end in zip(changes, ends, strict=True):
        if run.default_rotation or change % run.spec.period_strain > 1e-9:
            found = find_event(run, change, end)
            if found is not None:
                yield found


def event_series(run, ev: Event, params: model.Params) -> dict:
    """Per sample after one change (``find_event``): the strain since the change, each term's increment on both
    components, the state's fractions."""
    raw, c = run.raw_all, run.contacts
    strain = raw["strain"]
    at, before, after, idx = ev.at, ev.before, ev.after, ev.idx
    s_new, t, t_old, a0 = ev.s_new, ev.t, ev.t_old, ev.a0
    A = raw["fabric"]
    gamma = strain[idx] - strain[at]
    step = np.diff(strain[idx])
    # Eq. 13 on the state at the start of each interval, along that interval's direction, per unit strain
    L = np.array([model.shear_velocity_gradient(phi) for phi in raw["direction_deg"][idx[:-1]]])
    terms = eq13_terms(A[idx[:-1]], L, params)
    out = {"gamma": gamma, "step": step, "tol": ev.tol}
    for name in MEASURED:
        out[name] = components(c[f"budget_{name}"][after], s_new, t, a0, t_old)
    out["exchange"] = tuple(m + lost for m, lost in zip(out["made"], out["lost"], strict=True))
    for name in EQ13:
        out[name] = components(terms[name] * step[:, None, None] / math.sqrt(2.0), s_new, t, a0, t_old)
    out["A"] = components(A[idx], s_new, t, a0, t_old)
    strong = c["strong_fraction"][idx][:, None, None]
    out["strong"] = components(strong * c["strong_fabric"][idx], s_new, t, a0, t_old)
    out["weak"] = components((1 - strong) * c["weak_fabric"][idx], s_new, t, a0, t_old)
    for k, name in enumerate(CLASSES):
        out[f"survivors_{name}"] = components(c["survivor_part"][idx, k], s_new, t, a0, t_old)
    out["persistence"] = c["persistence_touching"][idx]
    out["packing"] = raw["packing_fraction"][idx] - raw["packing_fraction"][before].mean()
    # the change's contacts lost per unit strain, -d ln(persistence)/d gamma: read at the samples alone, it does not
    # depend on the tracking spacing (the counts made and lost do); a class with no survivor left has no force (NaN)
    with np.errstate(divide="ignore", invalid="ignore"):
        out["loss_rate"] = -np.diff(np.log(c["persistence_touching"][idx, 0])) / step
        out["force"] = c["survivor_force"][idx] / c["survivor_force"][idx, :1]
    out["S"] = terms["S"]
    out["lambda"] = terms["S"] ** params.persistence_exponent
    return out


def window_stats(events: list[dict], lo: float, hi: float, has_memory: bool) -> WindowBudget:
    """The events' rates over (lo, hi] and their state at hi."""
    def rate(e, name, part):
        pick = (e["gamma"][1:] > lo + e["tol"]) & (e["gamma"][1:] <= hi + e["tol"])
        span = e["step"][pick].sum()
        return float(e[name][part][pick].sum() / span) if span > 0.5 * (hi - lo) else math.nan

    def at_end(e, key, part=None):
        k = int(np.argmin(np.abs(e["gamma"] - hi)))
        if abs(e["gamma"][k] - hi) > 0.25 * (hi - lo) + 1e-9:
            return math.nan
        value = e[key] if part is None else e[key][part]
        return float(value[k])

    parts = {"shear": 0, "memory": 1}
    rates = {}
    for comp, part in parts.items():
        if comp == "memory" and not has_memory:
            rates[comp] = {}
            continue
        table = {name: Stat.of([rate(e, name, part) for e in events]) for name in (*COLUMNS, *EQ13)}
        table["total"] = Stat.of([sum(rate(e, n, part) for n in MEASURED) for e in events])
        table["eq13_total"] = Stat.of([sum(rate(e, n, part) for n in EQ13) for e in events])
        rates[comp] = table
    state = {}
    for comp, part in parts.items():
        if comp == "memory" and not has_memory:
            continue
        for key in ("A", "strong", "weak", *(f"survivors_{c}" for c in CLASSES)):
            state[f"{comp}_{key}"] = Stat.of([at_end(e, key, part) for e in events])
    for k, name in enumerate(("all", *CLASSES)):
        state[f"persistence_{name}"] = Stat.of([at_end(e, "persistence", (slice(None), k)) for e in events])
    state["packing_rise"] = Stat.of([at_end(e, "packing") for e in events])
    for k, name in enumerate(CLASSES, start=1):  # each class's survivors' mean normal force over all survivors'
        state[f"force_{name}"] = Stat.of([at_end(e, "force", (slice(None), k)) for e in events])

    def mean_in(e, key):
        pick = (e["gamma"][1:] > lo + e["tol"]) & (e["gamma"][1:] <= hi + e["tol"])
        return float(np.nansum(e[key][pick] * e["step"][pick]) / e["step"][pick].sum()) if pick.any() else math.nan

    def mean_before(e, key):  # S and Lambda at the start of each interval of the window
        pick = (e["gamma"][:-1] >= lo - e["tol"]) & (e["gamma"][:-1] < hi - e["tol"])
        return float(np.nanmean(e[key][pick])) if pick.any() else math.nan

    state["loss_rate"] = Stat.of([mean_in(e, "loss_rate") for e in events])
    state["S"] = Stat.of([mean_before(e, "S") for e in events])
    state["lambda"] = Stat.of([mean_before(e, "lambda") for e in events])
    state["loss_rate_times_lambda"] = Stat.of([mean_in(e, "loss_rate") * mean_before(e, "lambda") for e in events])
    return WindowBudget(lo, hi, rates["shear"], rates["memory"], state)


def curves(events: list[dict], has_memory: bool) -> dict[str, list[float]]:
    """Mean over events of the fraction followed (memory where the turn has a normal part, else shear) and of each
    term's cumulative sum from the change, on the first event's strains (the dense samples make them alike)."""
    part = 1 if has_memory else 0
    gamma = events[0]["gamma"]
    common = [e for e in events if len(e["gamma"]) == len(gamma) and np.allclose(e["gamma"], gamma, atol=2e-4)]
    out = {"gamma": gamma.tolist(), "component": "memory" if has_memory else "shear"}
    out["A"] = np.nanmean([e["A"][part] for e in common], axis=0).tolist()
    start = out["A"][0]
    for name in (*COLUMNS, *EQ13):
        cumulative = [np.concatenate([[0.0], np.cumsum(e[name][part])]) for e in common]
        out[name] = (start + np.nanmean(cumulative, axis=0)).tolist()
    for name in ("strong", "weak", *(f"survivors_{c}" for c in CLASSES)):
        out[name] = np.nanmean([e[name][part] for e in common], axis=0).tolist()
    return out


#: the strains after a change at which two data sets' budgets are compared (``make engines``)
COMPARED_GAMMAS = (0.005, 0.05, 0.2)


def change_measures(run) -> list[dict[str, float]]:
    """Per change of direction of a run (``direction_changes``), what its contacts show at ``COMPARED_GAMMAS``: the
    persistence of the change's contacts, the fraction of the fabric followed (the memory where the turn has a normal
    part, else the shear part), the strong network's share of it and the packing's rise; an empty dict for a change
    the run does not resolve, every one for a run that tracked no contacts."""
    changes = direction_changes(run.spec)
    if run.contacts is None:
        return [{} for _ in changes]
    part = 1 if abs(math.sin(math.radians(run.theta_deg))) >= MEMORY_MIN_SIN else 0
    followed = ("shear", "memory")[part]
    ends = changes[1:] + [run.raw_all["strain"][-1]]
    out = []
    for change, end in zip(changes, ends, strict=True):
        ev = find_event(run, change, end)
        e = None if ev is None else event_series(run, ev, model.PAPER)  # Eq. 13's terms not compared: Table 2 will do
        values = {}
        for g in COMPARED_GAMMAS if e is not None else ():
            k = int(np.argmin(np.abs(e["gamma"] - g)))
            if abs(e["gamma"][k] - g) > 0.25 * g:
                continue
            fraction = float(e["A"][part][k])
            values[f"persistence at γ = {g:g}"] = float(e["persistence"][k, 0])
            values[f"{followed} left at γ = {g:g}"] = fraction
            values[f"strong share of the {followed} at γ = {g:g}"] = float(e["strong"][part][k]) / fraction
            values[f"Φ rise at γ = {g:g}"] = float(e["packing"][k])
        out.append(values)
    return out


def group_label(run) -> str:
    label = f"{run.theta_deg:g}°"
    return label if run.default_rotation else f"{label} at {run.spec.rotate_at_strain:g}"


def budget_groups(runs: list, params: model.Params, laws: tuple = ()) -> list[BudgetGroup]:
    """``BudgetGroup`` of each protocol among ``runs`` (those with a contact budget), with the own terms of the laws
    ``laws`` ((parameters, where from) pairs: ``law_terms``)."""
    by_protocol: dict[tuple, list] = {}
    for run in runs:
        by_protocol.setdefault((run.theta_deg, run.spec.rotate_at_strain), []).append(run)
    groups = []
    for (theta, rotate_at), members in sorted(by_protocol.items(), key=lambda kv: (-kv[0][0], kv[0][1])):
        events = [event_series(run, ev, params) for run in members for ev in run_events(run)]
        if not events:
            continue
        has_memory = abs(math.sin(math.radians(theta))) >= MEMORY_MIN_SIN
        windows = [window_stats(events, lo, hi, has_memory) for lo, hi in WINDOWS]
        own = [law_terms.law_terms(law, source, theta, rotate_at, WINDOWS, has_memory) for law, source in laws]
        groups.append(BudgetGroup(group_label(members[0]), theta, rotate_at, sorted({str(r.path) for r in members}),
                                  len(events), windows, curves(events, has_memory), own))
    return groups


def markdown(label: str, params_source: str, groups: list[BudgetGroup]) -> str:
    lines = [f"# The contact budget: {label}", "",
             f"Eq. 13's terms with {params_source}. Rates per unit nominal strain of the shear fraction "
             "(-s_new.A.e2/a0) and the memory fraction (t.A.e2 over its value at the change), a0 the steady fabric "
             "before the change; mean ± standard error over the events (changes of direction, every cycle and "
             "seed), [n] where a cell used n of them only (the others not resolved there). "
             "`pipeline/studies/budget.py` defines every column.", ""]
    for g in groups:
        lines += [f"## {g.label} ({g.events} changes, {len(g.runs)} run(s))", ""]
        for comp in ("shear", "memory"):
            if not g.windows[0].__dict__[comp]:
                continue
            lines += [f"Rates of the {comp} fraction:", "",
                      "| strain after | made | lost | exchange | kept | crossed | DEM total | Eq. 13 input | recovery "
                      "| spin | Eq. 13 total |", "|---|" + "---|" * 10]
            for w in g.windows:
                r = getattr(w, comp)
                lines.append(f"| {w.lo:g}–{w.hi:g} | " + " | ".join(
                    r[n].text(2, g.events) for n in (*COLUMNS, "total", *EQ13, "eq13_total")) + " |")
            lines.append("")
        if g.laws:
            lines += law_terms.markdown_rows(g, g.laws, LAW_WINDOWS_FROM)
        comp = "memory" if g.windows[0].memory else "shear"
        lines += [f"The {comp} fraction at each window's end, and who holds it:", "",
                  "| strain | A | strong | weak | survivors compressed | neutral | stretched | persistence all "
                  "| compr. | neutral | stretched | force compr. | neutral | stretched | ΔΦ | loss rate | S "
                  "| loss rate × Λ(S) |", "|---|" + "---|" * 17]
        for w in g.windows:
            s = w.state
            cells = [s[f"{comp}_{k}"].text(3, g.events)
                     for k in ("A", "strong", "weak", *(f"survivors_{c}" for c in CLASSES))]
            cells += [s[f"persistence_{k}"].text(3, g.events) for k in ("all", *CLASSES)]
            cells += [s[f"force_{k}"].text(2, g.events) for k in CLASSES]
            cells += [s["packing_rise"].text(4, g.events), s["loss_rate"].text(2, g.events), s["S"].text(3, g.events),
                      s["loss_rate_times_lambda"].text(2, g.events)]
            lines.append(f"| {w.hi:g} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines) + "\n"


def tracked_runs(chosen) -> list:
    return [r for r in every_seed(chosen) if r.contacts is not None]


def choose(args) -> tuple:
    """The data set and its runs with a contact budget; without ``--engine`` (and ``--set``), of the preset's data sets
    of each engine the one with the most such runs (the default engine's on a tie)."""
    chosen = selection.from_arguments(args)
    runs = tracked_runs(chosen)
    if args.engine is None and not args.set:
        for engine in ENGINES:
            other = selection.data_set(chosen.preset, engine)
            if other != chosen and len(found := tracked_runs(other)) > len(runs):
                runs, chosen = found, other
    if not runs:
        raise PipelineError(f"no run of {chosen.label} tracked its contacts: make one with `make dem ... ENGINE="
                            f"{chosen.engine}` (contact_track_strain > 0, the default)")
    return chosen, runs


def eq13_params(chosen, path: Path | None) -> tuple[model.Params, str]:
    """``--params``, or Eq. 13 fitted on the data set's runs (``make models``' fit of the paper's law)."""
    if path is not None:
        params = io.read_params(path)
        if params.variant != model.params.DEFAULT_VARIANT:
            raise PipelineError(f"--params {path}: law {params.variant}, not Eq. 13's ({model.params.DEFAULT_VARIANT})")
        return params, f"the parameters of {path}"
    from ..model_selection.inputs import read
    from ..model_selection.judge import fit

    fitted, _ = fit(read(chosen), model.params.DEFAULT_VARIANT, "all", "runs")
    return fitted.params, f"Eq. 13 fitted on every run of {chosen.label} (as `make models`)"


def spacing_markdown(runs: list) -> str:
    """Runs of one spec tracked at different spacings: the terms' totals over each run and their difference from the
    finest spacing's, sample by sample."""
    runs = sorted(runs, key=lambda r: r.spec.contact_track_strain)
    finest = runs[0]
    for r in runs[1:]:
        if not np.array_equal(r.raw_all["fabric"], finest.raw_all["fabric"]):
            raise PipelineError(f"{r.path} and {finest.path} are not one trajectory (their fabrics differ)")
    lines = ["# The contact budget against the tracking spacing", "",
             f"One trajectory ({finest.spec.label()} and its copies, differing only in `contact_track_strain`). "
             "Made and lost: events over the run; each term's rms over the samples of its 12 component, and the rms "
             "of its difference from the finest spacing's.", "",
             "| contact_track_strain | tracking points | made | lost | entered + left | made rms | lost rms "
             "| made + lost rms | kept rms | made Δ | lost Δ | made + lost Δ | kept Δ |", "|---|" + "---|" * 12]

    def rms(x):
        return float(np.sqrt(np.mean(x ** 2)))

    base = finest.contacts
    for r in runs:
        c = r.contacts
        term = {n: c[f"budget_{n}"][1:, 0, 1] for n in MEASURED}
        ref = {n: base[f"budget_{n}"][1:, 0, 1] for n in MEASURED}
        net, ref_net = term["made"] + term["lost"], ref["made"] + ref["lost"]
        lines.append(
            f"| {r.spec.contact_track_strain:g} | {int(c['track_points'].sum())} | {int(c['made_count'].sum())} "
            f"| {int(c['lost_count'].sum())} | {int(c['entered_count'].sum() + c['left_count'].sum())} "
            f"| {rms(term['made']):.4f} | {rms(term['lost']):.4f} | {rms(net):.4f} | {rms(term['kept']):.5f} "
            f"| {rms(term['made'] - ref['made']):.4f} | {rms(term['lost'] - ref['lost']):.4f} "
            f"| {rms(net - ref_net):.5f} | {rms(term['kept'] - ref['kept']):.6f} |")
    return "\n".join(lines) + "\n"


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.budget", description=__doc__.splitlines()[0])
    selection.add_arguments(parser, "preset whose runs to read")
    parser.add_argument("--params", type=Path, help="Eq. 13's parameters (default: fitted on the data set's runs)")
    parser.add_argument("--spacing", type=Path, nargs="+", metavar="RUN.h5",
                        help="compare runs of one spec tracked at different spacings instead")
    parser.add_argument("--laws", type=Path, nargs="*", metavar="PARAMS.json",
                        help="laws whose own terms to set beside the DEM's (default: every law of `make models`' "
                             "results/<data set>/models/models.json, where it has run)")
    parser.add_argument("--out", type=Path, help="output folder (default results/<data set>/budget)")
    args = parser.parse_args(argv)
    if args.spacing:
        runs = [load(p) for p in args.spacing]
        if any(r.contacts is None for r in runs) or len(runs) < 2:
            raise PipelineError("--spacing needs two runs or more, each with a contact budget")
        out = io.check_writable_dir(args.out or preset_output(runs[0].spec.folder, "budget"))
        io.write_text(out / "spacing.md", spacing_markdown(runs))
        print(f"wrote {out / 'spacing.md'}")
        return 0
    given = law_terms.fitted_laws(args.laws, Path()) if args.laws is not None else None  # checked before long work
    chosen, runs = choose(args)
    out = io.check_writable_dir(args.out or preset_output(chosen.folder, "budget"))
    print(f"budget: {len(runs)} run(s) of {chosen.label} with a contact budget", flush=True)
    laws, law_files = given or law_terms.fitted_laws(None, preset_output(chosen.folder, "models"))
    params, source = eq13_params(chosen, args.params)
    groups = budget_groups(runs, params, tuple(laws))
    from . import near

    shells = near.near_groups(runs)
    from .. import schema

    made_from = schema.MadeFrom.of([r.path for r in runs] + law_files, {"data_set": chosen.folder,
                                                                          "params_source": source})
    record = {"schema_version": 2, "data_set": chosen.folder, "params": params.to_dict(), "params_source": source,
              "windows": [list(w) for w in WINDOWS], "groups": [dataclasses.asdict(g) for g in groups],
              "near_windows": [list(w) for w in near.WINDOWS], "near": [dataclasses.asdict(g) for g in shells],
              "made_from": made_from.to_dict()}
    io.write_json(out / "budget.json", record)
    io.write_text(out / "budget.md", markdown(chosen.label, source, groups) + near.markdown(shells))
    from ..figures import budget as figure

    print(f"wrote {out / 'budget.md'}, budget.json and {figure.draw(out).name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
