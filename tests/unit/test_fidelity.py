"""The fidelity study's bookkeeping, summaries and errors, on model-made runs and made-up summaries."""

import json

import numpy as np
import pytest

import model
from pipeline.dataset.derived import change_strains
from pipeline.errors import SpecError
from pipeline.paths import RESULTS_DIR, fidelity_output
from pipeline.studies.fidelity import ladder, render, table
from pipeline.studies.fidelity.summary import summarize
from tests.helpers import synthetic_run


def test_the_ladder_is_validated_and_its_preset_run_is_one_run_on_every_axis(tmp_path):
    rungs = ladder.rungs(ladder.load())
    base = [r for r in rungs if not r.spec.overrides and r.theta_deg == 180.0]
    # every axis but the seeds of other settings passes through the preset, always as the same run
    assert {r.axis for r in base} == set(ladder.load()["axes"]) - {"small_cell_seed", "dt_safety_seed"}
    assert len({r.relative for r in base}) == 1
    bad = tmp_path / "bad.toml"
    bad.write_text('preset = "reduced"\nthetas = [180.0]\n[axes.x]\nvalues = [{ dt_safety = 0.9 }]\n')
    with pytest.raises(SpecError, match="bad.toml, axis x, .*dt_safety"):
        ladder.rungs(ladder.load(bad), source=bad.name)
    # a user's ladder: checked in one line naming the file, its table in a folder of its own
    for text, said in (('preset = "huge"\nthetas = [180.0]\n[axes.x]\nvalues = [{ seed = 2 }]\n', "preset 'huge'"),
                       ('preset = "tiny"\n[axes.x]\nvalues = [{ seed = 2 }]\n', "axis x needs values, and thetas"),
                       ('preset = "tiny"\nthetas = [180.0]\n[axes.x]\nvalues = []\n', "axis x needs values")):
        bad.write_text(text)
        with pytest.raises(SpecError, match=f"bad.toml: {said}"):
            ladder.load(bad)
    assert fidelity_output() == RESULTS_DIR / "fidelity"
    assert fidelity_output(bad, "lammps") == RESULTS_DIR / "fidelity-bad-lammps"


def test_a_run_with_a_summary_or_a_file_is_not_run_again_and_the_rest_is_a_sweep(tmp_path):
    rungs = ladder.rungs(ladder.load())
    summaries, results = tmp_path / "summaries", tmp_path / "results"
    first, second = rungs[0], next(r for r in rungs if r.relative != rungs[0].relative)
    path = ladder.summary_path(first, summaries)
    path.parent.mkdir(parents=True)
    path.write_text("{}")
    (results / second.relative).parent.mkdir(parents=True)
    (results / second.relative).write_bytes(b"")
    todo = ladder.missing(rungs, summaries, roots=(results,))
    relatives = [r.relative for r in todo]
    assert first.relative not in relatives and second.relative not in relatives
    assert len(relatives) == len(set(relatives)) == len({r.relative for r in rungs}) - 2
    sweep = ladder.sweep_of(todo, "reduced", results)
    assert [t.output for t in sweep.tasks] == [results / r.relative for r in todo]
    from pipeline.spec import output_path

    for task, rung in zip(sweep.tasks, todo, strict=True):  # the launcher's arguments make exactly that run
        assert output_path(task.spec(), results) == results / rung.relative
    lammps = ladder.rungs(ladder.load(), "lammps")  # the same ladder in LAMMPS: its own runs, a LAMMPS sweep
    assert len(lammps) == len(rungs) and all(r.relative.parts[0].startswith("reduced-lammps") for r in lammps)
    for task, rung in zip(ladder.sweep_of(lammps[:3], "reduced", results).tasks, lammps[:3], strict=True):
        assert task.engine == "lammps" and output_path(task.spec(), results) == results / rung.relative


def test_the_summary_recovers_the_models_steady_values_and_the_runs_own_fit(tmp_path):
    run = synthetic_run(tmp_path, n_cycles=2, noise=0.002, seed=3)
    s = summarize(run)
    json.dumps(s)  # compact and JSON-able
    cycle = model.predict(180)
    before = cycle.strain < 0.7 - 1e-9
    mu_model = cycle.tau[before][-1, 0, 1]  # the steady tau12/p along the shear, at the end of a segment
    assert len(change_strains(run.spec)) == 5  # 0, 0.7, 1.4, 2.1, 2.8
    assert s["steady"]["mu"]["mean"] == pytest.approx(mu_model, abs=0.01)
    assert s["steady"]["A_norm"]["mean"] == pytest.approx(np.linalg.norm(cycle.A[before][-1]), abs=0.005)
    assert s["fit"]["values"]["b2"] == pytest.approx(model.PAPER.b2, rel=0.15)
    assert s["fit"]["rmse"]["own fit"]["tau12"] <= s["fit"]["rmse"]["Table 2"]["tau12"] + 0.02


def _summary(folder, mu, se=0.005, cpu=0.5, C=-5.6):
    steady = {k: {"mean": v, "standard_error": se} for k, v in
              {"mu": mu, "A_norm": 0.09, "A_aligned": -0.06, "phi_central": 0.6, "phi_gap": 0.65}.items()}
    return {"folder": folder, "name": "theta180", "theta_deg": 180.0, "overrides": {}, "steady": steady,
            "bulk_over_nominal": 1.4, "cost": {"cpu_hours": cpu, "steps_per_second": 1000, "grains": 714},
            "fit": {"values": {n: (C if n == "C" else getattr(model.PAPER, n)) for n in table.FITTED},
                    "standard_errors": {}, "rmse": {}}}


def test_the_table_recovers_a_known_bias_against_the_seeds_noise_and_prices_a_precision():
    rng = np.random.default_rng(0)
    seeds = [("seed", f"seed={k}", _summary(f"s{k}", 0.38 + rng.normal(0, 0.01), C=-5.6 + rng.normal(0, 0.3)))
             for k in range(12)]
    biased = ("inertial_number", "inertial_number=0.003", _summary("hi", 0.42, cpu=0.2))
    biased[2]["overrides"] = {"inertial_number": 3e-3}
    result = table.build([*seeds, biased])
    ref = result["references"]["180"]
    assert ref["runs"] == 12 and ref["steady"]["mu"]["standard_error"] == pytest.approx(0.01 / np.sqrt(12), rel=0.4)
    row = next(r for r in result["rows"] if r["axis"] == "inertial_number")
    assert abs(row["steady"]["mu"]["shift"] - 0.04) < 2 * row["steady"]["mu"]["shift_se"]
    # one run is as uncertain as the seeds scatter (0.01), not as its own windows say (0.005)
    assert row["steady"]["mu"]["shift_se"] >= ref["steady"]["mu"]["sd_per_run"] > 0.006
    assert row["error"] == pytest.approx(0.04 / 0.38, rel=0.15)
    preset = result["recommendation"]["180"]["quantities"]["C"]["candidates"][0]
    assert preset["setting"] == "preset"  # (0.3 / (0.05 * 5.6))^2 = 1.1 -> about 1-3 runs
    assert 1 <= preset["levels"]["0.05"]["runs"] <= 4
    assert result["pareto"]["180"] == ["inertial_number=0.003"]  # alone, it is on the front
    cheaper = ("inertial_number", "", {**_summary("lo", 0.39, cpu=0.1), "overrides": {"inertial_number": 5e-4}})
    front = table.build([*seeds, biased, cheaper])["pareto"]["180"]
    assert front == ["inertial_number=0.0005"]  # cheaper and nearer: it alone is on the front


def test_stability_cases_are_distinct_runs_and_only_the_unchecked_ones_pass_the_bounds():
    from pipeline.errors import SpecError
    from pipeline.spec import resolve
    from pipeline.studies import stability

    specs = [stability.spec_of(c) for c in stability.CASES]
    assert len({(s.folder, s.name) for s in specs}) == len(specs)
    for case, spec in zip(stability.CASES, specs, strict=True):
        for key, value in case.unchecked.items():
            assert getattr(spec, key) == value and spec.overrides[key] == value
            with pytest.raises(SpecError):
                resolve(case.theta_deg, case.preset, overrides={**case.overrides, key: value})


def test_small_cells_against_the_reference_cell_recover_the_bias_and_scatter_and_pick_the_winner():
    rng = np.random.default_rng(1)
    ref = [("seed", f"seed={k}", _summary(f"r{k}", 0.38 + rng.normal(0, 0.01), cpu=0.6,
                                          C=-5.6 + rng.normal(0, 0.3))) for k in range(60)]
    # small cells: 4x cheaper, twice the scatter; a bias in mu well above the ensemble's error, none in C
    small = [("small_cell_seed", f"seed={k}", _summary(f"s{k}", 0.36 + rng.normal(0, 0.02), cpu=0.15,
                                                        C=-5.6 + rng.normal(0, 0.6))) for k in range(60)]
    ens = table.build([*ref, *small])["ensembles"]["180"]
    assert ens["small_runs_per_reference_run"] == pytest.approx(4.0)
    mu, c = ens["quantities"]["mu"], ens["quantities"]["C"]
    assert abs(mu["bias"] + 0.02) < 3 * mu["bias_se"] and mu["sd_small"] == pytest.approx(0.02, rel=0.25)
    assert mu["better"] == "reference cell"  # a bias of 0.02 beats any number of small runs
    assert abs(c["bias"]) < 3 * c["bias_se"] and c["sd_reference"] == pytest.approx(0.3, rel=0.25)
    # no bias: 4 small runs of sd 0.6 give 0.3, a tie with one reference run: decided by the sampled noise
    assert c["error_small_ensemble"] == pytest.approx(np.sqrt(c["bias"] ** 2 + c["sd_small"] ** 2 / 4))
    assert table.ensemble_against_larger(ref[:5], 180.0) == {}  # no small cells: no answer


def test_the_extrapolation_recovers_a_bias_linear_in_one_over_h_at_the_papers_gap():
    rng = np.random.default_rng(2)
    entries = []
    for gap, seeds in ((6.8, 4), (8.5, 9), (11.9, 3), (13.6, 2)):
        for k in range(seeds):
            s = _summary(f"h{gap}s{k}", 0.45 - 0.5 / gap + rng.normal(0, 0.01), C=-5.0 - 4.0 / gap + rng.normal(0, 0.2))
            over = {"seed": float(k + 1)} if gap == 8.5 else {"width_d": gap / 0.85, "gap_d": gap, "seed": float(k + 1)}
            s["overrides"], s["spec"] = over, {"gap_d": gap, "width_d": gap / 0.85}
            entries.append(("seed" if gap == 8.5 else "cell", "", s))
    entries.append(("inertial_number", "", {**_summary("other", 0.30), "overrides": {"inertial_number": 3e-3},
                                            "spec": {"gap_d": 8.5}}))  # another axis: left out of the line
    result = table.build(entries, extrapolations={"cell": {"keys": ["gap_d", "width_d"], "transform": "inverse",
                                                           "paper": 17.0}})
    line = result["extrapolations"]["180"]["cell"]["quantities"]
    mu, c = line["mu"], line["C"]
    assert [p["runs"] for p in mu["points"]] == [4, 9, 3, 2]
    assert abs(mu["at_target"] - (0.45 - 0.5 / 17)) < 3 * mu["at_target_se"] and mu["at_target_se"] < 0.02
    assert abs(mu["slope"] + 0.5) < 3 * 0.2 and mu["chi2_per_dof"] < 4
    assert abs(c["at_target"] - (-5.0 - 4.0 / 17)) < 3 * c["at_target_se"]
    two = table.build(entries[:13], extrapolations={"cell": {"keys": ["gap_d", "width_d"], "transform": "inverse",
                                                             "paper": 17.0}})
    assert two["extrapolations"]["180"]["cell"]["quantities"]["mu"]["chi2_per_dof"] is None  # two values: untested


def test_the_recommendation_prices_a_target_error_and_an_ensemble_of_that_size_meets_it():
    from pipeline.studies.fidelity import recommend

    rng = np.random.default_rng(3)
    truth, sd = 0.38, 0.02  # one preset run: 5.3 % of the truth
    seeds = [("seed", "", _summary(f"r{k}", truth + rng.normal(0, sd), se=0.002, cpu=0.6)) for k in range(40)]

    def setting(axis, bias, cpu, runs):
        out = []
        for k in range(runs):
            s = _summary(f"{axis}{k}", truth + bias + rng.normal(0, sd), se=0.002, cpu=cpu)
            s["overrides"] = {axis: 1.0, "seed": float(k + 1)}
            out.append((axis, "", s))
        return out

    cheap_biased = setting("cheap", 0.06, 0.1, 6)  # 16 % off: meets neither target, however many runs
    cheap_fair = setting("fair", 0.0, 0.3, 6)  # half the preset's cost, no bias
    rec = table.build([*seeds, *cheap_biased, *cheap_fair])["recommendation"]["180"]["quantities"]["mu"]
    by = {c["setting"]: c for c in rec["candidates"]}
    assert by["cheap=1"]["levels"]["0.1"]["runs"] is None and "bias" in by["cheap=1"]["levels"]["0.1"]["why"]
    assert rec["cheapest"]["0.1"]["setting"] == rec["cheapest"]["0.05"]["setting"] == "fair=1"
    # the preset's runs: the fewest k with sd/sqrt(k) <= target
    sd_seen = by["preset"]["sd_per_run"]
    for level in (0.1, 0.05):
        k = by["preset"]["levels"][f"{level:g}"]["runs"]
        assert sd_seen / np.sqrt(k) <= level * rec["reference"] < sd_seen / np.sqrt(max(k - 1, 1)) + 1e-12 or k == 1
        # what it promises holds: the RMS error of many k-run means from the true distribution meets the target
        means = truth + rng.normal(0, sd, size=(4000, k)).mean(axis=1)
        assert np.sqrt(np.mean((means - truth) ** 2)) <= 1.15 * level * truth
    assert recommend.runs_for(0.0, 1.0, 0.01) is None  # 10 000 runs: beyond MAX_RUNS
    assert recommend.runs_for(0.02**2, 0.01, 0.01) is None  # a bias above the target


def test_the_combinations_a_reversal_fixes_are_found_and_compared_with_table_2():
    from pipeline.studies.fidelity import combinations

    rng = np.random.default_rng(4)
    seeds = []
    for k in range(12):  # a1 and a2 scale together by up to 2x (a loose product); their ratio is fixed to 1 %
        s = _summary(f"r{k}", 0.38)
        loose, tight = rng.normal(0, 0.5), rng.normal(0, 0.01)
        values = s["fit"]["values"]
        values["a1"] *= np.exp(loose - tight)
        values["a2"] *= 1.1 * np.exp(loose + tight)  # our ratio a2/a1: 10 % above Table 2's
        for n in ("C", "n", "b1", "b2", "m"):
            values[n] *= np.exp(rng.normal(0, 0.1))
        seeds.append(("seed", "", s))
    found = combinations.find([s for *_, s in seeds], ("C", "n", "a1", "b1", "a2", "b2", "m"))
    assert "m" in found["names"]  # one sign over the seeds (about Table 2's -0.6 in every made-up fit)
    assert combinations.find([s for *_, s in seeds], ("a1", "a2", "phi_c"))["names"] == ["a1", "a2"]  # held
    best = found["combinations"][0]
    v = best["direction"]
    assert abs(v["a2"]) == pytest.approx(abs(v["a1"]), rel=0.1) and v["a2"] * v["a1"] < 0 and abs(v["a2"]) > 0.6
    assert best["in_sample_sd"] <= best["sd_per_run"] < 0.05  # out of sample: never tighter than in sample
    # the product's ratio to Table 2: (a2 / a1)^0.707 of 1.1, against the seeds' error
    assert np.exp(best["mean"] - best["table2"]) == pytest.approx(1.1 ** abs(v["a2"]), abs=3 * best["standard_error"])
    assert found["combinations"][-1]["sd_per_run"] > 0.3  # the loose product comes last
    for *_, s in seeds[:8]:  # refitted in the paper's definitions: a2 another 10 % up there
        paper_fit = {**s["fit"]["values"], "a2": 1.1 * s["fit"]["values"]["a2"]}
        s["fit_paper_definitions"] = {**s["fit"], "values": paper_fit}
    table_ = table.build(seeds)
    assert table_["combinations"]["180"]["seeds"] == 12
    paper = table_["paper_definitions"]["180"]
    assert paper["seeds"] == 8 and paper["reference"]["fit"]["a2"]["mean"] == pytest.approx(
        1.1 * np.mean([s["fit"]["values"]["a2"] for *_, s in seeds[:8]]))
    assert "In the paper's definitions" in render.markdown(table_)
    assert combinations.find([s for *_, s in seeds][:4], ("a1", "a2")) == {}  # too few seeds to say


def test_an_older_summary_is_redone_where_its_run_is_at_hand_and_kept_where_it_is_not(tmp_path):
    import shutil

    from pipeline.studies.fidelity.gather import summaries
    from pipeline.studies.fidelity.summary import VERSION
    from tests.helpers import synthetic_file

    rungs = ladder.rungs(ladder.load())
    here, gone = rungs[0], next(r for r in rungs if r.relative != rungs[0].relative)
    summary_dir, root = tmp_path / "summaries", tmp_path / "runs"
    for rung in (here, gone):
        path = ladder.summary_path(rung, summary_dir)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({**_summary("old", 0.4), "schema_version": VERSION - 1, "marker": 1}))
    (root / here.relative).parent.mkdir(parents=True)
    shutil.copy(synthetic_file(tmp_path, n_cycles=2, noise=0.002, seed=5), root / here.relative)
    entries = summaries([here, gone], summary_dir, roots=(root,))
    redone, kept = entries[0][2], entries[1][2]
    assert redone["schema_version"] == VERSION and "marker" not in redone and redone["fit_paper_definitions"]
    assert json.loads(ladder.summary_path(here, summary_dir).read_text())["schema_version"] == VERSION
    assert kept["marker"] == 1  # its run is not here: the older summary still counts


def _cell_entries(rng, mu_of_gap, seeds=((6.8, 4), (8.5, 9), (11.9, 3), (13.6, 2)), sd=0.01):
    entries = []
    for gap, n in seeds:
        for k in range(n):
            s = _summary(f"h{gap}s{k}", mu_of_gap(gap) + rng.normal(0, sd))
            over = {"seed": float(k + 1)} if gap == 8.5 else {"width_d": gap / 0.85, "gap_d": gap, "seed": float(k + 1)}
            s["overrides"], s["spec"] = over, {"gap_d": gap, "width_d": gap / 0.85}
            entries.append(("seed" if gap == 8.5 else "cell", "", s))
    return entries


def _top(rng, mu, runs, sd=0.01):
    return [{**_summary(f"paper{k}", mu + rng.normal(0, sd)), "name": "theta180"} for k in range(runs)]


def test_the_top_rung_is_set_against_the_extrapolation_and_says_whether_it_was_predicted():
    rng = np.random.default_rng(5)
    truth = lambda gap: 0.45 - 0.5 / gap  # noqa: E731
    entries = _cell_entries(rng, truth)
    cell = {"cell": {"keys": ["gap_d", "width_d"], "transform": "inverse", "paper": 17.0}}
    fair = table.build(entries, extrapolations=cell, top=("paper (lammps)", _top(rng, truth(17.0), 3), ["cell"]))
    check = fair["top"]["180"]
    assert check["runs"] == 3 and check["data_set"] == "paper (lammps)"
    mu = check["checks"]["cell"]["mu"]
    assert mu["within_95"] and mu["extrapolated"] == fair["extrapolations"]["180"]["cell"]["quantities"]["mu"][
        "at_target"]
    off = table.build(entries, extrapolations=cell, top=("paper", _top(rng, truth(17.0) + 0.1, 1), ["cell"]))
    one = off["top"]["180"]["checks"]["cell"]["mu"]
    assert not one["within_95"] and one["z"] > 5 and one["paper_cell_se"] == 0.005  # one run: its windows' error
    assert "The top rung, the paper's cell (paper, 1 run(s))" in render.markdown(off)
    assert "| mu |" in render.markdown(off).split("The top rung")[1]


def test_two_top_rung_seeds_that_agree_by_chance_keep_their_own_errors():
    """Two seeds 0.0006 apart, each with a windows' error of 0.003: their scatter alone (0.0003) would claim ten
    times less than either run's noise allows; the error is at least their own errors' mean's (0.003 / sqrt 2)."""
    rng = np.random.default_rng(3)
    truth = lambda gap: 0.45 - 0.5 / gap  # noqa: E731
    line = table.extrapolate(_cell_entries(rng, truth), 180.0, ["gap_d", "width_d"], "inverse", 17.0, {"mu": 0.01},
                             ("mu",))
    top = [{**_summary(f"paper{k}", 0.387 + d, se=0.003), "name": "theta180"} for k, d in enumerate((0.0, 0.0006))]
    mu = table.top_check(top, {"cell": line}, ["cell"], "paper")["checks"]["cell"]["mu"]
    assert mu["paper_cell"] == pytest.approx(0.3873)
    assert mu["paper_cell_se"] == pytest.approx(0.003 / np.sqrt(2))
    apart = [{**_summary(f"paper{k}", 0.387 + d, se=0.003), "name": "theta180"} for k, d in enumerate((0.0, 0.02))]
    wide = table.top_check(apart, {"cell": line}, ["cell"], "paper")["checks"]["cell"]["mu"]
    assert wide["paper_cell_se"] == pytest.approx(0.01)  # their scatter, where it is the larger


def test_the_top_rungs_95_percent_verdict_covers_the_truth_about_95_percent_of_the_time():
    """Coverage of the check on synthetic ladders of known truth: the paper cell on the extrapolated line."""
    rng = np.random.default_rng(11)
    truth = lambda gap: 0.45 - 0.5 / gap  # noqa: E731
    ref_sd = {"mu": 0.01}
    inside = []
    for _ in range(400):
        entries = _cell_entries(rng, truth)
        line = table.extrapolate(entries, 180.0, ["gap_d", "width_d"], "inverse", 17.0, ref_sd, ("mu",))
        check = table.top_check(_top(rng, truth(17.0), 3), {"cell": line}, ["cell"], "paper")
        inside.append(check["checks"]["cell"]["mu"]["within_95"])
    assert 0.90 <= np.mean(inside) <= 0.99, np.mean(inside)


def test_the_top_rung_reads_the_paper_presets_data_set_at_its_angles_every_seed(tmp_path):
    from pipeline import spec as run_spec
    from tests.helpers import synthetic_file

    i = {"inertial_number": 0.001}
    for theta, overrides in ((180.0, i), (90.0, i), (60.0, i), (180.0, {**i, "seed": 2}),
                             (180.0, {"inertial_number": 0.002})):
        folder = tmp_path / run_spec.run_folder("paper", "lammps", overrides) / "dem"
        folder.mkdir(parents=True, exist_ok=True)
        synthetic_file(folder, theta=theta, name=f"theta{int(theta):03d}", n_cycles=1, preset="paper",
                       engine="lammps", overrides=overrides)
    spec = {**ladder.load(), "top": {"preset": "paper", "thetas": [180.0, 90.0], "checks": ["cell"]}}
    label, paths = ladder.top_runs(spec, roots=(tmp_path,))
    assert label == "paper (lammps, inertial_number=0.001)"
    first, second = run_spec.run_folder("paper", "lammps", i), run_spec.run_folder("paper", "lammps", {**i, "seed": 2})
    assert sorted((p.parts[-3], p.stem) for p in paths) == sorted([(first, "theta180"), (first, "theta090"),
                                                                  (second, "theta180")])
    assert ladder.top_runs({**spec, "top": {}}, roots=(tmp_path,)) == ("", [])


def test_one_top_runs_fitted_parameter_is_checked_on_its_own_fits_error():
    rng = np.random.default_rng(8)
    entries = _cell_entries(rng, lambda gap: 0.45 - 0.5 / gap)
    for _, _, s in entries:
        s["fit"]["values"]["C"] += rng.normal(0, 0.3)
    cell = {"cell": {"keys": ["gap_d", "width_d"], "transform": "inverse", "paper": 17.0}}
    one = _top(rng, 0.42, 1)
    one[0]["fit"]["standard_errors"] = {"C": 0.1}
    c = table.build(entries, extrapolations=cell, top=("paper", one, ["cell"]))["top"]["180"]["checks"]["cell"]["C"]
    assert c["paper_cell_se"] == 0.1 and c["critical"] == pytest.approx(1.96, abs=0.01) and c["within_95"]
