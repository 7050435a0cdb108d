"""Helpers of the tests: synthetic DEM run files made by the model (known truth), a command line run
in-process as if from a shell, and a fabric law whose own reversal runs away."""

import contextlib
import importlib
import importlib.util
import io
import runpy
import subprocess
import sys

import model
from dem.core.rawfile import write_raw
from pipeline.dataset.dem_file import load, write_h5

from .synthetic import synthetic_raw

#: a fabric law fitted past the reversal jump (the paper cell, six angles, 2026-11-25): a1 + a2 |A| = +0.017
RUNS_AWAY = model.PAPER.replace(C=-5.159, c1=5.159, n=0.1663, m=-0.2939, a1=-0.05258, b1=-1.924, a2=0.8649,
                                b2=-33.34, c2_coef=7.91, phi_c=0.5811)


def synthetic_file(folder, theta=180.0, name="run", **kw):
    """Write ``folder/<name>.h5`` from the model's cycle (see ``synthetic_raw``); returns its path. Its spec names
    the run as it is filed: ``<name>`` in the folder above ``dem/`` (else in its preset's)."""
    raw, meta = synthetic_raw(theta, **kw)
    filed_in = folder.parent.name if folder.name == "dem" else meta["spec"]["folder"]
    meta["spec"].update(name=name, folder=filed_in)
    write_raw(folder / f"{name}.npz", raw, meta)
    write_h5(folder / f"{name}.npz", folder / f"{name}.h5", {"git_commit": "test", "sessions": []})
    return folder / f"{name}.h5"


def synthetic_run(folder, theta=180.0, name="run", **kw):
    """The loaded ``DemRun`` of :func:`synthetic_file`."""
    return load(synthetic_file(folder, theta, name, **kw))


def run_main(main, argv) -> subprocess.CompletedProcess:
    """``main(argv)`` of a command line, in this process, as a shell would see it: exit status, stdout, stderr.
    An exception that escapes ``main`` escapes here too (where a shell would show a traceback)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exc:
            if isinstance(exc.code, str):
                err.write(exc.code + "\n")
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    return subprocess.CompletedProcess(list(argv), code, out.getvalue(), err.getvalue())


def fit_summary(weight="runs", estimates=None, runs=(), next_runs=None, persistence_exponent=0.75, **fields):
    """A ``fit.json`` (``pipeline.schema.FitSummary``) with only what a test of one part of the report needs: runs
    counted by ``weight``, a global refinement where ``estimates`` or ``next_runs`` are given (its ``runs``), no
    stepwise run, the rest empty; ``fields`` replace."""
    import model
    from pipeline import schema

    options = schema.FitOptions("a test", schema.Definitions(), "shear", weight, {}, 0.0, persistence_exponent, 0.05)
    refined = None if estimates is None and next_runs is None else schema.GlobalRefinement(
        list(runs), estimates, [], list(next_runs or []))
    return schema.FitSummary(**{"options": options, "stepwise": schema.Stepwise([], {}, None, [], None),
                                "params": model.Params(), "global_fit": refined, "dilatancy": None, "noise": None,
                                "identifiability": None, "bootstrap": None, "jackknife": None, "notes": [],
                                "made_from": schema.MadeFrom({}, {}), **fields})


def fit_row(**fields):
    """A row of ``make fit-from`` or ``make fit-definitions`` (``pipeline.schema.FitRow``) at Table 2's values, each
    standard error 0.1, misfit 1.2, Table 2's chi^2 4.5 % above it, the paper's definitions; ``fields`` replace."""
    import model
    from pipeline.schema import Definitions, FitRow, OwnReversal, Table2Test

    names = ("C", "n", "m", "a1", "b1", "a2", "b2", "c2_coef", "phi_c")
    return FitRow(**{"definitions": Definitions("nominal", "gap", "target"), "stress_fitted": "shear",
                     "weight": "runs", "fit_from": 0.0, "persistence_exponent": 0.75, "dilatancy_note": "",
                     "params": {n: getattr(model.PAPER, n) for n in names}, "model_params": model.PAPER,
                     "standard_errors": dict.fromkeys(names, 0.1), "status": {}, "misfit": 1.2, "chi2": 100.0,
                     "table2": Table2Test(4.5, 0.045, 1.2, None), "chi2_share_after_changes": 0.05,
                     "own_reversal": OwnReversal(None, None, "no steady state"), "mean_packing_fraction": 0.6,
                     **fields})


def module_main(module: str):
    """The command line ``python -m <module>`` as a function of its arguments, run in this process (a fresh run of
    the module's ``__main__`` each time): its exit status."""
    def main(argv) -> int:
        saved = sys.argv
        sys.argv = [module, *argv]
        try:
            if importlib.util.find_spec(module).submodule_search_locations is None:
                # a module, not a package: `python -m` runs its main(); runpy would run it a second time beside the
                # copy already imported (and warn)
                return importlib.import_module(module).main(list(argv)) or 0
            runpy.run_module(module, run_name="__main__", alter_sys=True)
        except SystemExit as exc:
            if isinstance(exc.code, str):
                raise SystemExit(exc.code) from None
            return exc.code or 0
        finally:
            sys.argv = saved
        return 0

    return main


def assert_contact_law(out: dict, spec: dict) -> None:
    """The collision checks (``dem.tools.yade_collision``, ``dem.tools.lammps_collision``) against the contact law of
    ``dem/core/contact.py``: restitution of each pair from its reduced mass (0.5 for the mean pair), k_t/k_n,
    k_n as designed, sliding at tan of the friction angle."""
    import numpy as np
    import pytest

    from dem.core.contact import contact_constants, pair_reduced_mass, restitution

    kn, _, cn, _ = contact_constants(spec)
    assert out["mean"]["restitution"] == pytest.approx(spec.restitution, abs=0.02)
    for pair in out.values():
        d = pair["diameter"]
        assert pair["restitution"] == pytest.approx(restitution(kn, cn, pair_reduced_mass(d, d)), abs=0.02)
        assert pair["kt_over_kn"] == pytest.approx(spec.kt_over_kn, rel=1e-3)
        assert pair["kn_over_design"] == pytest.approx(1.0, rel=1e-3)
        assert pair["sliding_ratio"] == pytest.approx(np.tan(np.radians(spec.friction_deg)), rel=1e-3)
    assert out["smallest"]["restitution"] < out["mean"]["restitution"] < out["largest"]["restitution"]
