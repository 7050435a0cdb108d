"""The calibration's noise model and intervals on model-made runs with DEM-like noise (known truth)."""

import dataclasses

import numpy as np
import pytest

import model
from pipeline.calibration import covariance, global_fit, identifiability, noise, resampling
from pipeline.calibration.fit_cycle import FitCycle
from pipeline.calibration.profile import profiles
from pipeline.schema import CandidateRun
from tests.helpers import fit_summary, synthetic_run

TRUE = model.Params()
NOISE = {"noise": 0.01, "correlation_strain": 0.03, "a_tau_correlation": -0.5}


def test_the_noise_model_measures_the_scatter_its_correlation_and_the_a_tau_coupling(tmp_path):
    runs = [synthetic_run(tmp_path, name=f"r{s}", n_cycles=4, seed=s, **NOISE) for s in range(2)]
    nm = noise.estimate(runs)
    assert nm.source == "correlation from the cycles about their run's cycle mean"
    assert nm.sigma_cycle["A"][0] == pytest.approx(0.01, rel=0.25)  # off-diagonal: the noise's standard deviation
    assert nm.sigma_cycle["tau_over_p"][1] == pytest.approx(0.01, rel=0.25)
    # AR(1) with correlation exp(-lag/0.03): integrated length 0.005 (1 + rho)/(1 - rho) = 0.060, less the taper's bias
    assert 0.03 < nm.correlation_strain()["A"][0] < 0.08
    assert nm.summary().A_tau_correlation[0] == pytest.approx(-0.5, abs=0.15)
    white = noise.estimate([synthetic_run(tmp_path, name=f"w{s}", n_cycles=4, seed=s, noise=0.01) for s in range(2)])
    assert white.correlation_strain()["A"][0] < 0.012


def _ar1_noise(step: float = 0.005, lags: int = 40) -> noise.NoiseModel:
    """A noise model measured every ``step`` strain: A and tau each AR(1) along strain, A_k(s) and tau_k(s + lag)
    correlated by -0.5 rho(lag), tau_k(s) and A_k(s + lag) by -0.5 rho(lag)^2 (one value at lag 0)."""
    rho = np.exp(-np.arange(lags) * step / 0.03)
    g = np.stack([np.stack([rho, -0.5 * rho], -1), np.stack([-0.5 * rho**2, rho], -1)], -2)  # (lags, 2, 2)
    ones = {q: np.ones(len(noise.COMPONENTS)) for q in noise.QUANTITIES}
    return noise.NoiseModel(step, ones, ones, np.repeat(g[None], len(noise.COMPONENTS), axis=0), "test")


def test_the_noise_correlation_matrix_holds_each_pair_of_samples_at_its_lag_and_order():
    """Sigma[i, j] of the stacked (A over L samples, tau over the same) is the autocovariance at lag j - i, the A-tau
    block taking the pair the right way round; at half the measured sampling the lags fall between the measured
    ones (linear) and the matrix stays symmetric."""
    nm, L = _ar1_noise(), 6
    g = nm.autocovariance[0]
    sigma = nm.covariance(0, L)
    assert sigma[1, 4] == g[3, 0, 0] and sigma[L + 1, L + 4] == g[3, 1, 1]
    assert sigma[1, L + 4] == g[3, 0, 1]  # A at 1, tau 3 samples later
    assert sigma[4, L + 1] == g[3, 1, 0]  # A at 4, tau 3 samples earlier: tau first
    np.testing.assert_array_equal(sigma, sigma.T)
    half = nm.covariance(0, L, lag_scale=0.5)
    assert half[0, 1] == pytest.approx((g[0, 0, 0] + g[1, 0, 0]) / 2)
    assert half[0, 2] == pytest.approx(g[1, 0, 0])
    np.testing.assert_allclose(half, half.T)


def test_a_cycles_noise_correlation_follows_its_own_sampling_and_its_restarted_grid():
    """A cycle sampled at half the noise's step gets the lags scaled to its step; a restarted cycle, the rows and
    columns of its kept samples out of its full grid's, so the samples either side of a gap keep their true lag."""
    nm = _ar1_noise()
    strain = np.arange(40) * 0.0025
    zeros, ones = np.zeros((40, 3, 3)), np.ones((40, 3, 3))
    dense = FitCycle(180.0, 0.05, 0.1, 1.0, 2, strain, zeros, zeros, np.zeros(40), ones, ones)
    np.testing.assert_array_equal(covariance.sample_covariance(nm, 1, dense), nm.covariance(1, 40, lag_scale=0.5))
    kept = np.r_[4:20, 24:40]
    restarted = dataclasses.replace(dense, strain=strain[kept], grid_index=kept)
    sigma = covariance.sample_covariance(nm, 1, restarted)
    full = nm.covariance(1, 40, lag_scale=0.5)
    assert sigma.shape == (2 * len(kept),) * 2
    assert sigma[15, 16] == full[19, 24]  # across the gap: 5 samples apart, not 1
    assert sigma[15, len(kept) + 16] == full[19, 40 + 24]


@pytest.mark.slow
def test_68_percent_intervals_cover_the_truth_at_their_rate_and_white_noise_ones_do_not(tmp_path):
    """40 noise draws of three reversal seeds with correlated noise: the sandwich intervals cover each
    parameter in 55-80 % of the draws; the same fit's white-noise errors (the noise's correlation ignored)
    cover far less."""
    hits, white_hits = [], []
    for draw in range(40):
        runs = [synthetic_run(tmp_path, name=f"c{draw}-{s}", seed=1000 * draw + s, **NOISE) for s in range(3)]
        data, nm = global_fit.prepare(runs)
        fit = global_fit.refine(data, TRUE, noise=nm)
        error = np.abs(fit.values - np.array([getattr(TRUE, n) for n in fit.names]))
        hits.append(error <= fit.standard_errors)
        white_hits.append(error <= np.sqrt(np.diag(fit.white_covariance)))
        for r in runs:
            r.path.unlink()
    coverage = np.mean(hits, axis=0)
    assert 0.55 <= np.mean(hits) <= 0.80, coverage
    assert np.all(coverage >= 0.45), dict(zip(global_fit.FREE, coverage, strict=True))
    assert np.mean(white_hits) < 0.45


def test_a_parameter_the_data_cannot_fix_has_a_flat_profile_and_is_reported_not_determined(tmp_path):
    """At steady shear (theta = 0) S is constant, so tau fixes only n + m S: n and m slide together. C is fixed
    there by tau's diagonal alone (tau11 = C A11); with the shear components (the default) it slides with n + m S."""
    runs = [synthetic_run(tmp_path, 0.0, name=f"z{s}", seed=s, **NOISE) for s in range(2)]
    data, nm = global_fit.prepare(runs)
    shear = global_fit.refine(data, TRUE, names=("C", "n", "m"), noise=nm)
    assert np.all(np.isinf(shear.standard_errors))
    data, nm = global_fit.prepare(runs, stress="all")
    best = global_fit.refine(data, TRUE, names=("C", "n", "m"), noise=nm)
    assert np.isinf(best.standard_errors[2]) and np.isfinite(best.standard_errors[0])
    summary = identifiability.summary(best, data, hold={"a1": TRUE.a1})
    assert summary.not_determined == ["n", "m"] and summary.parameters["C"].status == "determined"
    result = profiles(data, best, points=5)["parameters"]
    assert max(result["m"]["chi2_rise"]) < 1e-3 and result["m"]["intervals"]["68"] == [None, None]
    assert max(result["C"]["chi2_rise"]) > 10 and None not in result["C"]["intervals"]["68"]
    named = profiles(data, best, points=5, names=("C",))["parameters"]  # one parameter: its profile alone, the same
    assert list(named) == ["C"] and named["C"]["chi2_rise"] == result["C"]["chi2_rise"]


def test_profiling_a_parameter_the_fit_does_not_refine_is_one_line_before_any_fit(capsys):
    from pipeline.calibration.profile import main

    assert main(["--preset", "reduced", "--names", "C,colour"]) == 2
    err = capsys.readouterr().err
    assert "--names: 'colour' is not a parameter the fit refines" in err and err.count("\n") == 1


def test_a_model_that_misses_the_runs_says_so_beside_intervals_widened_by_the_root_of_its_misfit(tmp_path, capsys):
    """Runs the model makes itself fit within their noise: no note. The same fit with a misfit of 9 (the model three
    times the noise away) keeps the noise's intervals and gives beside them ones three times as wide, about the
    same value; the printout and the report say it, and say nothing of it at the smaller misfit."""
    from pipeline.calibration.text import print_global
    from pipeline.figures.report import parameter_lines

    runs = [synthetic_run(tmp_path, name=f"m{s}", seed=s, **NOISE) for s in range(2)]
    data, nm = global_fit.prepare(runs)
    fit = global_fit.refine(data, TRUE, noise=nm)
    assert fit.misfit < identifiability.MISFIT_NOTED
    near = identifiability.summary(fit, data)
    far = identifiability.summary(dataclasses.replace(fit, misfit=9.0), data)
    assert not near.misfit_noted and far.misfit_noted and far.misfit_widening == pytest.approx(3.0)
    assert near.misfit_widening == pytest.approx(np.sqrt(max(fit.misfit, 1.0)))
    for name, p in far.parameters.items():
        (low, high), (wide_low, wide_high) = p.intervals["68"], p.intervals_misfit_widened["68"]
        assert p.intervals == near.parameters[name].intervals, name
        assert wide_high - wide_low == pytest.approx(3 * (high - low)), name
        assert (wide_low + wide_high) / 2 == pytest.approx(p.value), name
    said = {}
    for label, ident, misfit in (("near", near, fit.misfit), ("far", far, 9.0)):
        estimates = dataclasses.replace(fit, misfit=misfit).estimates()
        report = fit_summary(estimates=estimates, runs=[str(r.path) for r in runs], identifiability=ident,
                             noise=nm.summary())
        print_global(report)
        said[label] = (capsys.readouterr().out, "\n".join(parameter_lines(TRUE, TRUE, report)))
    for printed, reported in (said["near"], said["far"]):
        assert ("sqrt(misfit) = 3.00 times" in printed) == (";  widened [" in printed) == (printed is said["far"][0])
        assert ("√misfit = 3.00 times" in reported) == ("widened × 3.00" in reported) == (reported is said["far"][1])
    header = next(line for line in said["far"][1].splitlines() if line.startswith("| parameter"))
    assert header.count("|") == next(line for line in said["far"][1].splitlines() if line.startswith("| C ")).count("|")


def test_table_2_is_inside_the_region_on_its_own_data_and_outside_on_other_physics(tmp_path):
    runs = [synthetic_run(tmp_path, name=f"t{s}", seed=s, **NOISE) for s in range(3)]
    data, nm = global_fit.prepare(runs)
    test = identifiability.table2_test(global_fit.refine(data, TRUE, noise=nm), data)
    assert test.inside["95"] and 0 <= test.chi2_rise <= test.quantiles["95"]
    other = TRUE.replace(b2=-30.0, b1=-2.2)
    runs = [synthetic_run(tmp_path, name=f"o{s}", seed=s, params=other, **NOISE) for s in range(3)]
    data, nm = global_fit.prepare(runs)
    test = identifiability.table2_test(global_fit.refine(data, other, noise=nm), data)
    assert not test.inside["95"] and not test.inside_misfit_widened["95"]


@pytest.mark.slow
def test_the_noise_bootstrap_agrees_with_the_sandwich_errors(tmp_path):
    runs = [synthetic_run(tmp_path, name=f"b{s}", seed=s + 50, **NOISE) for s in range(3)]
    data, nm = global_fit.prepare(runs)
    best = global_fit.refine(data, TRUE, noise=nm)
    boot = resampling.bootstrap(data, nm, best, 16, block_strain=0.2)
    ratio = np.array(boot.standard_deviation) / best.standard_errors
    assert np.all((ratio > 0.4) & (ratio < 2.5)), dict(zip(best.names, ratio, strict=True))
    for (low, high), value in zip(boot.interval_68, best.values, strict=True):
        assert low < value < high


@pytest.mark.slow
def test_the_jackknife_over_seeds_agrees_with_the_noise_model_where_seeds_differ_only_by_noise(tmp_path):
    runs = [synthetic_run(tmp_path, name=f"j{s}", seed=s + 90, **NOISE) for s in range(5)]
    data, nm = global_fit.prepare(runs)
    best = global_fit.refine(data, TRUE, noise=nm)
    jack = resampling.jackknife(data, {f"seed {s}": [s] for s in range(5)}, best, nm)
    ratio = np.array(jack.over_sandwich)
    assert np.all((ratio > 0.25) & (ratio < 3)) and 0.5 < np.exp(np.mean(np.log(ratio))) < 2, ratio
    with pytest.raises(global_fit.CalibrationError, match="at least 3 groups of runs to leave out, not 2"):
        resampling.jackknife(data[:2], {"seed 0": [0], "seed 1": [1]}, best)


@pytest.mark.slow
def test_leaving_out_each_angle_shifts_the_parameters_by_noise_alone_unless_one_angle_follows_other_physics(tmp_path):
    """Four angles (the reversal with two seeds, left out together) made with one parameter set, three noise
    draws: each leave-one-angle-out refit's shift, in units of the standard deviation the noise alone gives it,
    is a unit normal (rms 0.95, 68 % within 1 over six draws). The same runs with theta = 90 made with a 20 %
    smaller b2: leaving out 90 moves b2 by many of them, and that refit lies nearest the truth."""
    thetas = (180.0, 180.0, 30.0, 90.0, 120.0)
    groups = {"theta = 180": [0, 1], "theta = 30": [2], "theta = 90": [3], "theta = 120": [4]}
    other = TRUE.replace(b2=TRUE.b2 * 0.8)
    z = {}
    for label, at_90 in (("one 0", TRUE), ("one 1", TRUE), ("one 2", TRUE), ("other", other)):
        runs = [synthetic_run(tmp_path, t, name=f"{label}-{k}", seed=100 * len(z) + k, params=at_90 if t == 90.0
                              else TRUE, **NOISE) for k, t in enumerate(thetas)]
        data, nm = global_fit.prepare(runs)
        best = global_fit.refine(data, TRUE, noise=nm)
        jack = resampling.jackknife(data, groups, best, nm)
        z[label] = np.array(jack.shift_z, dtype=float)
    one = np.array([z[f"one {k}"] for k in range(3)])
    assert np.isfinite(one).all() and 0.6 < np.sqrt(np.mean(one ** 2)) < 1.4 and 0.5 < np.mean(np.abs(one) < 1) < 0.85
    b2 = jack.free.index("b2")
    assert abs(z["other"][2, b2]) > 5, z["other"]
    without = dict(zip(jack.left_out, np.array(jack.values)[:, b2], strict=True))
    assert min(without, key=lambda g: abs(without[g] - TRUE.b2)) == "theta = 90", without


def test_each_packing_fraction_definition_recovers_the_truth_of_data_built_with_it(tmp_path):
    """A run whose whole-gap Phi is the model's and whose central band is 0.05 looser: fitted with
    phi = gap, Eq. 18 returns Table 2's Phi_c; with phi = central, Phi_c 0.05 lower."""
    from dem.core.rawfile import write_raw
    from pipeline.dataset.dem_file import load, write_h5
    from pipeline.dataset.derived import Definitions
    from tests.helpers.synthetic import synthetic_raw

    raw, meta = synthetic_raw(180.0, n_cycles=1)
    volume = np.pi / 6 * np.sum((2 * np.array(meta["grain_radius"])) ** 3)
    phi = raw["packing_fraction"]
    raw["gap"] = 1.0 + volume / (meta["spec"]["width_d"] ** 2 * phi)  # W^2 (H - d) Phi = grain volume
    raw["packing_fraction"] = phi - 0.05
    write_raw(tmp_path / "run.npz", raw, meta)
    write_h5(tmp_path / "run.npz", tmp_path / "run.h5", {"git_commit": "test", "sessions": []})
    run = load(tmp_path / "run.h5")
    found = {}
    for definition in ("gap", "central"):
        data = [FitCycle.from_run(run.with_definitions(Definitions(phi=definition)))]
        found[definition] = global_fit.refine_dilatancy(data, TRUE).params.phi_c
    assert found["gap"] == pytest.approx(TRUE.phi_c, abs=0.006)  # Eq. 18's fit: within 0.005 on exact data
    assert found["gap"] - found["central"] == pytest.approx(0.05, abs=0.006)  # Eq. 18 is not linear in Phi


def test_without_a_measured_noise_there_are_no_intervals_and_no_verdict_on_table_2(tmp_path):
    """One cycle per run and no seeds: the scatter about a smoothed cycle stands in, and nothing it would
    give is printed as an interval."""
    from pipeline.calibration.calibrate import fit as calibrate

    runs = [synthetic_run(tmp_path, theta=t, name=f"u{int(t)}", n_cycles=1, seed=int(t), **NOISE)
            for t in (180.0, 90.0)]
    report = calibrate(runs[:1], tmp_path / "fit", cross_runs=runs[1:])
    ident = report.identifiability
    assert not report.noise.measured and not ident.noise_measured and ident.table2 is None
    assert all(p.intervals["68"] is None and p.status.startswith("no interval") for p in ident.parameters.values())
    assert report.global_fit.next_runs == []


@pytest.mark.slow
def test_the_next_runs_are_as_long_as_the_data_sets_and_priced_by_its_cpu_time(tmp_path, monkeypatch):
    """A data set of three-cycle runs at one CPU-hour per unit strain: every new candidate runs three cycles (the
    longer one six) and costs its strain in hours; another run at the data set's sampling never widens the weakest
    direction, while a reversal sampled five times as densely does (our least squares weighs its correlated samples
    as if independent) and is ranked last; a candidate whose model cycle fails at the best fit comes after it, with
    its error, instead of ending the fit."""
    from pipeline.calibration import design
    from pipeline.calibration.calibrate import calibrate
    from tests.helpers.synthetic import PERIOD, PRE

    made = design.candidate_data

    def failing_at_150(c, *args):
        if c.theta_deg == 150.0:
            raise model.SolverError("dop853: too many steps")
        return made(c, *args)

    monkeypatch.setattr(design, "candidate_data", failing_at_150)

    runs = [synthetic_run(tmp_path, theta=t, name=f"n{int(t)}", n_cycles=3, seed=int(t), **NOISE)
            for t in (180.0, 90.0)]
    for run in runs:
        run.parameters["cpu_seconds"] = 3600.0 * (PRE + 3 * PERIOD)
    ranked = calibrate(runs[:1], tuple(runs[1:])).next_runs
    assert ranked[-1] == CandidateRun("another seed at theta = 150", 150.0, 0.7, "dop853: too many steps")
    rows = {r.run: r for r in ranked[:-1]}
    seed = rows["another reversal seed (theta = 180)"]
    assert seed.n_cycles == 3 and seed.cpu_hours == pytest.approx(PRE + 3 * PERIOD)
    assert rows["a reversal run for 6 cycles instead of 3"].cpu_hours == pytest.approx(PRE + 6 * PERIOD)
    dense = rows.pop("a reversal sampled every 0.001 strain")
    assert all(r.weakest_after <= r.weakest_before * (1 + 1e-9) for r in rows.values())
    # five times the samples, correlated over the noise's length, weighed by the least squares as if independent
    assert dense.weakest_after > dense.weakest_before and dense is ranked[-2]
    assert seed.weakest_after < seed.weakest_before


@pytest.mark.slow
@pytest.mark.parametrize(("weight", "fit_from"), [("runs", 0.0), ("angles", 0.0), ("runs", 0.05)])
def test_the_ranking_predicts_the_errors_of_the_refit_with_the_new_run(tmp_path, weight, fit_from):
    """Two reversal seeds and a theta = 90 run: for another seed at 90, at 60 and of the reversal, the ranking's
    standard deviation along the weakest direction is what the refit with such a run gives (the same noise model,
    each run weighted as ``weight`` says and restarted ``fit_from`` past each change of direction; within 10 %),
    where the information a fit weighting by the full noise covariance would extract promised 15-18 % less."""
    from pipeline.calibration import design

    runs = [synthetic_run(tmp_path, t, name=f"r{k}", seed=40 + k, n_cycles=2, **NOISE)
            for k, t in enumerate((180.0, 180.0, 90.0))]
    for run in runs:
        run.parameters["cpu_seconds"] = 3600.0
    data, nm = global_fit.prepare(runs, fit_from, weight=weight)
    fit = global_fit.refine(data, TRUE, noise=nm)
    ranked = {r.run: r for r in design.rank(fit, nm, runs, [], data, weight=weight)}
    weakest = np.array([fit.directions[0]["direction"][n] for n in fit.names]) / np.abs(fit.values)
    for label, theta in (("another seed at theta = 90", 90.0), ("another seed at theta = 60", 60.0),
                         ("another reversal seed (theta = 180)", 180.0)):
        new = synthetic_run(tmp_path, theta, name=f"new{theta:g}", seed=90, n_cycles=2, **NOISE)
        refit = global_fit.refine(global_fit.weighed([*data, global_fit.scaled_cycle(new, nm, fit_from)], weight),
                                  fit.params, noise=nm)
        after = float(np.sqrt(weakest @ refit.covariance @ weakest))
        assert ranked[label].weakest_after == pytest.approx(after, rel=0.1), label
        assert ranked[label].weakest_after < ranked[label].weakest_before


def test_a_candidate_of_a_fit_past_the_jump_is_restarted_from_the_models_state_or_says_why_it_cannot_be():
    """With ``fit_from`` the candidate's pseudo-run keeps the samples from ``fit_from`` past each change of direction
    and restarts there from the model's own periodic state (so the model restarted reproduces its cycle); a reversal
    turned at 0.1 has no room to restart 0.15 past the turn, and says so."""
    from pipeline.calibration import design
    from tests.helpers.synthetic import PERIOD

    nm = _ar1_noise()
    whole = design.candidate_data(design.Candidate("r", 180.0), PERIOD, 1.0, nm, TRUE)
    restarted = design.candidate_data(design.Candidate("r", 180.0), PERIOD, 1.0, nm, TRUE, "shear", 0.05)
    assert restarted.fit_from == 0.05 and [r[0] for r in restarted.restarts] == pytest.approx([0.05, 0.75])
    np.testing.assert_array_equal(restarted.strain, whole.strain[restarted.grid_index])
    assert restarted.strain.min() == pytest.approx(0.05) and not np.any((restarted.strain > 0.7 - 1e-9)
                                                                        & (restarted.strain < 0.75 - 1e-9))
    np.testing.assert_allclose(restarted.prediction(TRUE).A, restarted.A, atol=1e-5)
    with pytest.raises(ValueError, match="fit_from=0.15"):
        design.candidate_data(design.Candidate("early", 180.0, rotate_at=0.1), PERIOD, 1.0, nm, TRUE, "shear", 0.15)


@pytest.mark.slow
def test_runs_of_the_data_set_are_weighed_from_their_own_data_even_where_the_models_pseudo_runs_fail(tmp_path,
                                                                                                       monkeypatch):
    """With every pseudo-run of the model failing: a committed run the fit leaves out is still weighed, from its own
    data, as the refit with it says (within 10 %), and another seed of it the same; another seed of a fitted
    protocol brings exactly that run's parts; a seed at an angle the data set lacks comes last with the model's
    error."""
    from pipeline.calibration import design

    runs = [synthetic_run(tmp_path, t, name=f"c{k}", seed=60 + k, n_cycles=2, **NOISE)
            for k, t in enumerate((180.0, 180.0, 90.0))]
    kept = synthetic_run(tmp_path, 60.0, name="kept", seed=70, n_cycles=2, **NOISE)
    for run in [*runs, kept]:
        run.parameters["cpu_seconds"] = 3600.0
    data, nm = global_fit.prepare(runs)
    fit = global_fit.refine(data, TRUE, noise=nm)

    def failing(*args):
        raise model.SolverError("dop853: too many steps")

    monkeypatch.setattr(design, "candidate_data", failing)
    ranked = {r.run: r for r in design.rank(fit, nm, runs, [kept], data)}
    weakest = np.array([fit.directions[0]["direction"][n] for n in fit.names]) / np.abs(fit.values)
    refit = global_fit.refine([*data, global_fit.scaled_cycle(kept, nm)], fit.params, noise=nm)
    committed = ranked["fit the committed theta = 60, rotated at 0.7 (no new run)"]
    assert committed.weakest_after == pytest.approx(float(np.sqrt(weakest @ refit.covariance @ weakest)), rel=0.1)
    assert ranked["another seed at theta = 60"].weakest_after == committed.weakest_after
    present = covariance.run_parts(fit.jacobian, data, nm)
    at_90 = covariance.sandwich([*present, present[2]], [1.0] * 4)[0]
    assert ranked["another seed at theta = 90"].weakest_after == pytest.approx(
        float(np.sqrt(weakest @ at_90 @ weakest)), rel=1e-12)
    assert ranked["another reversal seed (theta = 180)"].weakest_after < committed.weakest_before
    assert ranked["another seed at theta = 30"].error == "dop853: too many steps"


def test_a_committed_turn_of_fig_7_is_offered_as_fitted_or_as_another_seed_not_as_new():
    """Where Fig. 7's turn at 0.2 is committed, the candidates fit it for free or run another seed of it; the turn
    at 0.1, not committed, is offered as a new run."""
    from pipeline.calibration import design

    labels = [c.label for c in design.candidates([(90.0, 0.2)], n_cycles=5)]
    assert "fit the committed theta = 90, rotated at 0.2 (no new run)" in labels
    assert "another seed of theta = 90 rotated at 0.2 (Fig. 7)" in labels
    assert "theta = 90 rotated at 0.2 (Fig. 7)" not in labels
    assert "theta = 90 rotated at 0.1 (Fig. 7)" in labels


def test_weighing_each_angle_once_gives_a_protocols_seeds_the_weight_of_one_run(tmp_path):
    """Two reversal seeds and one theta = 90 run: with ``weight="angles"`` each seed carries 1/2, the 90 run 1, and
    the fit is the fit of the seeds' mean cycle as one run (sum_i |r_i|^2 / 2 = |r_mean|^2 + a constant); with
    "runs" each carries 1. A weighting not among WEIGHTS is one line naming it."""
    runs = [synthetic_run(tmp_path, t, name=f"w{k}", seed=k + 7, **NOISE) for k, t in enumerate((180.0, 180.0, 90.0))]
    data, nm = global_fit.prepare(runs, weight="angles")
    assert [d.weight for d in data] == [0.5, 0.5, 1.0]
    assert [d.weight for d in global_fit.weighed(data, "runs")] == [1.0, 1.0, 1.0]
    assert global_fit.fitted_residuals(data) == pytest.approx(2 / 3 * global_fit.fitted_residuals(
        global_fit.weighed(data, "runs")))
    names = ("C", "n", "m", "a1", "a2")
    per_angle = global_fit.refine(data, TRUE, names, noise=nm)
    mean = dataclasses.replace(data[0], A=(data[0].A + data[1].A) / 2, tau=(data[0].tau + data[1].tau) / 2, weight=1.0)
    of_mean = global_fit.refine([mean, data[2]], TRUE, names, noise=nm)
    per_run = global_fit.refine(global_fit.weighed(data, "runs"), TRUE, names, noise=nm)
    np.testing.assert_allclose(per_angle.values, of_mean.values, rtol=1e-4)
    assert np.max(np.abs(per_run.values - per_angle.values) / per_angle.standard_errors) > 1e-3
    with pytest.raises(global_fit.CalibrationError, match="weight='seeds': the runs are weighted by one of runs, ang"):
        global_fit.prepare(runs, weight="seeds")


@pytest.mark.slow
def test_with_each_angle_counted_once_the_intervals_and_the_seed_jackknifes_shifts_keep_their_rates(tmp_path):
    """Three reversal seeds and one theta = 90 run weighted by angle (the seeds 1/3 each), 24 noise draws: the
    sandwich's 68 % intervals cover the truth in 55-80 % of them, and leaving out one seed (the other two then
    carry 1/2 each) shifts the fit by a unit normal in units of the standard deviation the noise alone gives it
    (rms within 0.6-1.4). The seed jackknife's standard errors match the sandwich's part from the seeds' noise
    (rms ratio within 0.6-1.4), each below the whole sandwich's, which also holds the theta = 90 run's noise."""
    hits, z, theirs, whole = [], [], [], []
    for draw in range(24):
        runs = [synthetic_run(tmp_path, t, name=f"a{draw}-{k}", seed=500 + 10 * draw + k, **NOISE)
                for k, t in enumerate((180.0, 180.0, 180.0, 90.0))]
        data, nm = global_fit.prepare(runs, weight="angles")
        fit = global_fit.refine(data, TRUE, noise=nm)
        hits.append(np.abs(fit.values - np.array([getattr(TRUE, n) for n in fit.names])) <= fit.standard_errors)
        if draw < 6:
            jack = resampling.jackknife(data, {f"seed {k}": [k] for k in range(3)}, fit, nm, weight="angles")
            z.append(np.array(jack.shift_z, dtype=float))
            theirs.append(np.array(jack.over_their_noise, dtype=float))
            whole.append(jack.over_sandwich)
        for r in runs:
            r.path.unlink()
    assert 0.55 <= np.mean(hits) <= 0.80, np.mean(hits, axis=0)
    assert np.isfinite(z).all() and 0.6 < np.sqrt(np.mean(np.square(z))) < 1.4, np.array(z)
    assert np.all(np.array(theirs) > np.array(whole)), (theirs, whole)
    assert 0.6 < np.sqrt(np.mean(np.square(theirs))) < 1.4, (np.sqrt(np.mean(np.square(theirs))), np.array(theirs))


def test_the_noise_of_long_runs_in_a_large_cell_is_measured_not_floored(tmp_path):
    """Three seeds of five cycles with 0.003 of white noise per sample (about the paper cell's, A and tau alike): the
    noise of a run's five-cycle mean is measured at 0.003 / sqrt(5), with no seed part, and no floor stands in for
    it."""
    runs = [synthetic_run(tmp_path, name=f"q{s}", n_cycles=5, seed=s + 300, noise=0.003) for s in range(3)]
    nm = noise.estimate(runs)
    assert nm.source == "correlation from the seeds' cycle means about their protocol's mean"
    for q in noise.QUANTITIES:
        np.testing.assert_allclose(nm.sigma(q, 5), 0.003 / np.sqrt(5), rtol=0.25)
        assert np.all(nm.sigma(q, 5) > 2 * noise.SIGMA_FLOOR[q])
