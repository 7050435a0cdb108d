"""The engines' cross-validation table on synthetic runs of known truth: the same model seen by two engines agrees,
a shifted one is flagged."""

import math

import numpy as np
import pytest

import model
from pipeline.studies import versus
from tests.helpers import synthetic_run


def test_the_same_physics_agrees_and_a_shifted_one_does_not(tmp_path):
    def runs(engine, params, seeds):
        folder = tmp_path / engine
        folder.mkdir(exist_ok=True)
        return [synthetic_run(folder, 180.0, name=f"s{seed}", params=params, seed=seed, noise=0.01, n_cycles=1,
                              engine=engine) for seed in seeds]

    yade = runs("yade", model.PAPER, (1, 2, 3, 4))
    same = runs("lammps", model.PAPER, (5, 6, 7, 8))
    summary = versus.summarise({"180": {"yade": yade, "lammps": same}}, fits=False)
    rows = {r["quantity"]: r for r in summary["groups"]["180"]["rows"]}
    assert rows["τ12/p"]["yade"]["n"] == 4 and rows["τ12/p"]["lammps"]["n"] == 4
    tested = [r["agree"] for r in rows.values() if r["agree"] is not None]
    assert len(tested) >= 10 and sum(tested) >= len(tested) - 1  # one in twenty may fall outside by chance
    assert abs(rows["τ12/p"]["lammps"]["mean"] - rows["τ12/p"]["yade"]["mean"]) < 0.01
    assert 2.4 < rows["τ12/p"]["critical"] < 4.4  # Welch's t* at 3 to 6 degrees of freedom
    stronger = runs("lammps_shifted", model.PAPER.replace(C=model.PAPER.C * 1.2), (9, 10, 11, 12))
    shifted = versus.summarise({"180": {"yade": yade, "lammps": stronger}}, fits=False)
    mu = next(r for r in shifted["groups"]["180"]["rows"] if r["quantity"] == "τ12/p")
    assert mu["agree"] is False and math.isfinite(mu["z"]) and abs(mu["z"]) > 2
    assert "| τ12/p |" in versus.markdown(shifted) and "**no**" in versus.markdown(
        shifted)


def test_a_side_is_a_data_set_and_a_bad_one_is_one_line():
    from pipeline.dataset.selection import DataSet
    from pipeline.errors import PipelineError

    assert versus.side("reduced/lammps") == DataSet("reduced", "lammps")
    chosen = DataSet("paper", "lammps", (("inertial_number", 0.001),))
    assert versus.side("paper/lammps/inertial_number=0.001") == chosen
    assert versus.side("reduced/yade/seed=3") == DataSet("reduced")  # seeds are the runs compared, not a side
    for bad, message in (("reduced/foo", "'foo' is neither an engine"), ("nosuch", "unknown preset 'nosuch'"),
                         ("reduced/lammps/colour=1", "unknown override key(s) colour")):
        with pytest.raises(PipelineError, match=message.replace("(", r"\(").replace(")", r"\)")):
            versus.side(bad)


def test_one_run_against_several_is_tested_as_a_new_draw_and_a_shifted_one_is_flagged(tmp_path):
    folder = tmp_path / "runs"
    folder.mkdir()
    many = [synthetic_run(folder, 180.0, name=f"s{seed}", seed=seed, noise=0.01, n_cycles=1) for seed in (1, 2, 3)]
    one = [synthetic_run(folder, 180.0, name="one", seed=9, noise=0.01, n_cycles=1, engine="lammps")]
    summary = versus.summarise({"180": {"reduced (yade)": many, "paper (lammps)": one}}, fits=False)
    rows = {r["quantity"]: r for r in summary["groups"]["180"]["rows"]}
    mu = rows["τ12/p"]
    assert mu["paper (lammps)"]["n"] == 1 and mu["borrowed"] == "paper (lammps)"
    assert mu["critical"] == pytest.approx(4.303, abs=1e-3)  # Student's t, 2 degrees of freedom, 95 %
    tested = [r["agree"] for r in rows.values() if r["agree"] is not None]
    assert len(tested) >= 10 and sum(tested) >= len(tested) - 1
    assert "| τ12/p |" in versus.markdown(summary) and "†" in versus.markdown(summary)
    stronger = [synthetic_run(folder, 180.0, name="strong", seed=9, noise=0.01, n_cycles=1, engine="lammps",
                              params=model.PAPER.replace(C=model.PAPER.C * 1.2))]
    shifted = versus.summarise({"180": {"reduced (yade)": many, "paper (lammps)": stronger}}, fits=False)
    mu = next(r for r in shifted["groups"]["180"]["rows"] if r["quantity"] == "τ12/p")
    assert mu["agree"] is False and mu["z"] > 0  # B - A: the stronger backstress raises tau12/p
    alone = versus.summarise({"180": {"reduced (yade)": many[:1], "paper (lammps)": one}}, fits=False)
    assert all(r["agree"] is None for r in alone["groups"]["180"]["rows"])


def test_two_seeds_that_agree_by_chance_keep_their_own_errors():
    """Two runs 0.0006 apart against three 0.001 apart, each run with its own error 0.003: their scatter alone
    would make a 0.007 difference a disagreement; with the runs' own errors as the floor it is not. A quantity
    without own errors keeps its scatter."""
    a = [{"τ12/p": v, "A fraction at γ = 0.1": -0.45 + d} for v, d in ((0.379, 0.0), (0.380, 0.01), (0.381, -0.01))]
    b = [{"τ12/p": v, "A fraction at γ = 0.1": -0.42 + d} for v, d in ((0.3870, 0.0), (0.3876, 0.0004))]
    own = {"A": [{"τ12/p": 0.003, "A fraction at γ = 0.1": None}] * 3,
           "B": [{"τ12/p": 0.003, "A fraction at γ = 0.1": None}] * 2}
    rows = {r["quantity"]: r for r in versus.compare({"A": a, "B": b}, {"A": [5] * 3, "B": [5] * 2}, own)}
    assert rows["τ12/p"]["B"]["se"] == pytest.approx(0.003 / np.sqrt(2))
    assert rows["τ12/p"]["A"]["se"] == pytest.approx(0.003 / np.sqrt(3))  # A's scatter (0.0006) is below it too
    assert rows["τ12/p"]["agree"]
    bare = {r["quantity"]: r for r in versus.compare({"A": a, "B": b}, {"A": [5] * 3, "B": [5] * 2})}
    assert bare["τ12/p"]["B"]["se"] == pytest.approx(0.0003) and not bare["τ12/p"]["agree"]
    assert rows["A fraction at γ = 0.1"]["B"]["se"] == pytest.approx(0.0002)


@pytest.mark.parametrize("cycles_ratio", [1, 4])
def test_one_against_many_holds_95_percent_of_new_draws(cycles_ratio):
    """Three runs of five cycles and one run of 5 / ratio cycles, all from one normal population (a run's noise
    variance going as 1 / cycles): the test accepts the one run 95 % of the time."""
    rng = np.random.default_rng(cycles_ratio)
    accepted = []
    for _ in range(4000):
        many = rng.normal(0.0, 1.0, size=3)
        value = rng.normal(0.0, np.sqrt(cycles_ratio))
        summary = {"mean": many.mean(), "se": many.std(ddof=1) / np.sqrt(3), "n": 3}
        z, critical = versus.one_against_many(value, summary, widen=np.sqrt(cycles_ratio))
        accepted.append(abs(z) < critical)
    assert np.mean(accepted) == pytest.approx(0.95, abs=0.012)  # 3.5 binomial standard deviations


def test_within_run_scatter_holds_its_level_and_tells_when_the_runs_differ_more():
    """One run's events against three runs' events of the same distribution: |z within| < t* about 95 % of the
    time, F about 1; where the runs' means scatter more than their events, F says so."""
    rng = np.random.default_rng(3)
    inside, f = [], []
    for _ in range(2000):
        z, critical, ratio, dof = versus.within_run(list(rng.normal(size=8)), [list(rng.normal(size=8))
                                                                              for _ in range(3)])
        inside.append(abs(z) < critical)
        f.append(ratio)
    assert dof == 21 and abs(np.mean(inside) - 0.95) < 0.015 and 0.8 < np.mean(f) < 1.2
    apart = [list(rng.normal(loc=3 * k, size=8)) for k in range(3)]
    assert versus.within_run(list(rng.normal(size=8)), apart)[2] > 20


def test_cycle_by_cycle_meets_cycle_1_with_cycle_1_and_pools_the_later_cycles(tmp_path):
    folder = tmp_path / "runs"
    folder.mkdir()
    many = [synthetic_run(folder, 180.0, name=f"s{seed}", seed=seed, noise=0.01, n_cycles=3) for seed in (1, 2, 3)]
    one = [synthetic_run(folder, 180.0, name="one", seed=9, noise=0.01, n_cycles=3, engine="lammps")]
    single = [synthetic_run(folder, 180.0, name="single", seed=8, noise=0.01, n_cycles=1, engine="lammps")]
    groups = versus.summarise({"180": {"many": many, "one": one}}, fits=False)["cycle_groups"]
    assert set(groups) == {"180, cycle 1", "180, cycles 2 on"}
    mu = next(r for r in groups["180, cycles 2 on"]["rows"] if r["quantity"] == "τ12/p")
    assert mu["dof_within"] == 3 * (4 - 1) and abs(mu["z_within"]) < mu["critical_within"]
    text = versus.markdown(versus.summarise({"180": {"many": many, "one": one}}, fits=False))
    assert "### θ = 180, cycles 2 on (3 and 1 runs)" in text and "z within ‡" in text
    only_first = versus.summarise({"180": {"many": many, "single": single}}, fits=False)["cycle_groups"]
    assert set(only_first) == {"180, cycle 1"}  # a one-cycle side has no later cycles to meet


def test_both_engines_give_the_same_contact_budget_after_a_turn_within_their_seeds_scatter():
    """The committed reduced runs at 150 degrees, two seeds of each engine, all tracking their contacts: the contact
    budget (persistence, the memory left, the strong network's share of it, the packing's rise, at 0.005, 0.05 and
    0.2 strain after each turn) agrees between Yade and LAMMPS within Welch's test, all but one quantity in twenty
    as chance allows, seed against seed and cycle against cycle."""
    from pipeline.dataset.lookup import seed_runs
    from pipeline.paths import ROOT

    roots = (ROOT / "data" / "reference",)
    runs = {label: seed_runs(versus.side(f"reduced/{label}"), 150.0, roots) for label in ("yade", "lammps")}
    assert all(len(r) == 2 and all(run.contacts is not None for run in r) for r in runs.values())
    summary = versus.summarise({"150": runs}, fits=False)
    rows = [r for r in summary["groups"]["150"]["rows"]
            if r["quantity"].split(" at γ")[0] in ("persistence", "memory left", "strong share of the memory",
                                                  "Φ rise")]
    assert len(rows) == 12 and all(r["yade"]["n"] == 2 and r["lammps"]["n"] == 2 for r in rows)
    tested = [r["agree"] for r in rows if r["agree"] is not None]
    assert len(tested) == 12 and sum(tested) >= 11, [(r["quantity"], r["z"]) for r in rows]
