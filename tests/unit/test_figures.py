"""`make compare` and `make figures`: the comparison files, then headless figures and the report that only read them."""

import dataclasses
import json
import re
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

import model
from pipeline import schema
from pipeline.calibration.calibrate import fit
from pipeline.comparison.compare import compare, fitted_in
from pipeline.comparison.metrics import along as metrics_along
from pipeline.comparison.metrics import memory_curves
from pipeline.dataset.derived import PAPER_DEFINITIONS, Definitions
from pipeline.dataset.smoothing import relaxation_strain
from pipeline.figures.draw import draw
from pipeline.io import read_params, write_params
from tests.helpers import fit_row, fit_summary, module_main, synthetic_run

main = module_main("pipeline.figures")


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("compare")
    rev = synthetic_run(tmp, name="theta180", n_cycles=2, noise=0.005, seed=1)
    other = synthetic_run(tmp, theta=60.0, name="theta060", n_cycles=2, noise=0.005, seed=2)
    (tmp / "seed3").mkdir()
    rev3 = synthetic_run(tmp / "seed3", name="theta180", n_cycles=2, noise=0.005, seed=3)
    fit([rev], tmp / "fit", cross_runs=[other])
    sets = {"Table 2": model.Params(), "our fit": read_params(tmp / "fit" / "params.json")}
    made_from = schema.MadeFrom.of([tmp / "fit" / "params.json", rev.path, other.path, rev3.path],
                                   {"fit": schema.read_fit(tmp / "fit" / "fit.json").made_from.digest()})
    metrics = compare([rev, other], sets, tmp / "fit" / "fit.h5", tmp / "compare", "synthetic", other_seeds=(rev3,),
                      made_from=made_from)
    return tmp, metrics


def test_comparison_writes_predictions_and_metrics(compared):
    tmp, metrics = compared
    assert json.loads((tmp / "compare" / "metrics.json").read_text())["preset"] == "synthetic"
    with h5py.File(tmp / "compare" / "compare.h5") as f:
        g = f["runs/00"]
        assert set(g["model"]) == {"Table 2", "our fit"}
        assert g["model/Table 2/A"].shape == (280, 3, 3) and g["dem/A"].shape == (281, 3, 3)
        assert "reversal" in f and f["reversal/00/backstress12"].shape == f["reversal/00/A12"].shape
        # the memory's curves: theta060's two turns, each starting at 1 (the old direction's whole part)
        memory = [f["memory"][k] for k in f["memory"]]
        assert [(m.attrs["run"], m.attrs["segment"]) for m in memory] == [
            ("theta060", "after the turn to theta"), ("theta060", "after the turn back")]
        for m in memory:
            assert m["dem"].shape == m["dem_sem"].shape == m["strain_after"].shape
            assert abs(m["model/Table 2/fraction"][0] - 1) < 0.05 and abs(m["dem"][0] - 1) < 0.2
    # the model with the true parameters fits the synthetic data to the noise: small normalised errors
    row = next(e for e in metrics.errors.rows if e.run == "theta180" and e.parameters == "Table 2")
    assert max(row.errors[k] for k in ("A12", "A32", "tau12", "tau32")) < 0.15
    # model data made with c1 = -C and Phi below Phi_c + c3 satisfy Eq. 19
    assert metrics.second_law.holds


def test_a_protocol_at_several_seeds_has_its_errors_over_the_seeds_and_an_overshoot_row_per_seed(compared):
    """A protocol run at two seeds: each parameter set's error has its mean, least and largest over the seeds;
    the first seed's own row is one end of the range; a protocol at one seed has no spread. The overshoot has a row
    per seed, the other seed's right after the first's."""
    _, metrics = compared
    spread = {(r.run, r.parameters): r for r in metrics.errors.seed_spread}
    assert set(spread) == {("theta180", "Table 2"), ("theta180", "our fit")}
    for (run, label), r in spread.items():
        assert r.seeds == [1, 3]
        first = next(e for e in metrics.errors.rows if e.run == run and e.parameters == label)
        for k in ("A12", "A32", "tau12", "tau32"):
            v = r.errors[k]
            assert v.least < v.mean < v.largest and first.errors[k] in (v.least, v.largest), (label, k)
    # the overshoot: a row per seed, each seed's beside the first's, each its own measure
    order = [(r.run, r.seed, r.segment) for r in metrics.after_changes.overshoot]
    assert order == [("theta180", 1, "after the turn to theta"), ("theta180", 3, "after the turn to theta"),
                     ("theta180", 1, "after the turn back"), ("theta180", 3, "after the turn back"),
                     ("theta060", 2, "after the turn to theta"), ("theta060", 2, "after the turn back")]
    assert metrics.after_changes.overshoot[0].A.dem != metrics.after_changes.overshoot[1].A.dem


def test_the_cycle_figure_draws_a_protocols_other_seeds_beside_its_first(compared, monkeypatch):
    """compare.h5 keeps the other seed's cycle mean of the reversal (none for theta060, run at one seed); Figs. 5-7
    draw it in each of that row's panels, say the seeds in its title, and name it in the legend even when the row
    is not the first."""
    from pipeline.figures import cycles

    tmp, _ = compared
    drawn = []
    monkeypatch.setattr(cycles, "save", lambda fig, out: drawn.append(fig) or out)
    with h5py.File(tmp / "compare" / "compare.h5") as f:
        rev, other = f["runs/00"], f["runs/01"]
        assert list(rev["other_seeds"]) == ["3"] and "other_seeds" not in other
        assert rev["other_seeds/3/A"].shape == rev["dem/A"].shape
        cycles.plot([other, rev], tmp / "cycles.png", "test")
    axes = drawn[0].axes
    for k, ax in enumerate(axes):
        others = [line for line in ax.lines if line.get_color() == "C9"]
        assert len(others) == (1 if k >= 4 else 0), k  # the second row's four panels
    assert axes[4].get_title(loc="left").endswith("2 seeds") and "seeds" not in axes[0].get_title(loc="left")
    assert "DEM, other seeds" in [t.get_text() for t in axes[3].get_legend().get_texts()]


def test_the_memory_of_a_turn_at_two_seeds_has_a_row_and_a_curve_per_seed(tmp_path, monkeypatch):
    """A turn run at two seeds: the memory table has the other seed's rows right after the first's; compare.h5
    keeps both seeds' curves, and memory.png draws the other seed's as thin lines in the run's panel, whose title
    counts the seeds and whose legend names them."""
    from pipeline.figures import memory

    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    first = synthetic_run(tmp_path / "a", theta=60.0, name="theta060", n_cycles=2, noise=0.005, seed=1)
    second = synthetic_run(tmp_path / "b", theta=60.0, name="theta060", n_cycles=2, noise=0.005, seed=2)
    sets = {"Table 2": model.Params(), "our fit": model.Params()}
    metrics = compare([first], sets, None, tmp_path / "compare", "synthetic", other_seeds=(second,),
                      made_from=schema.MadeFrom.of([first.path, second.path], {}))
    assert [(r.seed, r.segment) for r in metrics.after_changes.memory] == [
        (1, "after the turn to theta"), (2, "after the turn to theta"), (1, "after the turn back"),
        (2, "after the turn back")]
    drawn = []
    monkeypatch.setattr(memory, "save", lambda fig, out: drawn.append(fig) or out)
    with h5py.File(tmp_path / "compare" / "compare.h5") as f:
        groups = [f["memory"][k] for k in f["memory"]]
        assert [g.attrs["seed"] for g in groups] == [1, 1, 2, 2]
        memory.plot(groups, list(sets), tmp_path / "memory.png", "test")
    ax = drawn[0].axes[0]
    assert sum(line.get_label() == "DEM, other seeds" for line in ax.lines) == 2  # both turns of seed 2
    assert ax.get_title().endswith("2 seeds")
    assert "DEM, other seeds" in [t.get_text() for t in ax.get_legend().get_texts()]


def test_the_overshoot_of_model_made_runs_is_the_models_and_the_model_arrives_from_below(compared):
    """Runs made by the model with Table 2's parameters: the DEM's overshoot measure (the component along the
    new direction, early minus steady, from the cycles) is the model's own by the same measure on its cycle,
    after both changes of each run; the model approaches its steady value from below (negative)."""
    _, metrics = compared
    rows = {(r.run, r.segment): r for r in metrics.after_changes.overshoot}
    assert set(rows) == {(run, seg) for run in ("theta180", "theta060")
                         for seg in ("after the turn to theta", "after the turn back")}
    for r in rows.values():
        for v in (r.A, r.tau):
            assert v.model["Table 2"] < 0 and v.steady > 0, r
            assert abs(v.dem - v.model["Table 2"]) < 3 * v.dem_se + 0.002, r
    assert rows[("theta180", "after the turn to theta")].tau.model["Table 2"] < -0.02  # slow after a reversal
    X = np.zeros((3, 3))
    X[0, 1], X[2, 1] = -0.05, 0.02
    assert metrics_along(X, 0.0) == -0.05 and metrics_along(X, 90.0) == pytest.approx(0.02)
    assert metrics_along(X, 180.0) == pytest.approx(0.05)


def test_the_memory_of_model_made_runs_is_the_models_and_fades(compared):
    """Runs made by the model with Table 2's parameters: the DEM's memory of the old direction (the fabric's part
    normal to the new direction, as a fraction of the old steady fabric's) is the model's own by the same measure,
    after both turns at 60 degrees; it fades from near 1/3 to a few per cent; the reversal has no such part."""
    _, metrics = compared
    rows = {(r.run, r.segment): r for r in metrics.after_changes.memory}
    assert set(rows) == {("theta060", "after the turn to theta"), ("theta060", "after the turn back")}
    for r in rows.values():
        model_left = r.model["Table 2"]
        assert 0.2 < model_left[0] < 0.5 and model_left[0] > model_left[1] > model_left[2] > 0, r
        for dem, se, mod in zip(r.dem, r.dem_se, model_left, strict=True):
            assert abs(dem - mod) < 3 * se + 0.02, r


def test_the_memory_skips_a_change_from_a_segment_too_short_to_be_steady(tmp_path):
    """Fig. 7's protocol (the turn at 0.1): before the turn to theta the old segment, 0.1 long, has no steady end
    to measure the memory against, and after the turn back the new one is too short to follow it."""
    run = synthetic_run(tmp_path, theta=90.0, name="theta090", n_cycles=2)
    fig7 = SimpleNamespace(spec=dataclasses.replace(run.spec, rotate_at_strain=0.1), series=run.series, path=run.path)
    assert memory_curves(fig7, {}) == []
    assert [r["segment"] for r in memory_curves(run, {})] == ["after the turn to theta", "after the turn back"]


def test_figures_and_report_only_read_the_files(compared, tmp_path):
    tmp, _ = compared
    made = draw(tmp / "compare", tmp / "fit", tmp_path)
    for name in ("fig3_fabric_law", "fig4_flow_rule", "fig5_6_cycles", "fig8_backstress", "fig9_work_rates",
                 "memory"):
        png = tmp_path / "figures" / f"{name}.png"
        assert png in made and png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG", name
    report = (tmp_path / "report.md").read_text()
    assert "| C |" in report and "| theta060 | our fit |" in report and "share of the backstress" in report
    assert "relaxation strain after the reversal" in report and "(holds)" in report
    assert "| e-folds | a1 | b1 | a2 | b2 |" in report  # the stepwise calibration's sensitivity
    assert "## Overshoot after a change of direction" in report
    assert "## Memory of the old direction after a change" in report and "| theta060 (" in report
    assert "| theta060 (2 cycles) | after the turn back |" in report
    assert "### Over seeds" in report and "| theta180 | 1, 3 | Table 2 |" in report
    # the overshoot has a row per seed, each named by its seed where the run has several
    assert "| theta180, seed 1 (2 cycles) | after the turn to theta |" in report
    assert "| theta180, seed 3 (2 cycles) | after the turn to theta |" in report
    assert "2 DEM run(s) compared, one per protocol (their other seeds" in report
    assert "The fit took 2 run(s)" in report and "each run counted once." in report


@pytest.mark.slow  # draws every figure again (test_figures_and_report_only_read_the_files draws them fast)
def test_another_comparisons_figures_go_beside_it_not_over_the_data_sets(compared):
    """``--compare DIR`` without ``--out`` (another seed's comparison, say) draws into DIR."""
    tmp, _ = compared
    assert main(["--preset", "tiny", "--compare", str(tmp / "compare"), "--fit", str(tmp / "fit")]) == 0
    assert (tmp / "compare" / "report.md").exists() and (tmp / "compare" / "figures" / "fig4_flow_rule.png").exists()


def test_missing_inputs_are_one_line_errors(tmp_path, capsys):
    assert main(["--preset", "no-such-preset", "--out", str(tmp_path)]) == 2
    assert "unknown preset 'no-such-preset'" in capsys.readouterr().err
    assert main(["--preset", "tiny", "--set", "friction_deg=33", "--out", str(tmp_path)]) == 2
    assert "metrics.json not found: run `make compare`" in capsys.readouterr().err
    assert main(["--preset", "../../etc"]) == 2
    assert "preset '../../etc' is not a valid name" in capsys.readouterr().err


def test_parameters_are_compared_in_the_definitions_they_were_fitted_in(compared, tmp_path):
    tmp, _ = compared
    fit_json = json.loads((tmp / "fit" / "fit.json").read_text())
    assert fitted_in(tmp / "fit" / "params.json") == Definitions(**fit_json["options"]["definitions"])
    mine = Definitions(strain="bulk", phi="central", pressure="wall")  # e.g. a row of make fit-from, alone
    write_params(tmp_path / "row.json", model.Params(), {"definitions": dataclasses.asdict(mine)})
    assert fitted_in(tmp_path / "row.json") == mine
    write_params(tmp_path / "mine.json", model.Params())  # no metadata: the paper's, as Table 2's
    assert fitted_in(tmp_path / "mine.json") == PAPER_DEFINITIONS


def test_a_row_alone_takes_the_smoothed_reversals_of_its_data_sets_fit_in_the_same_definitions(compared, tmp_path,
                                                                                                 monkeypatch):
    from pipeline.comparison import compare as comparison

    tmp, _ = compared
    monkeypatch.setattr(comparison, "preset_output", lambda folder, *parts: tmp.joinpath(*parts))
    ours = fitted_in(tmp / "fit" / "params.json")
    row = tmp_path / "fit_from" / "row.json"
    row.parent.mkdir()
    write_params(row, model.Params(), {"definitions": dataclasses.asdict(ours)})
    assert comparison.smoothed_reversals(row, "data set", ours) == tmp / "fit" / "fit.h5"
    assert comparison.smoothed_reversals(tmp / "fit" / "params.json", "data set", ours) == tmp / "fit" / "fit.h5"
    other = dataclasses.replace(ours, pressure="wall" if ours.pressure == "target" else "target")
    assert comparison.smoothed_reversals(row, "data set", other) is None


def test_relaxation_strain_of_an_exponential():
    strain = np.arange(0, 0.7, 0.005)
    x = 1 - np.exp(-strain / 0.15)  # within 5 % after 0.15 ln 20 = 0.449
    assert relaxation_strain(strain, x) == pytest.approx(0.15 * np.log(20), rel=1e-6)
    # noise as large as a tenth of the change moves it by a few per cent, not to the window's end
    noisy = x + np.random.default_rng(1).normal(0, 0.1, x.size)
    assert relaxation_strain(strain, noisy) == pytest.approx(0.15 * np.log(20), rel=0.15)
    assert np.isnan(relaxation_strain(strain, np.random.default_rng(2).normal(0, 1, x.size)))


@pytest.mark.slow
def test_the_profile_figure_is_drawn_from_profiles_json_of_the_same_fit_only(compared, tmp_path):
    tmp, _ = compared
    fit_dir = tmp_path / "fit"
    fit_dir.mkdir()
    for name in ("fit.json", "fit.h5"):
        (fit_dir / name).write_bytes((tmp / "fit" / name).read_bytes())
    g = json.loads((fit_dir / "fit.json").read_text())["global"]["estimates"]

    def profile(best):
        grid = best + np.linspace(-0.4, 0.4, 5)
        return {"best": best, "standard_error": 0.1, "noise_factor": 4.0, "grid": grid.tolist(),
                "chi2_rise": ((grid - best) ** 2 * 400).tolist(), "intervals": {"68": [best - 0.05, best + 0.05],
                                                                                 "95": [best - 0.1, best + 0.1]}}

    png = tmp_path / "out" / "figures" / "profiles.png"
    stale = {n: profile(v + 1.0) for n, v in zip(g["free"], g["values"], strict=True)}
    (fit_dir / "profiles.json").write_text(json.dumps({"misfit": 1.0, "levels": {"68": 1, "95": 3.84},
                                                       "parameters": stale}))
    assert png not in draw(tmp / "compare", fit_dir, tmp_path / "out")
    same = {n: profile(v) for n, v in zip(g["free"], g["values"], strict=True)}
    (fit_dir / "profiles.json").write_text(json.dumps({"misfit": 1.0, "levels": {"68": 1, "95": 3.84},
                                                       "parameters": same}))
    made = draw(tmp / "compare", fit_dir, tmp_path / "out")
    assert png in made and png.read_bytes()[:4] == b"\x89PNG"


def test_the_report_shows_the_fit_against_the_restart_in_standard_errors_from_table_2():
    from pipeline.figures.report import jump_lines

    paper = model.Params()
    row = fit_row(fit_from=0.005, params={**paper.to_dict(), "a1": -0.015},
                  standard_errors={n: 0.003 if n == "a1" else 1.0 for n in paper.to_dict()})
    lines = jump_lines([row, dataclasses.replace(row, persistence_exponent=0.5)], paper)
    assert len([x for x in lines if x.startswith("| 0.005")]) == 1  # k = 3/4 rows only
    assert "-0.015 (+2.0)" in lines[-1] and "+4.5%" in lines[-1]
    lines = jump_lines([dataclasses.replace(row, fit_from=0.002, runs=3), dataclasses.replace(row, runs=17)], paper)
    assert lines[-2].startswith("| 0.002 | 3 |") and lines[-1].startswith("| 0.005 | 17 |")


def test_the_report_says_how_new_runs_join_the_fit():
    from pipeline.figures.report import next_runs_lines
    from pipeline.schema import CandidateRun

    ranked = CandidateRun("another seed at theta = 120", 120.0, 0.7, cpu_hours=5.6, weakest_before=0.14,
                          weakest_after=0.11, worst_relative_se_after=0.11)
    per_run = next_runs_lines(fit_summary(next_runs=[ranked, CandidateRun("x", 30.0, 0.7, "fails")]))
    assert per_run[-1] == "| another seed at theta = 120 | 0.11 | 0.11 | 5.60 |" and len(per_run) == 8
    assert per_run[3].endswith("each counting once.")
    per_angle = next_runs_lines(fit_summary(weight="angles", next_runs=[ranked]))
    assert per_angle[3].endswith("another seed of an angle shares that angle's weight.")
    assert next_runs_lines(fit_summary(next_runs=[])) == []
    failed = next_runs_lines(fit_summary(next_runs=[CandidateRun("another seed at theta = 30", 30.0, 0.7,
                                                                 "dop853: too many steps")]))
    assert failed[-1].startswith("None can be told: no candidate can be weighed at the best fit")
    assert "another seed at theta = 30: dop853: too many steps" in failed[-1]


def test_the_report_takes_the_fits_past_the_jump_only_of_the_fits_weighting():
    from pipeline.figures.report import same_weighting

    rows = [fit_row(fit_from=0.005, weight="angles"), fit_row(fit_from=0.0, weight="angles")]
    angles, runs = fit_summary(weight="angles"), fit_summary(weight="runs")
    assert same_weighting(rows, angles) and not same_weighting(rows, runs)
    assert same_weighting([fit_row(fit_from=0.005)], runs) and not same_weighting([fit_row(fit_from=0.005)], angles)


def test_atomic_writes_leave_files_as_readable_as_a_plain_write(tmp_path):
    """The temporary each atomic write renames into place has the permissions a plain ``open`` would give (the
    umask's), not ``mkstemp``'s owner-only ones: results on a shared disk stay readable by the group."""
    import os

    from pipeline import io

    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    written = io.write_text(tmp_path / "atomic.txt", "x")
    assert os.stat(written).st_mode & 0o777 == os.stat(plain).st_mode & 0o777


def test_the_flow_rule_figure_gives_each_angle_one_colour_and_one_legend_entry_however_many_seeds(tmp_path,
                                                                                                 monkeypatch):
    from pipeline.figures import laws

    with h5py.File(tmp_path / "fit.h5", "w") as f:
        for k, theta in enumerate((120.0, 120.0, 150.0)):
            g = f.create_group(f"cross_check/{k:02d}")
            g.attrs["theta_deg"] = theta
            for key in ("S", "C", "Y"):
                g.create_dataset(key, data=np.linspace(0.01, 0.2, 5))
        for k in range(3):
            for key in ("S", "Y"):
                f.create_dataset(f"reversal/{k:02d}/{key}", data=np.linspace(0.01, 0.2, 5))
    drawn = []
    monkeypatch.setattr(laws, "save", lambda fig, out: drawn.append(fig) or out)
    laws.flow_rule(tmp_path / "fit.h5", model.Params(), model.Params(), tmp_path / "fig4.png")
    left, right = drawn[0].axes
    labels = right.get_legend_handles_labels()[1]
    assert labels.count("θ = 120°") == 1 and labels.count("θ = 150°") == 1
    assert labels.count("reversal (Eq. 16)") == 1
    seed1, seed2, other = (line.get_color() for line in left.lines[:3])
    assert seed1 == seed2 != other
    ours = next(line.get_color() for line in left.lines if line.get_label() == "our fit")
    assert ours not in (seed1, other)  # our fit's colour is no angle's


def test_the_fabric_law_figure_draws_every_reversal_seed_into_one_inset_per_panel(tmp_path, monkeypatch):
    from pipeline.figures import laws

    S = np.linspace(0.01, 0.2, 5)
    with h5py.File(tmp_path / "fit.h5", "w") as f:
        for k in range(3):
            for key in ("S", "alpha1", "beta1", "alpha2", "beta2"):
                f.create_dataset(f"reversal/{k:02d}/{key}", data=S if key == "S" else -S - k)
    drawn = []
    monkeypatch.setattr(laws, "save", lambda fig, out: drawn.append(fig) or out)
    laws.fabric_law(tmp_path / "fit.h5", model.Params(), model.Params(), tmp_path / "fig3.png")
    for panel in drawn[0].axes[:2]:  # the top row, alpha_1 and alpha_2
        insets = panel.child_axes
        assert len(insets) == 1 and len(insets[0].lines) == 3 + 1  # three seeds and our fit's line


def test_the_backstress_figure_names_each_part_once_however_many_reversal_seeds(tmp_path, monkeypatch):
    from pipeline.figures import reversal

    x = np.linspace(0.7, 1.4, 8)
    parts = [{"strain": x, "backstress12": -x, "isotropic12": x - k, "tau12": x + k, "A12": -x / 10}
             for k in range(3)]
    drawn = []
    monkeypatch.setattr(reversal, "save", lambda fig, out: drawn.append(fig) or out)
    reversal.backstress_figure(parts, -5.0, tmp_path / "fig8.png")
    left = drawn[0].axes[0]
    assert len(left.lines) == 9 and len(left.get_legend_handles_labels()[1]) == 3


def test_the_report_names_the_fitted_law_and_prints_every_parameter_it_owns():
    """A fit of the "jump" law shows the law and its k (jump_fabric) beside Eq. 13's nine; Table 2 has none."""
    import model
    from pipeline.figures.report import law_sentence, parameter_lines

    fitted = model.Params(variant="jump", jump_fabric=-0.0143, C=-6.1)
    lines = parameter_lines(fitted, model.PAPER, None)
    rows = {line.split("|")[1].strip(): line for line in lines[2:]}
    assert list(rows) == ["C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c", "jump_fabric"]
    assert "-0.0143" in rows["jump_fabric"] and rows["jump_fabric"].rstrip().endswith("– |")
    assert "`jump`" in law_sentence(fitted) and "`jump_fabric`" in law_sentence(fitted)
    assert "Eq. 13 as written" in law_sentence(model.PAPER)


@pytest.mark.slow  # fits and checks of several seconds each
def test_a_product_whose_inputs_changed_or_that_mixes_two_fits_is_refused(tmp_path):
    """Every stage that reads a product checks what made it, whatever the file times say: a params.json edited by
    hand, one from another fit beside this fit.json, a fit whose run changed or is gone, and a comparison whose
    parameters changed since, are each refused in one line."""
    import json
    import shutil

    from pipeline.errors import PipelineError
    from pipeline.figures.draw import draw

    rev = synthetic_run(tmp_path, name="theta180", n_cycles=2, noise=0.005, seed=1)
    fit([rev], tmp_path / "fit")
    params = tmp_path / "fit" / "params.json"
    schema.check_fitted(params)  # as made: believed
    kept = params.read_text()
    edited = json.loads(kept)
    edited["C"], edited["c1"] = -4.0, 4.0  # Eq. 19 holds: the check that refuses is the fit's own
    params.write_text(json.dumps(edited))
    with pytest.raises(PipelineError, match="does not hold the parameters fit.json beside it fitted"):
        schema.check_fitted(params)
    params.write_text(kept)
    other = json.loads(kept)
    other["metadata"]["made_from"] = "0" * 64  # another fit's parameters, the values alike
    params.write_text(json.dumps(other))
    with pytest.raises(PipelineError, match="come from two fits"):
        schema.check_fitted(params)
    params.write_text(kept)
    shutil.copy(rev.path, tmp_path / "kept.h5")
    rev.path.write_bytes(rev.path.read_bytes()[:-1] + b"\1")  # the run changed since the fit
    with pytest.raises(PipelineError, match="was fitted on runs that have changed or gone since"):
        schema.check_fitted(params)
    rev.path.unlink()  # gone: a results/ copy deleted, the committed file underneath older
    with pytest.raises(PipelineError, match="changed or gone since"):
        schema.check_fitted(params)
    shutil.copy(tmp_path / "kept.h5", rev.path)
    schema.check_fitted(params)
    sets = {"Table 2": model.Params(), "our fit": read_params(params)}
    compare([rev], sets, None, tmp_path / "compare", "synthetic", made_from=schema.MadeFrom.of(
        [params, rev.path], {"fit": schema.read_fit(tmp_path / "fit" / "fit.json").made_from.digest()}))
    edited["C"], edited["c1"] = -4.5, 4.5
    params.write_text(json.dumps(edited))  # a new fit after the comparison, which the figures would draw beside it
    with pytest.raises(PipelineError, match="compared files that have changed or gone since .*params.json"):
        draw(tmp_path / "compare", tmp_path / "fit", tmp_path / "out")


@pytest.mark.slow  # fits and checks of several seconds each
def test_a_fit_copied_from_another_fit_is_refused_by_the_figures_in_one_line(compared, tmp_path):
    """fit.json or fit.h5 of another fit beside the compared one (another data set's, copied in): the figures name
    the foreign file and what remakes it; the same files, untouched, draw."""
    import shutil

    from pipeline.errors import PipelineError
    from pipeline.figures.draw import check_fit_belongs

    tmp, metrics = compared
    ours = schema.read_fit(tmp / "fit" / "fit.json")
    check_fit_belongs(ours, tmp / "fit", metrics.made_from)
    rev = synthetic_run(tmp_path, name="theta180", n_cycles=2, noise=0.01, seed=7)
    fit([rev], tmp_path / "other", data_set={"data_set": "another", "skip_cycles": 0})
    theirs = schema.read_fit(tmp_path / "other" / "fit.json")
    with pytest.raises(PipelineError, match="fit.json is not the fit .* comparison read"):
        check_fit_belongs(theirs, tmp / "fit", metrics.made_from)
    mixed = tmp_path / "mixed"
    shutil.copytree(tmp / "fit", mixed)
    shutil.copy(tmp_path / "other" / "fit.h5", mixed / "fit.h5")
    with pytest.raises(PipelineError, match="fit.h5 is not the fit.json beside it's"):
        check_fit_belongs(ours, mixed, metrics.made_from)


@pytest.mark.parametrize("recorded, expected, said", [
    ({"data_set": "reduced-lammps", "skip_cycles": 0}, {"data_set": "reduced", "skip_cycles": 0},
     "was made for data_set='reduced-lammps', not 'reduced'"),
    ({"data_set": "reduced", "skip_cycles": 1}, {"data_set": "reduced", "skip_cycles": 0},
     "was made for skip_cycles=1, not 0"),
    ({}, {"data_set": "reduced"}, "was made for data_set='(not recorded)'"),
])
def test_a_product_of_another_data_set_or_cycles_is_refused_naming_what_remakes_it(recorded, expected, said):
    from pipeline.errors import PipelineError

    with pytest.raises(PipelineError, match=re.escape(said) + ".*`make fit PRESET=reduced` remakes it"):
        schema.MadeFrom({}, recorded).require_same("results/reduced/fit/fit.json", expected, "fit PRESET=reduced")


def test_a_compare_h5_of_another_comparison_beside_metrics_json_is_refused(compared, tmp_path):
    import shutil

    from pipeline.errors import PipelineError
    from pipeline.figures.draw import draw

    tmp, metrics = compared
    mixed = tmp_path / "compare"
    shutil.copytree(tmp / "compare", mixed)
    with h5py.File(mixed / "compare.h5", "r+") as f:  # as another comparison of the same runs writes it
        f.attrs["made_from"] = "0" * 64
    with pytest.raises(PipelineError, match="compare.h5 is not the metrics.json beside it's"):
        draw(mixed, tmp / "fit", tmp_path / "out")
