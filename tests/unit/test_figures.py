"""`python -m pipeline.figures`: headless figures and the report from a tiny synthetic fixture."""

import pytest

from pipeline import fit
from pipeline.figures.__main__ import main
from tests.unit.test_fit import synthetic_file


def test_figures_and_report_build_headless(tmp_path):
    rev = synthetic_file(tmp_path, name="theta180", n_cycles=2, noise=0.005, seed=1)
    other = synthetic_file(tmp_path, theta=60.0, name="theta060", n_cycles=2, noise=0.005, seed=2)
    fit.fit([rev], tmp_path / "fit", cross_paths=[other])
    assert main(["--runs", str(rev), str(other), "--params", str(tmp_path / "fit" / "params.json"),
                 "--out", str(tmp_path / "out")]) == 0
    for name in ("fig3_fabric_law", "fig4_flow_rule", "fig5_6_cycles", "fig8_backstress", "fig9_work_rates"):
        png = tmp_path / "out" / "figures" / f"{name}.png"
        assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG", name
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| C |" in report and "| theta060 | our fit |" in report and "share of the backstress" in report
    assert "relaxation strain after the reversal" in report
    # model data made with c1 = -C and Phi below Phi_c + c3 satisfy Eq. 19
    assert "second law (Eq. 19)" in report and "(holds)" in report
    assert "| e-folds | a1 | b1 | a2 | b2 |" in report  # the stepwise calibration's sensitivity
    # the model with the true parameters fits the synthetic data to the noise: small normalised errors
    row = next(line for line in report.splitlines() if line.startswith("| theta180 | Table 2 |"))
    assert max(float(x) for x in row.split("|")[3:7]) < 0.15


def test_missing_inputs_are_one_line_errors(tmp_path, capsys):
    assert main(["--preset", "no-such-preset", "--out", str(tmp_path)]) == 2
    assert "no DEM run of preset 'no-such-preset'" in capsys.readouterr().err
    rev = synthetic_file(tmp_path, name="theta180", n_cycles=1)
    assert main(["--runs", str(rev), "--params", str(tmp_path / "none.json"), "--out", str(tmp_path)]) == 2
    assert "cannot read parameters" in capsys.readouterr().err


def test_relaxation_strain_of_an_exponential():
    import numpy as np

    from pipeline.calibrate import relaxation_strain

    strain = np.arange(0, 0.7, 0.005)
    x = 1 - np.exp(-strain / 0.15)  # within 5 % after 0.15 ln 20 = 0.449
    assert relaxation_strain(strain, x) == pytest.approx(0.15 * np.log(20), rel=1e-6)
    # noise as large as a tenth of the change moves it by a few per cent, not to the window's end
    noisy = x + np.random.default_rng(1).normal(0, 0.1, x.size)
    assert relaxation_strain(strain, noisy) == pytest.approx(0.15 * np.log(20), rel=0.15)
    assert np.isnan(relaxation_strain(strain, np.random.default_rng(2).normal(0, 1, x.size)))
