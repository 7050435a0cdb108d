"""Bad input, tried as a hostile but honest user would: every case exits non-zero with one line that names
the value, no traceback, and leaves nothing behind. (Damaged run folders need Yade: tests/integration.)

The command lines run in-process (``run_main``: the same ``main`` a shell runs); Make itself runs as a
process, in the ``slow`` tests."""

import os
import shutil
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

import model
from model.cli import main as model_main
from model.cli import save_params
from pipeline import schema
from pipeline.paths import ROOT
from pipeline.runs.launch import main as launch_main
from pipeline.studies.fidelity.__main__ import main as fidelity_main
from tests.helpers import module_main, run_main, synthetic_file

fit_main, compare_main, figures_main = (module_main(f"pipeline.{m}") for m in ("calibration", "comparison", "figures"))


def run(args, cwd=ROOT):
    return subprocess.run(args, capture_output=True, text=True, cwd=cwd, timeout=120)


def assert_refused(proc, fragment):
    err = proc.stderr.strip()
    assert proc.returncode != 0, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout
    assert len(err.splitlines()) == 1, err
    assert fragment in err, err


def listing(folder):
    return sorted(p.relative_to(folder) for p in folder.rglob("*"))


# ---------------------------------------------------------------- make dem (the launcher; refused before Yade)
DEM_CASES = [
    (["--theta", "ninety"], "theta='ninety' is not a number"),
    (["--theta", "inf"], "theta='inf' is not a number"),
    (["--theta", "1e308"], "theta='1e308' must lie in [-180, 180]"),
    (["--theta", "720"], "theta='720' must lie in [-180, 180]"),
    (["--theta", "1_80"], "theta='1_80' is not a number"),
    (["--theta", "90", "--preset", "giant"], "unknown preset 'giant'"),
    (["--theta", "90", "--preset", "../../x"], "unknown preset '../../x'"),
    (["--theta", "90", "--set", "gap_d=-1"], "gap_d=-1.0 must be > 0"),
    (["--theta", "90", "--set", "colour=3"], "unknown override key(s) colour"),
    (["--theta", "90", "--set", "seed=1e20"], "seed=1e+20 must be <= 2147483647"),
    (["--theta", "90", "--set", "seed=2.5"], "seed=2.5 must be an integer"),
    (["--theta", "90", "--set", "inertial_number=5"], "inertial_number=5.0 is past the quasi-static regime"),
    (["--theta", "90", "--set", "dt_safety=100"], "dt_safety=100.0 is past the stability limit"),
    (["--theta", "90", "--set", "restitution=0.1"], "restitution=0.1 with dt_safety=0.2 damps the lightest pair"),
    (["--theta", "90", "--set", "fill_packing_fraction=5"], "fill_packing_fraction=5.0 is above random close"),
    (["--theta", "90", "--set", "fill_packing_fraction=0.001"], "fill_packing_fraction=0.001 gives 1 grains"),
    (["--theta", "90", "--set", "overlap_ratio=0.9"], "overlap_ratio=0.9 is not a small overlap"),
    (["--theta", "90", "--set", "width_d=7"], "width_d=7.0 must be an even integer"),
    (["--theta", "90", "--preset", "tiny", "--set", "diameter_min_d=1.8", "--set", "diameter_max_d=2.0"],
     "diameter_max_d=2.0 must be < width_d/2 = 2: a grain of half the periodic cell or more meets its own image"),
    (["--theta", "90", "--set", "restitution=1.5"], "restitution=1.5 must be < 1"),
    (["--theta", "90", "--set", "friction_deg=95"], "friction_deg=95.0 must be < 90"),
    (["--theta", "90", "--set", "diameter_min_d=2"], "diameter_min_d=2.0 must be < diameter_max_d"),
    (["--theta", "90", "--set", "checkpoint_steps=10"], "checkpoint_steps=10.0 must be >= 1000"),
    (["--theta", "90", "--set", "sample_strain=0.00001"], "sample_strain=1e-05 must be >= 0.0005"),
    (["--theta", "90", "--set", "profile_bin_d=0.0001"], "profile_bin_d=0.0001 must be >= 0.25 d"),
    (["--theta", "90", "--set", "noequals"], "override 'noequals' is not of the form key=value"),
    (["--theta", "90", "--set", "seed=0x10"], "override seed='0x10' is not a number"),
    (["--theta", "90", "--rotate-at", "2"], "rotate_at=2.0 must lie strictly between 0 and period_strain=1.4"),
    (["--theta", "90", "--rotate-at", "abc"], "rotate_at='abc' is not a number"),
    (["--theta", "90", "--rotate-at", "1e-320"], "name the run with 334 characters (at most 96)"),
    (["--theta", "90", "--set", "width_d=1000", "--set", "gap_d=850"], "give 7.14e+08 grains, more than 2e+06"),
    (["--theta", "90", "--threads", "0"], "threads=0 must be between 1 and 256"),
    (["--theta", "90", "--threads", "x"], "argument --threads: invalid int value: 'x'"),
    (["--theta", "90", "--engine", "foo"], "engine='foo' is not a DEM engine here (known: yade, lammps)"),
]


@pytest.mark.parametrize("args, fragment", DEM_CASES, ids=[" ".join(a) for a, _ in DEM_CASES])
def test_make_dem_refuses(tmp_path, args, fragment):
    proc = run_main(launch_main, ["run", *args, "--results", str(tmp_path)])
    assert_refused(proc, fragment)
    assert proc.returncode == 2 and listing(tmp_path) == []


# ---------------------------------------------------------------- the Makefile's variables never reach a shell
MAKE_CASES = [
    ("THETA=180; touch INJECTED", "THETA='180; touch INJECTED' is not a number"),
    ("PRESET=quick; touch INJECTED", "PRESET='quick; touch INJECTED' is not a name"),
    ("PRESET=tiny\ntouch INJECTED\ntrue", "PRESET='tiny\\ntouch INJECTED\\ntrue' holds a line break"),
    ("SET=seed=2 $$(touch INJECTED)", "SET='seed=2 $$(touch INJECTED)' is not a list of key=value"),
    ("THETA=$(shell touch INJECTED)", "THETA='$(shell touch INJECTED)' is not a number"),
    ("THREADS=1 && touch INJECTED", "THREADS='1 && touch INJECTED' is not a whole number"),
    ("ROTATE_AT=`touch INJECTED`", "ROTATE_AT='`touch INJECTED`' is not a number"),
    ("RANKS=1\n2", "RANKS='1\\n2' holds a line break"),
    ("ENGINE=lammps;touch INJECTED", "ENGINE='lammps;touch INJECTED' is not yade or lammps"),
]
OTHER_CASES = [
    ("fit", "WEIGHT=angles;touch INJECTED;true", "WEIGHT='angles;touch INJECTED;true' is not runs or angles"),
    ("figures", "PRESET=$(shell touch INJECTED)", "PRESET='$(shell touch INJECTED)' is not a name"),
    ("fit-bootstrap", "BOOT=0|touch INJECTED", "BOOT='0|touch INJECTED' is not a whole number"),
    ("bench-lammps-settings", 'A=sort 0" $$(touch INJECTED)', "is not LAMMPS settings"),
    ("bench-lammps-settings", "RUN_DIR=results/x.run&&touch INJECTED", "is not a run folder"),
    ("versus", "A=reduced;touch INJECTED;true", "A='reduced;touch INJECTED;true' is not a data set"),
    ("compare-seed", "SEED=2$$(touch INJECTED)", "SEED='2$$(touch INJECTED)' is not a whole number"),
    ("sweep-status", "SWEEP=x\ntouch INJECTED", "holds a line break"),
]
MAKE_TARGETS = [("dem", a, f) for a, f in MAKE_CASES] + OTHER_CASES


def make(tmp_path, *args, env=None):
    """The project's Makefile run in an empty folder (its Python from the project): whatever it runs, runs there."""
    return subprocess.run(["make", "--no-print-directory", "-f", str(ROOT / "Makefile"), *args], capture_output=True,
                          text=True, cwd=tmp_path, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})})


@pytest.mark.slow
@pytest.mark.parametrize("target, assignment, fragment", MAKE_TARGETS, ids=[f"{t} {a}" for t, a, _ in MAKE_TARGETS])
def test_make_variables_are_checked_before_any_command(tmp_path, target, assignment, fragment):
    name, _, value = assignment.partition("=")
    proc = make(tmp_path, target, f"{name}={value.replace(chr(92) + 'n', chr(10))}")
    assert_refused(proc, fragment)
    assert [str(p) for p in listing(tmp_path)] == ["results", "results/.make", "results/.make/goals",
                                                   *(f"results/.make/goals/{v}" for v in sorted(
                                                       ("CHECK_ERROR", "DATA_SET", "FIT_SUFFIX"))),
                                                   "results/.make/goals.stamp"]


@pytest.mark.slow
def test_a_value_that_would_run_while_make_reads_itself_stays_text(tmp_path):
    """``make help WEIGHT='$(shell ...)'``: every target, even one that reads no variable, takes it as text; and A
    and B, short names a shell may hold for other uses, do not stop a target that does not read them."""
    proc = make(tmp_path, "help", "WEIGHT=$(shell touch INJECTED)", env={"A": 'a "quoted" $value', "B": "x|y"})
    assert proc.returncode == 0 and "make versus" in proc.stdout, proc.stderr
    assert listing(tmp_path) == []


# ---------------------------------------------------------------- make fit / fit-bootstrap / compare / figures
@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Synthetic reversal and 90-degree runs, and damaged copies, in a folder of their own."""
    folder = tmp_path_factory.mktemp("inputs")
    rev = synthetic_file(folder, name="theta180", n_cycles=2)
    synthetic_file(folder, theta=90.0, name="theta090", n_cycles=1)
    (folder / "junk.h5").write_bytes(b"not an hdf5 file at all")
    for name, damage in (("missing", "delete"), ("nan", "nan"), ("short", "truncate")):
        copy = folder / f"{name}.h5"
        shutil.copy(rev, copy)
        with h5py.File(copy, "a") as f:
            if damage == "delete":
                del f["raw/fabric"]
            elif damage == "nan":
                f["raw/fabric"][5, 0, 1] = np.nan
            else:
                data = {k: f["raw"][k][()] for k in f["raw"]}
                for k, v in data.items():
                    unit = f["raw"][k].attrs["unit"]
                    del f["raw"][k]
                    f["raw"].create_dataset(k, data=v[:300]).attrs["unit"] = unit
    (folder / "a_file").write_text("")
    return folder


#: (arguments, with {inp} for the inputs folder; the fragment the one-line error must hold)
FIT_CASES = [
    (["--preset", "../../etc"], "preset '../../etc' is not a valid name"),
    (["--preset", "nosuch"], "unknown preset 'nosuch'"),
    (["--preset", "tiny", "--set", "nosuch=1"], "unknown override key(s) nosuch"),
    (["--bootstrap", "1", "--runs", "{inp}/theta180.h5"], "bootstrap=1: a bootstrap needs at least 2"),
    (["--bootstrap", "0", "--runs", "{inp}/theta180.h5"], "bootstrap=0: a bootstrap needs at least 2"),
    (["--window", "-1", "--runs", "{inp}/theta180.h5"], "window=-1.0 must be a positive strain"),
    (["--window", "5", "--runs", "{inp}/theta180.h5"], "window=5.0 must be a positive strain shorter"),
    (["--runs", "{inp}/theta180.h5", "{inp}/theta180.h5"], "is the same run as"),
    (["--runs", "{inp}/junk.h5"], "cannot open"),
    (["--runs", "{inp}/missing.h5"], "/raw/fabric is missing"),
    (["--runs", "{inp}/nan.h5"], "/raw/fabric has non-finite values"),
    (["--runs", "{inp}/short.h5"], "samples do not cover every cycle"),
    (["--runs", "{inp}/theta090.h5"], "not a reversal run"),
    (["--runs", "{inp}/theta180.h5", "--out", "{inp}/a_file/fit"], "a_file is a file"),
    (["--runs", "{inp}/theta180.h5", "--window", "nan"], "window=nan must be a positive strain"),
    (["--runs", "{inp}/theta180.h5", "--jackknife"], "a jackknife over seeds needs at least 3 of them, not 1"),
    (["--runs", "{inp}/theta180.h5", "--jackknife", "angles"],
     "a jackknife over angles needs at least 3 of them, not 1 (theta = 180)"),
    (["--runs", "{inp}/theta180.h5", "--jackknife", "angle"], "invalid choice: 'angle'"),
    (["--runs", "{inp}/theta180.h5", "--angles", "180"], "--angles chooses among a data set's runs"),
    # these two read the committed reduced data set's every run (seconds): make test, not make test-unit
    pytest.param(["--preset", "reduced", "--angles", "180", "75"],
                 "angles: no run at theta = 75 (the data set has 30, 60, 90", marks=pytest.mark.slow),
    pytest.param(["--preset", "reduced", "--angles", "90", "60"], "angles=90 60: the fit needs the reversal, 180",
                 marks=pytest.mark.slow),
]


@pytest.mark.parametrize("template, fragment", FIT_CASES,
                         ids=[" ".join(getattr(case, "values", case)[0]) for case in FIT_CASES])
def test_make_fit_refuses(inputs, tmp_path, template, fragment):
    args = [a.format(inp=inputs) for a in template]
    before = listing(inputs)
    proc = run_main(fit_main, args if "--out" in args else [*args, "--out", str(tmp_path / "fit")])
    assert_refused(proc, fragment)
    assert listing(tmp_path) == [] and listing(inputs) == before


@pytest.mark.parametrize("main, args, fragment", [
    (figures_main, ["--preset", "../x"], "preset '../x' is not a valid name"),
    (figures_main, ["--preset", "nosuch"], "unknown preset 'nosuch'"),
    (figures_main, ["--preset", "tiny", "--engine", "lammps"], "metrics.json not found: run `make compare`"),
    (compare_main, ["--preset", "tiny", "--set", "seed=7"], "cannot read parameters"),
    (compare_main, ["--preset", "a/b"], "preset 'a/b' is not a valid name"),
])
def test_make_compare_and_figures_refuse(tmp_path, main, args, fragment):
    proc = run_main(main, [*args, "--out", str(tmp_path / "out")])
    assert_refused(proc, fragment)
    assert listing(tmp_path) == []


def test_make_compare_refuses_parameters_fitted_in_definitions_it_does_not_know(tmp_path):
    params = tmp_path / "params.json"
    params.write_text(model.Params().to_json({"definitions": {"strain": "sideways", "phi": "gap",
                                                              "pressure": "target"}}))
    proc = run_main(compare_main, ["--preset", "tiny", "--params", str(params), "--out", str(tmp_path / "out")])
    assert_refused(proc, "are not definitions (strain='sideways' is not one of bulk, nominal)")
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------- python -m model
def write_bytes(path, data: bytes):
    path.write_bytes(data)
    return path


def params_file(folder, **changes):
    path = folder / "p.json"
    save_params(model.Params().replace(**changes), path)
    return path


@pytest.mark.parametrize("make_args, fragment", [  # bad numbers: tests/unit/test_cli.py
    (lambda d: ["--theta", "90", "--params", str(params_file(d, c3=5.0))], "packing fraction leaves (0, 1)"),
    (lambda d: ["--theta", "180", "--params", str(params_file(d, b2=35.0))], "parameters off Table 2: b2 = +35"),
    (lambda d: ["--theta", "90", "--params", str(d / "none.json")], "not a regular file of parameters"),
    (lambda d: ["--theta", "90", "--params", "/dev/zero"], "/dev/zero: not a regular file of parameters"),
    (lambda d: ["--theta", "90", "--params", str(write_bytes(d / "b.json", b'{"C": \xff}'))], "not UTF-8 text"),
    (lambda d: ["--theta", "90", "--params", str(write_bytes(d / "b.json", b" " * 70000))],
     "more than 65536 bytes"),
    (lambda d: ["--theta", "90", "--params", str(write_bytes(d / "b.json", b'{"C": 1' + b"0" * 5000 + b"}"))],
     "is not valid JSON (Exceeds the limit"),
    (lambda d: ["--theta", "90", "--params", str(write_bytes(d / "b.json", model.Params().to_json().replace(
        '"C": -5.6', '"C": 1' + "0" * 400).encode()))], "C=10000000000000000000... is too large"),
    (lambda d: ["--theta", "1e300"], "'1e300' must lie in [-180, 180] degrees"),
])
def test_python_m_model_refuses(tmp_path, make_args, fragment):
    args = make_args(tmp_path)
    before = listing(tmp_path)
    proc = run_main(model_main, ["predict", *args, "--out", str(tmp_path / "out.csv")])
    assert_refused(proc, fragment)
    assert listing(tmp_path) == before


def test_python_m_model_refuses_a_duplicate_key_and_an_output_folder(tmp_path):
    (tmp_path / "dup.json").write_text(model.Params().to_json().replace('"C": -5.6', '"C": -5.6, "C": -5'))
    proc = run_main(model_main, ["predict", "--theta", "90", "--params", str(tmp_path / "dup.json"),
                                 "--out", str(tmp_path / "out.csv")])
    assert_refused(proc, "key(s) given more than once: C")
    proc = run_main(model_main, ["predict", "--theta", "90", "--out", str(tmp_path)])
    assert_refused(proc, "is a folder: give a file name")
    assert listing(tmp_path) == [(tmp_path / "dup.json").relative_to(tmp_path)]


def test_python_m_model_writes_only_regular_files_through_unique_temporaries(tmp_path):
    import os
    import threading

    os.mkfifo(tmp_path / "fifo")
    proc = run_main(model_main, ["predict", "--theta", "90", "--out", str(tmp_path / "fifo")])
    assert_refused(proc, "is not a regular file (a device, FIFO or socket)")
    proc = run_main(model_main, ["predict", "--theta", "90", "--out", "/dev/null"])
    assert_refused(proc, "/dev/null is not a regular file")
    # four writers of one output: each through its own temporary, the file complete, none left behind
    from model.cli import result_table, write_csv

    table = result_table(model.predict(90))
    threads = [threading.Thread(target=write_csv, args=(tmp_path / "out.csv", table)) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len((tmp_path / "out.csv").read_text().splitlines()) == len(table) + 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo", "out.csv"]


def test_an_engine_that_is_not_installed_is_one_line_naming_its_packages():
    """The project's venv has no LAMMPS (Debian's python3 does, after ``make system-lammps``): asking it for one is
    the one-line message a user without LAMMPS sees."""
    import importlib.util

    from dem.lammps.lib import new_lammps

    assert importlib.util.find_spec("lammps") is None, "the venv is meant to be without LAMMPS"
    with pytest.raises(ImportError) as err:
        new_lammps()
    assert "make system-lammps" in str(err.value) and "\n" not in str(err.value)


# ---------------------------------------------------------------- make bench-lammps-settings (refused before LAMMPS)
@pytest.mark.parametrize("folder, extra, fragment", [
    ("empty", [], "no checkpoint there"),
    ("yade", [], "a yade run, not a LAMMPS one"),
    ("lammps", ["--a", " ; "], "--a=' ; ' is not LAMMPS settings"),
    ("lammps", ["--a", "shell touch x"], "--a='shell touch x' is not LAMMPS settings"),
    ("lammps", ["--steps", "10"], "--steps 10 must be at least 100"),
    ("lammps", ["--rounds", "0"], "--rounds 0 must be at least 1"),
])
def test_the_lammps_settings_benchmark_refuses(tmp_path, folder, extra, fragment):
    from pipeline.studies.bench_lammps_settings import main as bench_main

    run_dir = tmp_path / "run.run"
    run_dir.mkdir()
    if folder != "empty":
        (run_dir / "checkpoint.json").write_text("{}")
        (run_dir / "spec.json").write_text(f'{{"engine": "{folder}"}}')
    out = tmp_path / "bench"
    proc = run_main(bench_main, ["--run-dir", str(run_dir), "--a", "atom_modify sort 0 0.0", "--b",
                                 "atom_modify sort 1000 0.0", *extra, "--out", str(out)])
    assert_refused(proc, fragment)
    assert not out.exists()


# ---------------------------------------------------------------- an empty path is no path
@pytest.mark.parametrize("module, argv", [
    ("pipeline.calibration", ["--preset", "reduced", "--out", ""]),
    ("pipeline.model_selection", ["--preset", "reduced", "--out", " "]),
    ("pipeline.figures", ["--preset", "reduced", "--out", ""]),
    ("pipeline.runs", ["run", "--theta", "90", "--preset", "tiny", "--results", ""]),
    ("pipeline.studies.bench_update", ["--out", ""]),
])
def test_an_empty_path_is_refused_not_taken_as_the_current_folder(tmp_path, monkeypatch, module, argv):
    """Every pipeline command line's path options (``pipeline.cli.Parser``): '' would be '.', and a fit or a run
    would land among the user's own files."""
    monkeypatch.chdir(tmp_path)
    proc = run_main(module_main(module), argv)
    assert proc.returncode == 2 and "is empty: give a path" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not any(tmp_path.iterdir())


@pytest.mark.parametrize("kind", ["fifo", "device", "folder", "too large"])
def test_a_file_a_stage_reads_must_be_regular_and_bounded(tmp_path, kind):
    """A ladder, a parameters file or a record that is a FIFO (which would hang), a device (which never ends), a
    folder, or larger than the bound: one line, at once."""
    import os

    from pipeline import io
    from pipeline.errors import PipelineError, SpecError
    from pipeline.studies.fidelity import ladder

    path = {"fifo": tmp_path / "fifo", "device": Path("/dev/zero"), "folder": tmp_path,
            "too large": tmp_path / "large"}[kind]
    if kind == "fifo":
        os.mkfifo(path)
    if kind == "too large":
        path.write_bytes(b" " * (io.MAX_TEXT_BYTES + 1))
    for read in (ladder.load, io.read_params, schema.read_fit):
        with pytest.raises((SpecError, PipelineError)) as err:
            read(path)
        assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_make_fidelity_with_a_ladder_of_many_runs_asks_for_many(tmp_path):
    ladder_file = tmp_path / "wide.toml"
    ladder_file.write_text('preset = "reduced"\nthetas = [30.0, 60.0, 90.0]\n[axes.seed]\nvalues = ['
                           + ", ".join(f"{{ seed = {k} }}" for k in range(1, 72)) + "]\n")
    proc = run_main(fidelity_main, ["--run", "--ladder", str(ladder_file), "--out", str(tmp_path / "out")])
    assert proc.returncode == 2 and "runs, more than 200: MANY=1 (--allow-many)" in proc.stderr
    assert not (tmp_path / "out").exists()
