"""`python -m pipeline.calibration` (`make fit`): the stepwise and global calibration on synthetic runs."""

import dataclasses
import json
import re

import numpy as np
import pytest

import model
from pipeline.calibration import global_fit
from pipeline.calibration.calibrate import fit
from pipeline.calibration.fit_cycle import FitCycle
from pipeline.calibration.stepwise import dilatancy_estimate
from pipeline.dataset import lookup
from pipeline.dataset.derived import Definitions, cycle_D_dev
from pipeline.dataset.selection import DataSet
from pipeline.errors import CalibrationError, PipelineError
from pipeline.io import read_params
from pipeline.schema import OwnReversal, read_fit
from pipeline.spec import resolve, run_folder
from tests.helpers import RUNS_AWAY, fit_row, fit_summary, module_main, synthetic_file, synthetic_run

fit_main = module_main("pipeline.calibration")

TRUE = model.Params()


@pytest.mark.slow
def test_noise_free_reversal_gives_the_fabric_law_and_eq15s_known_bias(tmp_path):
    path = synthetic_file(tmp_path, n_cycles=2)
    assert fit_main(["--runs", str(path), "--out", str(tmp_path / "fit")]) == 0
    report = read_fit(tmp_path / "fit" / "fit.json")
    est = {k: v.value for k, v in report.stepwise.estimates.items()}
    # the fabric law (Eqs. 9, 12, 13) from the smoothed Jaumann rate
    assert est["b1"] == pytest.approx(TRUE.b1, rel=0.02) and est["b2"] == pytest.approx(TRUE.b2, rel=0.02)
    assert est["a1"] == pytest.approx(TRUE.a1, rel=0.05) and est["a2"] == pytest.approx(TRUE.a2, rel=0.15)
    # Eq. 15 measures C - 2m near steady state after a reversal (smoothing moves it by < 0.1)
    assert est["C_eq15"] == pytest.approx(TRUE.C - 2 * TRUE.m, abs=0.1)
    stepwise = read_params(tmp_path / "fit" / "params_stepwise.json")
    assert stepwise.C == pytest.approx(est["C_eq15"]) and stepwise.c1 == -stepwise.C  # Eq. 19
    # the global refinement of the same run recovers the flow rule that Eq. 15 misses
    refined = read_params(tmp_path / "fit" / "params.json")
    for name in ("C", "n", "m", "b1", "b2"):
        assert getattr(refined, name) == pytest.approx(getattr(TRUE, name), rel=0.02), name
    assert refined.c1 == -refined.C
    # on noise-free data the fabric law does not hinge on the smoothing window
    for window, values in report.stepwise.sensitivity.smoothing_window.items():
        assert values["b2"] == pytest.approx(TRUE.b2, rel=0.02), window


@pytest.mark.slow
def test_several_seeds_give_a_mean_and_its_standard_error(tmp_path):
    runs = [synthetic_run(tmp_path, name=f"s{seed}", n_cycles=2, noise=0.002, seed=seed) for seed in range(3)]
    report = fit(runs, tmp_path / "fit")
    b2 = report.stepwise.estimates["b2"]
    assert len(b2.per_run) == 3 and len(report.stepwise.runs) == 3
    assert b2.standard_error == pytest.approx(np.std(b2.per_run, ddof=1) / np.sqrt(3))


def test_bad_inputs_are_one_line_errors(tmp_path, capsys):
    assert fit_main(["--preset", "no-such-preset", "--out", str(tmp_path / "fit")]) == 2
    assert "unknown preset 'no-such-preset'" in capsys.readouterr().err
    assert fit_main(["--preset", "tiny", "--set", "friction_deg=33", "--out", str(tmp_path / "fit")]) == 2
    assert "no reversal run of tiny (yade, friction_deg=33)" in capsys.readouterr().err
    path = synthetic_file(tmp_path, theta=90.0, n_cycles=1)
    assert fit_main(["--runs", str(path), "--out", str(tmp_path / "fit")]) == 2
    assert "not a reversal run: " in capsys.readouterr().err
    assert fit_main(["--runs", str(tmp_path / "missing.h5")]) == 2
    assert "cannot open" in capsys.readouterr().err
    assert fit_main(["--window", "-1"]) == 2
    assert not (tmp_path / "fit").exists()


def test_sec33_cross_check_on_other_angles_finds_constant_C(tmp_path):
    reversal = synthetic_run(tmp_path, name="rev", n_cycles=1)
    angles = [synthetic_run(tmp_path, theta=t, name=f"t{int(t)}", n_cycles=1) for t in (60.0, 120.0)]
    report = fit([reversal], tmp_path / "fit", cross_runs=angles)
    for check in report.stepwise.cross_check:
        assert check.C_median == pytest.approx(TRUE.C, rel=0.02)
        assert check.m == pytest.approx(TRUE.m, abs=0.1) and check.n == pytest.approx(TRUE.n, abs=0.02)
    # one reversal of one cycle: nothing to take a stepwise error from, and none is claimed
    assert all(np.isnan(e.standard_error) and e.error_from is None for e in report.stepwise.estimates.values())


@pytest.mark.slow
def test_global_fit_on_noisy_angles_recovers_table_2_within_its_standard_errors(tmp_path):
    runs = [synthetic_run(tmp_path, theta=t, name=f"g{int(t)}", n_cycles=3, noise=0.01, seed=int(t))
            for t in (180.0, 30.0, 90.0, 150.0)]
    report = fit(runs[:1], tmp_path / "fit", cross_runs=runs[1:])
    g = report.global_fit.estimates
    assert g.success and 0.5 < g.misfit < 3  # white noise, measured from the cycles: misfit ~ 1
    for name, value, se in zip(g.free, g.values, g.standard_errors, strict=True):
        assert abs(value - getattr(TRUE, name)) < 3.5 * se, name
    d = report.dilatancy  # Eq. 18 on Phi with c1 = -C, noise 0.001 on Phi
    values = dict(zip(d.free, d.values, strict=True))
    assert values["phi_c"] == pytest.approx(TRUE.phi_c, abs=0.005)
    assert values["c2_coef"] == pytest.approx(TRUE.c2_coef, rel=0.15)
    assert read_params(tmp_path / "fit" / "params.json").phi_c == pytest.approx(values["phi_c"])
    corr = np.array(g.correlation)
    np.testing.assert_allclose(np.diag(corr), 1.0) and np.testing.assert_allclose(corr, corr.T)


def test_runs_are_found_in_results_first_then_in_the_reference_dataset(tmp_path):
    results, reference = tmp_path / "results", tmp_path / "reference"
    s2, f30 = run_folder("p", overrides={"seed": 2}), run_folder("p", overrides={"friction_deg": 30})
    seed2 = {"overrides": {"seed": 2}, "seed": 2}  # a run's spec holds its seed, its overrides what was set
    for root, folder, theta, kw in ((results, "p", 180.0, {"seed": 1}), (reference, "p", 180.0, {"seed": 1}),
                                    (reference, s2, 180.0, seed2),
                                    (reference, f30, 180.0, {"overrides": {"friction_deg": 30}, "seed": 1}),
                                    (reference, "p", 90.0, {"seed": 1}), (reference, s2, 90.0, seed2)):
        (root / folder / "dem").mkdir(parents=True, exist_ok=True)
        path = synthetic_file(root / folder / "dem", theta=theta, name=f"theta{int(theta):03d}", n_cycles=1,
                              preset="p", **kw)
        assert path.exists()
    roots = (results, reference)
    assert [r.path for r in lookup.reversal_seeds(DataSet("p"), roots)] == [results / "p/dem/theta180.h5",
                                                                   reference / s2 / "dem/theta180.h5"]
    angles = lookup.other_angles(lookup.preset_runs(DataSet("p"), roots))
    assert [r.path for r in angles] == [reference / "p/dem/theta090.h5"]
    # the fit takes every seed of every angle, the other overrides' runs apart
    assert [r.path for r in lookup.fit_runs(DataSet("p"), roots)] == [
        results / "p/dem/theta180.h5", reference / s2 / "dem/theta180.h5",
        reference / "p/dem/theta090.h5", reference / s2 / "dem/theta090.h5"]
    # one seed's runs, for `python -m pipeline.comparison --seed N`; a seed with no run names the seeds there are
    assert [r.path for r in lookup.runs_at_seed(DataSet("p"), 2, roots)] == [reference / s2 / "dem/theta090.h5",
                                                                          reference / s2 / "dem/theta180.h5"]
    # what the comparison of one seed's runs sets beside them: the other seeds' runs of the data set
    assert [r.path for r in lookup.other_seeds_of(DataSet("p"), lookup.preset_runs(DataSet("p"), roots), roots)] == [
        reference / s2 / "dem/theta090.h5", reference / s2 / "dem/theta180.h5"]
    with pytest.raises(PipelineError, match=r"seed=5: p \(yade\) has runs of seeds 1, 2 only"):
        lookup.runs_at_seed(DataSet("p"), 5, roots)
    # a writer's hidden temporary is not a run
    (results / "p/dem/.theta090.tmp123.h5").write_bytes(b"partial")
    assert [r.path for r in lookup.preset_runs(DataSet("p"), roots)] == [reference / "p/dem/theta090.h5",
                                                               results / "p/dem/theta180.h5"]


@pytest.mark.slow  # fits and checks of several seconds each
def test_own_reversal_runs_table_2_and_names_why_a_law_that_runs_away_fails():
    """``definitions.own_reversal``, the fit-from table's column: Table 2's own cycle keeps |A| at its steady value;
    a fabric law with a positive start rate cannot give a cycle, and the reason names the fabric."""
    from pipeline.calibration.definitions import own_reversal

    paper, away = own_reversal(model.Params()), own_reversal(RUNS_AWAY)
    assert paper.error is None and paper.peak_over_steady == pytest.approx(1.0, abs=0.01)
    assert away.peak_over_steady is None and away.start_rate > 0.01 and "the fabric grows" in away.error
    # a law whose fabric never leaves zero has no steady state to reverse from: said, not raised
    still = own_reversal(model.Params(a1=0.0, b1=0.0))
    assert still.start_rate is None and still.error.startswith("no steady state: ")
    from pipeline.calibration.restart import own_reversal_cell
    assert own_reversal_cell(still) == "no steady state"


@pytest.mark.slow  # reads the committed reduced data set's every run
def test_the_angles_option_keeps_every_run_at_those_angles_and_no_other():
    from pipeline.calibration.inputs import only_angles

    chosen = DataSet("reduced")
    reversals, cross = lookup.reversal_seeds(chosen), tuple(lookup.other_angles(lookup.preset_runs(chosen)))
    kept = only_angles([180.0, 90.0, 30.0], reversals, cross)
    assert {r.theta_deg for r in kept} == {90.0, 30.0}
    assert len(kept) == sum(r.theta_deg in (90.0, 30.0) for r in cross) and len(cross) > len(kept)


def test_each_engines_runs_are_found_apart():
    """A LAMMPS run sits in ``<preset>-lammps[-<hash>]/``, which the Yade lookup's ``<preset>-*`` variants also
    match: each engine's lookup keeps its own runs only."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        yade_seed2, lammps_seed2 = run_folder("p", "yade", {"seed": 2}), run_folder("p", "lammps", {"seed": 2})
        for folder, engine, kw in (("p", "yade", {}), (yade_seed2, "yade", {"overrides": {"seed": 2}}),
                                   ("p-lammps", "lammps", {}), (lammps_seed2, "lammps", {"overrides": {"seed": 2}})):
            (root / folder / "dem").mkdir(parents=True)
            synthetic_file(root / folder / "dem", name="theta180", n_cycles=1, preset="p", engine=engine, **kw)
        yade = lookup.reversal_seeds(DataSet("p"), (root,))
        lammps = lookup.reversal_seeds(DataSet("p", "lammps"), (root,))
        assert [r.path.parts[-3] for r in yade] == ["p", yade_seed2] and {r.engine for r in yade} == {"yade"}
        assert [r.path.parts[-3] for r in lammps] == ["p-lammps", lammps_seed2]
        assert [r.path.parts[-3] for r in lookup.preset_runs(DataSet("p", "lammps"), (root,))] == ["p-lammps"]
        with pytest.raises(PipelineError, match="engine='foo' is not a DEM engine"):
            lookup.reversal_seeds(DataSet("p", "foo"), (root,))


@pytest.mark.parametrize("damage, message", [
    ("dangling", "is a link that leads nowhere"),
    ("loop", "is a link that leads nowhere (or in a loop)"),
    ("other preset", "is a run of preset 'q' by its provenance, not of 'p': move it to results/q/dem/"),
])
def test_a_damaged_run_in_results_is_one_line_not_a_fallback_to_the_committed_one(tmp_path, damage, message):
    from pipeline.errors import PipelineError

    results, reference = tmp_path / "results", tmp_path / "reference"
    for root in (results, reference):
        (root / "p/dem").mkdir(parents=True)
    synthetic_file(reference / "p/dem", name="theta180", n_cycles=1, preset="p")
    target = results / "p/dem/theta180.h5"
    if damage == "dangling":
        target.symlink_to(tmp_path / "gone.h5")
    elif damage == "loop":
        target.symlink_to(results / "p/dem/other.h5")
        (results / "p/dem/other.h5").symlink_to(target)
    else:
        synthetic_file(results / "p/dem", name="theta180", n_cycles=1, preset="q")
    with pytest.raises(PipelineError, match=re.escape(message)):
        lookup.fit_runs(DataSet("p"), (results, reference))


@pytest.mark.slow
def test_make_fit_bootstrap_adds_the_noise_and_stepwise_bootstraps(tmp_path, capsys):
    from pipeline.calibration.stepwise import small_sample_factor
    from pipeline.calibration.text import print_report

    runs = [synthetic_run(tmp_path, theta=t, name=f"b{int(t)}", n_cycles=4, noise=0.01, seed=int(t) + 7)
            for t in (180.0, 90.0)]
    report = fit(runs[:1], tmp_path / "fit", cross_runs=runs[1:], bootstrap=12)
    boot, g = report.bootstrap, report.global_fit.estimates
    assert len(boot.replicates) == 12
    ratio = np.array(boot.standard_deviation) / np.array(g.standard_errors)
    assert np.all((ratio > 0.3) & (ratio < 3)), dict(zip(g.free, ratio, strict=True))
    # the stepwise calibration, bootstrapped over cycles: a spread, and an interval around its value
    step = boot.stepwise
    for key in ("C_eq15", "n", "m", "b1", "b2", "c2_coef", "phi_c"):
        i = step.free.index(key)
        assert 0 < step.standard_deviation[i] < np.inf, key
        assert step.percentile_2_5[i] <= report.stepwise.estimates[key].value <= step.percentile_97_5[i], key
    # one reversal: its stepwise errors are the spread over the resamplings of its cycles
    for key in ("C_eq15", "m", "phi_c"):
        e = report.stepwise.estimates[key]
        assert e.error_from == "cycle resamples"
        half_width = step.half_width_68[step.free.index(key)]
        assert e.standard_error == pytest.approx(half_width * small_sample_factor(4)) and half_width > 0, key
    print_report(report, tmp_path / "fit")
    out = capsys.readouterr().out
    assert "nan" not in out and "one run ± its error from resamplings of its cycles (docs/calibration.md)" in out
    assert re.search(r"stepwise route on the same resamplings, 95 %: .*phi_c \[\+0\.\d+, \+0\.\d+\]", out)


def test_bootstrap_needs_more_than_one_cycle(tmp_path, capsys):
    path = synthetic_file(tmp_path, n_cycles=1)
    assert fit_main(["--runs", str(path), "--out", str(tmp_path / "fit"), "--bootstrap", "3"]) == 2
    assert "needs runs with more than one cycle" in capsys.readouterr().err


def test_dilatancy_fit_at_a_bound_is_an_error(tmp_path):
    import dataclasses

    data = FitCycle.from_run(synthetic_run(tmp_path, n_cycles=1))
    too_loose = dataclasses.replace(data, phi=np.full_like(data.phi, 0.2))  # looser than any Phi_c in bounds
    with pytest.raises(CalibrationError, match=r"sits at a bound: (c2_coef|phi_c) = "):
        global_fit.refine_dilatancy([too_loose], TRUE)


def test_dilatancy_estimator_recovers_eq18_given_the_true_c1(tmp_path):
    run = synthetic_run(tmp_path, n_cycles=1)
    c = run.cycle
    strain, A, phi = c["strain"], c["A"], c["packing_fraction"]
    D = cycle_D_dev(run)
    c2_coef, phi_c = dilatancy_estimate(strain, phi, np.gradient(phi, strain), A, D,
                                        model.hardening_variable_stack(A, D), TRUE.c1, 1.0, 0.7)
    assert c2_coef == pytest.approx(TRUE.c2_coef, rel=0.01)
    assert phi_c == pytest.approx(TRUE.phi_c, abs=1e-3)


def test_the_strain_measure_option_recovers_the_truth_of_each_measure(tmp_path):
    """Runs made by the model in nominal strain, with a band shearing 1.3 x nominal: fitted in nominal strain
    the fabric law is the truth; in bulk strain its rates (a_i, b_i) are 1.3 x smaller; the flow rule is the same."""

    runs = [synthetic_run(tmp_path, theta=t, name=f"d{int(t)}", n_cycles=2, noise=0.002, seed=int(t), bulk_ratio=1.3)
            for t in (180.0, 90.0)]
    fits = {}
    for strain in ("bulk", "nominal"):
        data = [FitCycle.from_run(r.with_definitions(Definitions(strain=strain))) for r in runs]
        fits[strain] = global_fit.refine(data, TRUE).params
    ratio = 1.3 * (1 - 2 * 0.005 / 1.4)  # the band's strain per nominal strain over a cycle with two reversals
    for name in ("b1", "b2"):
        assert getattr(fits["nominal"], name) == pytest.approx(getattr(TRUE, name), rel=0.03), name
        assert getattr(fits["bulk"], name) == pytest.approx(getattr(TRUE, name) / ratio, rel=0.05), name
    for name in ("C", "n"):  # bulk strain is a uniform rescaling only away from the reversals: a few per cent
        assert getattr(fits["nominal"], name) == pytest.approx(getattr(TRUE, name), rel=0.03), name
        assert getattr(fits["bulk"], name) == pytest.approx(getattr(TRUE, name), rel=0.08), name


def test_held_parameters_stay_and_the_fisher_directions_name_the_weakest_combination(tmp_path, capsys):
    runs = [synthetic_run(tmp_path, theta=t, name=f"h{int(t)}", n_cycles=2, noise=0.005, seed=int(t))
            for t in (180.0, 90.0)]
    report = fit(runs[:1], tmp_path / "fit", cross_runs=runs[1:], hold={"a2": TRUE.a2})
    g = report.global_fit.estimates
    assert "a2" not in g.free and g.params["a2"] == TRUE.a2 and report.options.held == {"a2": TRUE.a2}
    steps = [d["relative_step"] for d in g.directions]
    assert len(steps) == len(g.free) == 6 and steps == sorted(steps, reverse=True)
    for d in g.directions:
        assert np.linalg.norm(list(d["direction"].values())) == pytest.approx(1.0)
    with pytest.raises(CalibrationError, match="cannot hold phi_c: only C, n, m"):
        fit(runs[:1], tmp_path / "fit2", hold={"phi_c": 0.6})
    assert fit_main(["--runs", str(runs[0].path), "--hold", "a2=x", "--out", str(tmp_path / "f3")]) == 2
    assert "--hold 'a2=x' is not NAME=VALUE" in capsys.readouterr().err


@pytest.mark.slow
def test_profile_intervals_match_the_sandwich_errors_on_a_nearly_linear_problem(tmp_path):
    """On model data with white noise the problem is nearly linear near the optimum: the 68 % profile
    interval is the sandwich's +-1 standard error; the profile's minimum is the fit."""
    from pipeline.calibration.profile import profiles

    runs = [synthetic_run(tmp_path, theta=t, name=f"p{int(t)}", n_cycles=3, noise=0.01, seed=int(t) + 3)
            for t in (180.0, 90.0)]
    data, noise = global_fit.prepare(runs)
    best = global_fit.refine(data, TRUE, noise=noise)
    result = profiles(data, best, points=5, span=3.0)
    for name, p in result["parameters"].items():
        low, high = p["intervals"]["68"]
        assert min(p["chi2_rise"]) < 0.05, name
        assert low is not None and high is not None, name
        assert (high - low) / 2 == pytest.approx(p["standard_error"], rel=0.2), name
        assert low < p["best"] < high, name


@pytest.mark.slow
def test_the_restarted_fit_recovers_the_truth_past_a_jump_that_biases_the_whole_cycle_fit(tmp_path):
    """Runs made by a model whose fabric loses 30 % of itself at once at each change of direction: fitted over
    the whole cycle the fit absorbs the jump (C 28, a1 5 standard errors off); restarted 0.005 past each change,
    with the restart state profiled out, it recovers every parameter within its intervals."""
    runs = [synthetic_run(tmp_path, name=f"s{seed}", seed=seed, jump=0.3, noise=0.003, correlation_strain=0.03,
                          a_tau_correlation=-0.5) for seed in range(3)]
    runs.append(synthetic_run(tmp_path, theta=90.0, name="t90", seed=7, jump=0.3, noise=0.003,
                              correlation_strain=0.03, a_tau_correlation=-0.5))
    names = global_fit.FREE
    z = {}
    for fit_from in (0.0, 0.005):
        data, noise = global_fit.prepare(runs, fit_from)
        best = global_fit.refine(data, TRUE, noise=noise)
        se = dict(zip(best.names, best.standard_errors, strict=True))
        z[fit_from] = {n: (getattr(best.params, n) - getattr(TRUE, n)) / se[n] for n in names}
    assert max(abs(v) for v in z[0.005].values()) < 3, z[0.005]
    assert max(abs(v) for v in z[0.0].values()) > 10, z[0.0]


def test_a_restarted_cycle_keeps_the_samples_past_gamma0_and_restarts_from_the_dem_state(tmp_path):
    cycle = FitCycle.from_run(synthetic_run(tmp_path, n_cycles=1).with_definitions(Definitions(strain="nominal")))
    restarted = cycle.restarted(0.01)
    assert len(restarted.strain) == len(cycle.strain) - 4  # two samples after each of two changes
    assert restarted.strain[0] == pytest.approx(0.01) and 0.7 + 0.005 not in restarted.strain
    assert [r[:3] for r in restarted.restarts] == [(pytest.approx(0.01), 0.7, 0.0), (pytest.approx(0.71), 1.4, 180.0)]
    np.testing.assert_array_equal(restarted.restarts[1][3], cycle.A[142])
    pred = restarted.prediction(TRUE)  # noise-free model data: the restarted model is the data
    np.testing.assert_allclose(pred.A, restarted.A, atol=2e-6)
    assert cycle.restarted(0) is cycle
    for bad in (0.003, -0.005, 0.7):
        with pytest.raises(ValueError, match=f"fit_from={bad}"):
            cycle.restarted(bad)


def test_an_interrupted_write_keeps_the_previous_complete_set(tmp_path):
    from pipeline import io

    paths = [tmp_path / "fit.json", tmp_path / "params.json"]
    for p in paths:
        p.write_text("previous")
    with pytest.raises(KeyboardInterrupt), io.atomic_paths(*paths) as temps:
        temps[0].write_text("new")
        raise KeyboardInterrupt  # Ctrl-C between two outputs
    assert [p.read_text() for p in paths] == ["previous", "previous"]
    assert sorted(x.name for x in tmp_path.iterdir()) == ["fit.json", "params.json"]  # no temporary left
    with io.atomic_paths(*paths) as temps:
        for t in temps:
            t.write_text("new")
    assert [p.read_text() for p in paths] == ["new", "new"]


def test_the_restart_table_reads_its_options_and_marks_what_is_not_determined():
    from pipeline.calibration import restart
    from pipeline.errors import PipelineError

    assert restart._numbers("fit-from", "0,0.005") == (0.0, 0.005)
    with pytest.raises(PipelineError, match="--fit-from 'x' is not a comma-separated list"):
        restart._numbers("fit-from", "x")
    with pytest.raises(PipelineError, match="--exponents: 5.0 must lie in"):
        restart._numbers("exponents", "0.5,5")
    names = ("C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")
    row = fit_row(fit_from=0.005, params=dict.fromkeys(names, 1.0), status={"m": "not determined"},
                  own_reversal=OwnReversal(0.017, None, "the fabric grows"), runs=9)
    text = restart.markdown([row], "reduced")
    assert "| 0.005 | 0.75 | 9 | +1 ± 0.1 | +1 ± 0.1 | +1 (open) |" in text and "+4.5% | n/a | +0.017, fails |" in text
    assert "| Table 2 |" in text and "+2.8e-05, peak 1.00 |" in text  # Table 2's own reversal, on the edge


def test_each_restart_row_writes_every_parameter_it_ran_with_where_the_comparison_reads_them(tmp_path):
    """A row past the jump, with k held at 1/2, is written whole (k and the parameters not fitted included) as a
    file of parameters that reads back equal, named by its gamma0, k and runs; its metadata say whether the model's
    own reversal runs with it."""
    from pipeline import io
    from pipeline.calibration import restart
    from pipeline.calibration.definitions import own_reversal

    params = model.Params().replace(persistence_exponent=0.5, a1=-0.03, b2=-40.0, phi_c=0.58)
    row = fit_row(fit_from=0.005, persistence_exponent=0.5, runs=6, weight="angles", model_params=params,
                  own_reversal=own_reversal(params))
    path = restart.write_row_params(tmp_path, row)
    assert path == tmp_path / "fit_from" / "from0.005-k0.5-runs6.json"
    assert io.read_params(path) == params
    metadata = json.loads(path.read_text())["metadata"]
    assert metadata["fit_from"] == 0.005 and metadata["own_reversal"]["error"] is None
    assert metadata["weight"] == "angles"


def dense_fake_run(dense: bool = True):
    """A run-like object with the dense samples' bookkeeping: A12 and Phi equal to the nominal strain."""
    from types import SimpleNamespace

    from dem.core.protocol import sample_strains

    spec = dataclasses.replace(resolve(180, "reduced"), dense_sample_strain=0.0005 if dense else 0.0,
                               dense_window_strain=0.05)
    strain = np.array(sample_strains(spec))
    A = np.zeros((len(strain), 3, 3))
    A[:, 0, 1] = A[:, 1, 0] = strain
    series = {"strain_nominal": strain, "A": A, "packing_fraction": strain}
    return SimpleNamespace(spec=spec, series_all=series)


def test_states_past_each_change_are_cycle_means_of_the_dense_samples():
    from pipeline.dataset.derived import states_after_changes

    A, phi = states_after_changes(dense_fake_run(), 0.002)
    # cycle means at 0.002 and 1.402 past the first change, 0.702 and 2.102 past the second
    np.testing.assert_allclose(A[:, 0, 1], [0.702, 1.402])
    np.testing.assert_allclose(phi, [0.702, 1.402])
    assert states_after_changes(dense_fake_run(), 0.0023) is None  # no sample there
    assert states_after_changes(dense_fake_run(dense=False), 0.002) is None
    assert states_after_changes(dense_fake_run(dense=False), 0.005) is not None  # on the grid


def test_a_cycle_restarts_between_grid_points_from_the_dense_state(tmp_path):
    cycle = FitCycle.from_run(synthetic_run(tmp_path, n_cycles=1).with_definitions(Definitions(strain="nominal")))
    A = np.stack([np.eye(3) * 0.01, np.eye(3) * 0.02])
    restarted = cycle.restarted(0.002, (A, np.array([0.61, 0.62])))
    assert restarted.strain[0] == pytest.approx(0.005)  # the grid samples past the restart
    assert restarted.restarts[0][0] == pytest.approx(0.002) and restarted.restarts[1][0] == pytest.approx(0.702)
    np.testing.assert_array_equal(restarted.restarts[1][3], A[1])
    assert restarted.restarts[1][4] == 0.62
    with pytest.raises(ValueError, match="or have dense samples"):
        cycle.restarted(0.002)


def test_the_restart_table_fits_an_off_grid_gamma0_on_the_dense_runs_beside_the_grid_one():
    from pipeline.calibration import restart

    dense, grid_only = dense_fake_run(), dense_fake_run(dense=False)
    rows = restart.settings([dense, grid_only], fit_from=(0.0, 0.002, 0.005), exponents=(0.5, 0.75))
    assert [(g, k, len(r)) for g, k, r in rows] == [(0.0, 0.75, 2), (0.002, 0.75, 1), (0.005, 0.75, 1),
                                                    (0.005, 0.75, 2), (0.005, 0.5, 2)]
    assert rows[1][2] == [dense]


def test_a_fit_row_weighs_the_runs_as_make_fit_does(tmp_path):
    """``make fit-definitions`` and ``fit-from`` fit their rows with the weighting asked for: two reversal seeds and
    one theta = 90 run counted once per angle give the global fit of ``prepare(weight="angles")``, not the one
    run by run."""
    from pipeline.calibration import definitions

    runs = [synthetic_run(tmp_path, t, name=f"w{k}", seed=k + 7, noise=0.003, n_cycles=1)
            for k, t in enumerate((180.0, 180.0, 90.0))]
    paper = Definitions(strain="nominal", phi="gap")
    row = definitions.fit_row(runs, paper, weight="angles")
    data, noise = global_fit.prepare([r.with_definitions(paper) for r in runs], weight="angles")
    per_angle = global_fit.refine(data, model.Params(), noise=noise)
    assert row.weight == "angles" and row.misfit == pytest.approx(per_angle.misfit)
    assert row.params["a1"] == pytest.approx(per_angle.params.a1)
    assert definitions.fit_row(runs, paper).chi2 != pytest.approx(row.chi2)


@pytest.mark.slow
def test_reversals_alone_leave_the_dilatancy_undetermined_and_say_so(tmp_path, capsys):
    """Eq. 18 on reversals alone: Phi_c runs off along c2_coef (committed data, two seeds). The fit goes on, writes
    no dilatancy, keeps Table 2's c2_coef and Phi_c in params.json and says so, instead of failing."""
    from pipeline.paths import ROOT

    runs = [str(ROOT / f"data/reference/{folder}/dem/theta180.h5") for folder in ("reduced", "reduced-df0432d3")]
    assert fit_main(["--runs", *runs, "--out", str(tmp_path / "fit")]) == 0
    report = read_fit(tmp_path / "fit" / "fit.json")
    assert report.dilatancy is None
    assert any("c2_coef and Phi_c are not determined" in note for note in report.notes)
    params = read_params(tmp_path / "fit" / "params.json")
    assert (params.c2_coef, params.phi_c) == (model.PAPER.c2_coef, model.PAPER.phi_c)
    assert params.c1 == -params.C != model.PAPER.c1  # Eq. 19 follows the fitted C
    assert "c2_coef, phi_c: not determined by these runs" in capsys.readouterr().out


def test_a_fit_row_whose_dilatancy_the_runs_cannot_fix_keeps_table_2s_and_says_so(tmp_path, monkeypatch):
    """Reversals alone leave Eq. 18's c2_coef and Phi_c open (make fit goes on with Table 2's): so do
    make fit-from and make fit-definitions, their errors NaN (shown as open) and a note in the row."""
    from pipeline.calibration import definitions

    def no_dilatancy(data, params):
        raise CalibrationError("the dilatancy fit did not converge")

    monkeypatch.setattr(global_fit, "refine_dilatancy", no_dilatancy)
    run = synthetic_run(tmp_path, name="one", seed=1, noise=0.003, n_cycles=1)
    row = definitions.fit_row([run], Definitions(strain="nominal", phi="gap"))
    assert "not determined" in row.dilatancy_note and "did not converge" in row.dilatancy_note
    assert row.params["c2_coef"] == model.PAPER.c2_coef and row.params["phi_c"] == model.PAPER.phi_c
    assert np.isnan(row.standard_errors["phi_c"]) and np.isfinite(row.standard_errors["C"])
    assert "(open)" in definitions.markdown([row], "x").split("\n")[-3]


@pytest.mark.slow
def test_a_single_runs_stepwise_errors_cover_the_spread_of_its_noise_draws(tmp_path):
    """One reversal of five cycles with DEM-like noise, drawn 16 times: each draw's stepwise errors (from
    resamplings of its cycles) hold its estimates within that of the draws' median for about 68 % of (draw,
    estimate) pairs. Measured over 24 other draws: 70 % (58 % without the small-sample widening)."""
    from pipeline.calibration.stepwise import BOOTSTRAPPED, calibrate_run, combine, stepwise_bootstrap

    keys = [k for k in BOOTSTRAPPED if not k.startswith("persistence_exponent")]
    estimates, errors = [], []
    for draw in range(16):
        run = synthetic_run(tmp_path, name=f"d{draw}", n_cycles=5, noise=0.01, seed=300 + draw,
                            correlation_strain=0.03, a_tau_correlation=-0.5)
        combined = combine([calibrate_run(run)], stepwise_bootstrap([run], 20, 0.05, seed=draw))
        estimates.append([combined[k]["value"] for k in keys])
        errors.append([combined[k]["standard_error"] for k in keys])
    estimates, errors = np.array(estimates), np.array(errors)
    covered = np.abs(estimates - np.median(estimates, axis=0)) < errors
    assert 0.55 < covered.mean() < 0.85, dict(zip(keys, covered.mean(axis=0).round(2), strict=True))


def test_the_stress_fitted_is_shear_by_default_and_a_bad_choice_is_one_line():
    shear = global_fit.noise_scales(4, None, 2)[1]
    assert np.all(np.isinf(shear[:, [0, 1, 0], [0, 1, 2]])) and np.all(shear[:, [0, 2], [1, 1]] == 1)
    assert np.all(np.isfinite(global_fit.noise_scales(4, None, 2, "all")[1]))
    assert np.all(global_fit.noise_scales(4, None, 2)[0] == 1)  # A: every component, whatever the stress fitted
    with pytest.raises(CalibrationError, match="stress='normal': the stress components fitted are one of shear, all"):
        from pipeline.calibration.calibrate import Settings
        Settings(stress="normal")


@pytest.mark.slow
def test_a_normal_stress_difference_the_model_lacks_pulls_the_fabric_law_only_when_tau_s_diagonal_is_fitted(
        tmp_path):
    """Model data plus a steady normal-stress difference (tau11/p -0.04, tau22/p -0.02, tau33/p +0.06, as the paper
    cell's DEM shows): the default fit (tau's shear components, the paper's) recovers Table 2's flow rule and fabric
    law within its errors; the fit of every component misses them by many."""
    import dataclasses

    runs = [synthetic_run(tmp_path, theta=t, name=f"d{int(t)}", n_cycles=3, noise=0.005, seed=int(t))
            for t in (180.0, 90.0)]
    offset = np.diag([-0.04, -0.02, 0.06])
    found = {}
    for stress in ("shear", "all"):
        data, noise = global_fit.prepare(runs, stress=stress)
        data = [dataclasses.replace(d, tau=d.tau + offset) for d in data]
        fit = global_fit.refine(data, TRUE, noise=noise)
        found[stress] = {n: abs(v - getattr(TRUE, n)) / se
                         for n, v, se in zip(fit.names, fit.values, fit.standard_errors, strict=True)}
    assert max(found["shear"].values()) < 4, found
    assert max(found["all"].values()) > 10, found["all"]


@pytest.mark.slow
def test_where_the_model_misses_the_runs_the_fit_gives_each_parameters_range_over_refits_without_one_angle(tmp_path):
    """The reversal, 30° and a 90° made with another fabric law (b2 -25, a2 0.4): one parameter set
    misses them (misfit >= 2), so the fit refits without each angle in turn, and b2's range over those refits
    reaches past the interval widened by the misfit. C, a2 and b2 are fitted, the rest held at the truth (27
    times faster than with all seven free)."""
    from pipeline.calibration.calibrate import Settings, calibrate

    noise = {"noise": 0.003, "correlation_strain": 0.03, "a_tau_correlation": -0.5, "n_cycles": 2}
    reversals = [synthetic_run(tmp_path, 180.0, name="r", seed=1, **noise)]
    cross = (synthetic_run(tmp_path, 30.0, name="c30", seed=5, **noise),
             synthetic_run(tmp_path, 90.0, name="c90", seed=6, params=TRUE.replace(b2=-25.0, a2=0.4), **noise))
    held = Settings(hold={name: getattr(TRUE, name) for name in ("n", "m", "a1", "b1")})
    ident = calibrate(reversals, cross, settings=held).identifiability
    assert ident.misfit_noted and ident.misfit >= 2
    assert ident.spread_over_angles is not None, (ident.noise_measured, ident.misfit)
    spread = ident.spread_over_angles
    assert spread.left_out == ["theta = 180", "theta = 30", "theta = 90"]
    assert set(spread.ranges) == set(ident.parameters)
    low, high = spread.ranges["b2"]
    wide_low, wide_high = ident.parameters["b2"].intervals_misfit_widened["68"]
    assert low < high and (low < wide_low or high > wide_high), (spread.ranges["b2"], (wide_low, wide_high))


def test_the_printout_says_why_no_new_run_is_ranked_when_none_can_be_weighed(capsys):
    """Where no candidate can be weighed (a fit past the jump whose model cannot run its own reversal, or whose
    segments are too short to restart in), the printout says so with the first reason instead of leaving the
    ranking out without a word."""
    from pipeline.calibration.text import print_next_runs
    from pipeline.schema import CandidateRun

    print_next_runs(fit_summary(next_runs=[
        CandidateRun("another reversal seed (theta = 180)", 180.0, 0.7, "dop853: too many steps"),
        CandidateRun("another seed at theta = 30", 30.0, 0.7, "dop853: too many steps")]))
    out = capsys.readouterr().out
    assert out.startswith("runs that would fix the weakest combination: none can be told")
    assert "another reversal seed (theta = 180): dop853: too many steps" in out
    print_next_runs(fit_summary(next_runs=[]))
    assert capsys.readouterr().out == ""
