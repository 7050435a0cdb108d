"""Where the memory of a turn lives: the near-contact fabric against the contact fabric, and where the contacts made
come from, after each change of direction (``make budget``, runs of file version 4 on: ``dem/core/neighbours.py``).

For every change of direction, per protocol (the events pooled as in ``pipeline.studies.budget``):

- the **memory** (or, for a reversal, the **shear** part) of the contact fabric A, of the near shells' fabrics
  ``G_g`` (pairs within a gap g of touching, g/d = 0.01, 0.03, 0.1) and of the contacts made in each window, all in
  units of A's steady shear part before the change, ``a0 = -s_old.A.e2`` (A's memory: 1 at the change, 0 once the old
  direction is forgotten; its shear part runs from -1 after a reversal to 1), beside each one's own steady value
  before the change (``x0 / a0``, ``x0 = -s_old.X.e2``; a shell's is small, so its own fraction would be noise): does G
  hold the memory longer than A, and do the contacts made carry the old direction (drawn from G) or none (made along
  D', as Eq. 13's input)?
- the share of the contacts made in each window whose pair was within gap g at the change (**fed** by the turn's near
  shell), and the packing fraction's rise since the change (does G's memory go with the compaction?);
- the **gain and loss functions**: contacts made and lost per unit strain in 8 bins of the load
  ``x = n.D'n / max = 2 (n.s)(n.e2)`` (-1 most compressed, 1 most stretched), the gain per near pair of the widest
  shell in the bin and the loss per contact in the bin, before the change (its steady state) and in each window.

Each value is the mean over events with its standard error (``budget.Stat``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

import model
from dem.core.budget import LOAD_BINS
from dem.core.neighbours import NEAR_GAPS

from ..comparison.metrics import MEMORY_MIN_SIN
from .budget import E2, Event, Stat, components, group_label, run_events

#: windows of strain after a change (coarser than the budget's: the near shells are read at the samples)
WINDOWS = ((0.0, 0.005), (0.005, 0.02), (0.02, 0.05), (0.05, 0.1), (0.1, 0.2), (0.2, 0.4))
#: the fabrics whose memory is followed: A, each shell's G_g, and the contacts made
FABRICS = ("A", *(f"G{g:g}" for g in NEAR_GAPS), "made")
#: the shell whose pairs the gain is counted per
GAIN_SHELL = len(NEAR_GAPS) - 1


@dataclasses.dataclass(frozen=True)
class NearWindow:
    """One window after the changes of one protocol: the fabrics' memory (``FABRICS``; A and G at the window's end,
    the contacts made over it), the share of the contacts made that the turn's shells fed, the packing's rise at its
    end, and the gain and loss per bin of load (per unit strain)."""

    lo: float
    hi: float
    memory: dict[str, Stat]
    fed: dict[str, Stat]
    packing_rise: Stat
    gain_per_near: list[Stat]
    loss_per_contact: list[Stat]


@dataclasses.dataclass(frozen=True)
class NearGroup:
    """Every change of direction of one protocol in a data set, its near pairs' record."""

    label: str
    theta_deg: float
    rotate_at: float
    runs: list[str]
    events: int
    component: str  # "memory" or, where the turn has no normal part, "shear"
    steady: dict[str, Stat]  # before the change: each shell's and the contacts made's x0 / a0, its pairs per contact
    steady_gain_per_near: list[Stat]
    steady_loss_per_contact: list[Stat]
    windows: list[NearWindow]


def has_near(run) -> bool:
    """Whether ``run`` recorded its near pairs (a run file of version 4 on)."""
    return run.contacts is not None and "near_fabric" in run.contacts


def _fraction(X, ev: Event, part: int) -> np.ndarray:
    """X's memory (part 1) or shear (part 0) part at the change and each sample after it, in units of A's ``a0``."""
    return components(X[ev.idx], ev.s_new, ev.t, ev.a0, ev.t_old)[part]


def _weighted(fabric, count, rows) -> np.ndarray:
    """The mean of ``fabric`` over ``rows`` weighted by ``count`` (the contacts made each interval)."""
    w = count[rows].astype(float)
    keep = w > 0
    if not keep.any():
        return np.full((3, 3), np.nan)
    return np.einsum("k,kij->ij", w[keep], fabric[rows][keep]) / w[keep].sum()


@dataclasses.dataclass(frozen=True)
class NearSteady:
    """The steady state before a change: the gain and loss by load summed over the samples before it (``gain``,
    ``loss``) and the mean populations they are rates of (``contacts``, ``near``: the widest shell's pairs) over the
    strain ``span``; each shell's and the contacts made's shear part over A's (``x0``, ``made_x0``), and each shell's
    pairs per region contact."""

    gain: np.ndarray
    loss: np.ndarray
    contacts: np.ndarray
    near: np.ndarray
    span: float
    x0: np.ndarray
    made_x0: float
    per_contact: np.ndarray


@dataclasses.dataclass(frozen=True)
class NearEvent:
    """One change of direction, per sample from the change on (``gamma`` the strain since it; the interval k ends at
    sample k + 1): the fractions (``fractions``: ``FABRICS`` but the contacts made, in units of A's ``a0``), the
    packing's rise, the samples' counts and the contacts made's fabric; its frame and its steady state before."""

    gamma: np.ndarray
    step: np.ndarray
    tol: float
    fractions: dict[str, np.ndarray]
    packing: np.ndarray
    made_count: np.ndarray
    made_near_change: np.ndarray
    made_by_load: np.ndarray
    lost_by_load: np.ndarray
    contacts_by_load: np.ndarray
    near_by_load: np.ndarray
    made_fabric: np.ndarray
    frame: tuple
    a0: float
    steady: NearSteady

    def within(self, lo: float, hi: float) -> np.ndarray:
        """The samples ending an interval after the change within (lo, hi]."""
        pick = (self.gamma[1:] > lo + self.tol) & (self.gamma[1:] <= hi + self.tol)
        return np.flatnonzero(pick) + 1

    def at_end(self, values: np.ndarray, lo: float, hi: float) -> float:
        """``values`` at the sample nearest ``hi`` (NaN where none lies within a quarter of the window)."""
        k = int(np.argmin(np.abs(self.gamma - hi)))
        return float(values[k]) if abs(self.gamma[k] - hi) <= 0.25 * (hi - lo) + 1e-9 else math.nan

    def made_memory(self, rows: np.ndarray, part: int) -> float:
        """The contacts made at ``rows``: their fabric's part in units of A's ``a0``."""
        s_new, t, t_old = self.frame
        return float(components(_weighted(self.made_fabric, self.made_count, rows), s_new, t, self.a0, t_old)[part])


def near_event(run, ev: Event, part: int) -> NearEvent:
    """The ``NearEvent`` of one change of ``run`` (``budget.find_event``)."""
    raw, c = run.raw_all, run.contacts
    idx, before = ev.idx, ev.before
    fractions = {"A": _fraction(raw["fabric"], ev, part)}
    fractions |= {f"G{g:g}": _fraction(c["near_fabric"][:, k], ev, part) for k, g in enumerate(NEAR_GAPS)}
    made0 = _weighted(c["made_fabric"], c["made_count"], before)
    steady = NearSteady(
        c["made_by_load"][before].sum(axis=0), c["lost_by_load"][before].sum(axis=0),
        c["contacts_by_load"][before].mean(axis=0), c["near_by_load"][before, GAIN_SHELL].mean(axis=0),
        float(np.diff(raw["strain"][np.concatenate([before, [ev.at]])]).sum()),
        np.array([ev.fraction0(c["near_fabric"][:, k]) / ev.a0 for k in range(len(NEAR_GAPS))]),
        float(-model.shear_direction(ev.phi_old) @ made0 @ E2) / ev.a0,
        np.mean(c["near_count"][before] / raw["contacts"][before, None], axis=0))
    return NearEvent(
        raw["strain"][idx] - raw["strain"][ev.at], np.diff(raw["strain"][idx]), ev.tol, fractions,
        raw["packing_fraction"][idx] - raw["packing_fraction"][before].mean(), c["made_count"][idx],
        c["made_near_change"][idx], c["made_by_load"][idx], c["lost_by_load"][idx], c["contacts_by_load"][idx],
        c["near_by_load"][idx], c["made_fabric"][idx], (ev.s_new, ev.t, ev.t_old), ev.a0, steady)


def _rates(counts, population, span) -> np.ndarray:
    """Events per member of the population per unit strain, per bin (NaN for an empty bin)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(population > 0, counts / (population * span), np.nan)


def window(events: list[NearEvent], lo: float, hi: float, part: int) -> NearWindow:
    memory = {key: Stat.of([e.at_end(e.fractions[key], lo, hi) for e in events]) for key in FABRICS[:-1]}
    memory["made"] = Stat.of([e.made_memory(e.within(lo, hi), part) for e in events if len(e.within(lo, hi))])
    fed = {f"G{g:g}": Stat.of([e.made_near_change[e.within(lo, hi), k].sum() / e.made_count[e.within(lo, hi)].sum()
                               for e in events if e.made_count[e.within(lo, hi)].sum() > 0])
           for k, g in enumerate(NEAR_GAPS)}
    gain, loss = [], []
    for e in events:
        rows = e.within(lo, hi)
        span = e.step[rows - 1].sum()
        if not span > 0.5 * (hi - lo):
            continue
        gain.append(_rates(e.made_by_load[rows].sum(axis=0), e.near_by_load[rows, GAIN_SHELL].mean(axis=0), span))
        loss.append(_rates(e.lost_by_load[rows].sum(axis=0), e.contacts_by_load[rows].mean(axis=0), span))
    return NearWindow(lo, hi, memory, fed, Stat.of([e.at_end(e.packing, lo, hi) for e in events]),
                      _per_bin(gain), _per_bin(loss))


def _per_bin(rows) -> list[Stat]:
    if not rows:
        return [Stat(math.nan, None, 0)] * LOAD_BINS
    rows = np.array(rows)
    return [Stat.of(rows[:, b]) for b in range(LOAD_BINS)]


def near_groups(runs: list) -> list[NearGroup]:
    """``NearGroup`` of each protocol among ``runs`` (those that recorded their near pairs: ``has_near``)."""
    by_protocol: dict[tuple, list] = {}
    for run in runs:
        if has_near(run):
            by_protocol.setdefault((run.theta_deg, run.spec.rotate_at_strain), []).append(run)
    groups = []
    for (theta, rotate_at), members in sorted(by_protocol.items(), key=lambda kv: (-kv[0][0], kv[0][1])):
        part = 1 if abs(math.sin(math.radians(theta))) >= MEMORY_MIN_SIN else 0
        events = [near_event(run, ev, part) for run in members for ev in run_events(run)]
        if not events:
            continue
        steady = {}
        for k, g in enumerate(NEAR_GAPS):
            steady[f"x0 G{g:g} / a0"] = Stat.of([e.steady.x0[k] for e in events])
            steady[f"G{g:g} pairs per contact"] = Stat.of([e.steady.per_contact[k] for e in events])
        steady["x0 made / a0"] = Stat.of([e.steady.made_x0 for e in events])
        st = [e.steady for e in events if e.steady.span > 0]
        groups.append(NearGroup(
            group_label(members[0]), theta, rotate_at, sorted({str(r.path) for r in members}), len(events),
            ("shear", "memory")[part], steady,
            _per_bin([_rates(s.gain, s.near, s.span) for s in st]),
            _per_bin([_rates(s.loss, s.contacts, s.span) for s in st]),
            [window(events, lo, hi, part) for lo, hi in WINDOWS]))
    return groups


def markdown(groups: list[NearGroup]) -> str:
    """The near pairs' section of ``budget.md``."""
    if not groups:
        return ""
    gaps = ", ".join(f"{g:g}" for g in NEAR_GAPS)
    lines = ["## Where the memory lives: the near pairs", "",
             f"Near shells: pairs within a gap g = {gaps} d of touching (`dem/core/neighbours.py`). Each fabric's "
             "memory (shear part for a reversal) in units of A's steady value before the change, a0 (each one's own "
             "value then: x0 / a0): A and G_g at the window's end, the contacts made over the window. Fed: the share "
             "of the contacts made whose pair was in the shell at the change. Gain: contacts made per near pair of "
             "the widest shell per unit strain; loss: contacts lost per contact per unit strain; in 8 bins of "
             "x = 2 (n.s)(n.e2) from -1 (most compressed by the shear of the interval) to 1 (most stretched); [n] "
             "where a cell used n of the events only. "
             "`pipeline/studies/near.py` defines every column.", ""]
    bins = " | ".join(f"{-1 + 2 * (b + 0.5) / LOAD_BINS:+.2f}" for b in range(LOAD_BINS))
    for g in groups:
        lines += [f"### {g.label} ({g.events} changes, {len(g.runs)} run(s)): {g.component}", "",
                  "Before the change: " + "; ".join(f"{k} {v.text(3, g.events)}" for k, v in g.steady.items())
                  + ".", "",
                  "| strain after | " + " | ".join(FABRICS) + " | " + " | ".join(f"fed {k}" for k in
                                                                          g.windows[0].fed) + " | ΔΦ |",
                  "|---|" + "---|" * (len(FABRICS) + len(NEAR_GAPS) + 1)]
        for w in g.windows:
            cells = [w.memory[k].text(3, g.events) for k in FABRICS] + [w.fed[k].text(3, g.events) for k in w.fed]
            lines.append(f"| {w.lo:g}–{w.hi:g} | " + " | ".join(cells) + f" | {w.packing_rise.text(4, g.events)} |")
        for name, steady, attr in (("gain per near pair", g.steady_gain_per_near, "gain_per_near"),
                                   ("loss per contact", g.steady_loss_per_contact, "loss_per_contact")):
            lines += ["", f"The {name} per unit strain, by load x (bin centres):", "",
                      f"| strain after | {bins} |", "|---|" + "---|" * LOAD_BINS,
                      "| before | " + " | ".join(s.text(1, g.events) for s in steady) + " |"]
            lines += [f"| {w.lo:g}–{w.hi:g} | " + " | ".join(s.text(1, g.events) for s in getattr(w, attr)) + " |"
                      for w in g.windows]
        lines.append("")
    return "\n".join(lines) + "\n"
