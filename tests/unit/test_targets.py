"""The user's make targets (``pipeline.targets``): which stages each runs with which arguments, the include file the
Makefile reads, and the one-line refusal of a bad value. Nothing here runs a stage."""

import os
import re
import shutil
import subprocess
import sys

import pytest

from pipeline import spec as run_spec
from pipeline import targets
from pipeline.errors import PipelineError
from pipeline.paths import ROOT


def plan(target: str, **variables: str) -> list[str]:
    """The command lines ``make <target> <variables>`` runs (``python -m pipeline.targets --plan``)."""
    return [str(c) for c in targets.TARGETS[target](targets.Variables(variables))]


def refusal(target: str, **variables: str) -> str:
    with pytest.raises(PipelineError) as err:
        targets.TARGETS[target](targets.Variables(variables))
    assert "\n" not in str(err.value)
    return str(err.value)


@pytest.mark.parametrize("variables, words", [
    ({"PRESET": "paper", "ENGINE": "lammps", "SET": "inertial_number=1e-3 seed=2"},
     "--preset paper --engine lammps --set inertial_number=1e-3 --set seed=2"),
    ({"PRESET": "paper", "ENGINE": "yade"}, "--preset paper --engine yade"),
    ({"PRESET": "reduced", "FIT_FROM": "0.005", "WEIGHT": "angles"},
     "--preset reduced --fit-from 0.005 --weight angles"),
    ({"PRESET": "paper", "VARIANT": "loading"}, "--preset paper --variant loading"),
])
def test_make_fit_hands_the_stage_the_data_set_and_the_fits_options(variables, words):
    assert plan("fit", **variables) == [f"python -m pipeline.calibration {words}"]


def test_the_goals_values_name_the_data_sets_folder_and_no_path_found_on_disk(tmp_path):
    values = targets.goal_values(targets.Variables({"PRESET": "paper", "ENGINE": "lammps",
                                                    "SET": "inertial_number=0.001 seed=3"}), ["fit", "figures"])
    folder = run_spec.run_folder("paper", "lammps", {"inertial_number": 0.001})
    assert values == targets.GoalValues(DATA_SET=folder)
    stamp = tmp_path / "goals.stamp"
    targets.write_goal_values(stamp, values)
    assert (tmp_path / "goals" / "DATA_SET").read_text() == folder
    before = stamp.stat().st_mtime_ns
    targets.write_goal_values(stamp, values)
    assert stamp.stat().st_mtime_ns == before  # unchanged: Make does not read itself again
    targets.write_goal_values(stamp, targets.GoalValues(CHECK_ERROR="x"))
    assert stamp.read_text() != values.stamp()  # changed with the values: Make reads itself again


@pytest.mark.parametrize("goals, variables, message", [
    (["dem"], {"THETA": "$(shell touch x) # y"}, "THETA='$(shell touch x) # y' is not a number"),
    (["fit"], {"WEIGHT": "angles;touch x"}, "WEIGHT='angles;touch x' is not runs or angles"),
    (["dem"], {"RANKS": "1\n2"}, "RANKS='1\\n2' holds a line break"),
    (["dem"], {"PRESET": "giant"}, "unknown preset 'giant'"),
    (["compare-seed"], {"PRESET": "paper"}, "SEED is empty"),
    (["runs", "versus"], {"A": "reduced yade", "B": "paper"}, "A='reduced yade' is not a data set"),
    (["fit"], {"VARIANT": "loading;touch x"}, "VARIANT='loading;touch x' is not a name"),
    (["models"], {"ACROSS": "reduced:gromacs"}, "ACROSS='reduced:gromacs' is not a list of PRESET[:ENGINE]"),
    (["models"], {"LAWS": "elastic jump"}, "LAWS='elastic jump' is not a comma-separated list of names"),
])
def test_a_bad_value_becomes_one_make_line_that_expands_to_the_text_given(goals, variables, message):
    """CHECK_ERROR holds the message as given (Make reads it as text and never expands it)."""
    values = targets.goal_values(targets.Variables(variables), goals)
    assert message in values.CHECK_ERROR and "\n" not in values.CHECK_ERROR and values.DATA_SET == ""


@pytest.mark.parametrize("target, variables, fragment", [
    ("dem", {"THETA": "180; touch x"}, "THETA='180; touch x' is not a number"),
    ("dem", {"ENGINE": "lammps;touch x"}, "ENGINE='lammps;touch x' is not yade or lammps"),
    ("dem", {"SET": "seed=2 $(touch x)"}, "SET='seed=2 $(touch x)' is not a list of key=value"),
    ("dem", {"FRESH": "maybe"}, "FRESH='maybe' is not 1 or empty"),
    ("dem", {"SET": "colour=3"}, "unknown override key(s) colour"),
    ("sweep", {}, "THETAS is empty"),
    ("sweep", {"THETAS": "30 60", "SEEDS": "1 two"}, "SEEDS='1 two' is not a list of whole numbers"),
    ("fit-angles", {"PRESET": "reduced"}, "ANGLES is empty"),
    ("fit-jackknife", {"OVER": "runs"}, "OVER='runs' is not seeds or angles"),
    ("compare-seed", {"PRESET": "paper", "SEED": "two"}, "SEED='two' is not a whole number"),
    ("bench-dem", {"ENGINES": "yade,gromacs"}, "ENGINES='yade,gromacs' is not a comma-separated list of yade"),
    ("bench-lammps-settings", {"RUN_DIR": "r.run", "A": "shell touch x"}, "A='shell touch x' is not LAMMPS settings"),
    ("bench-lammps-settings", {"RUN_DIR": "r.run&&x"}, "RUN_DIR='r.run&&x' is not a run folder"),
    ("versus", {"A": "reduced"}, "B is empty"),
])
def test_a_target_refuses_a_bad_value_in_one_line_naming_it(target, variables, fragment):
    assert fragment in refusal(target, **variables)


def test_the_targets_pass_their_options_and_folders():
    folder = "results/" + run_spec.run_folder("paper", "lammps", {"inertial_number": 0.001})
    assert plan("compare-seed", PRESET="paper", SEED="2") == [
        f"python -m pipeline.comparison --preset paper --seed 2 --params {folder}/fit/params.json "
        f"--out {folder}/compare-seed2",
        f"python -m pipeline.figures --preset paper --fit {folder}/fit --compare {folder}/compare-seed2"]
    # a fit of another law or other options, its comparison and its figures: folders of their own
    assert plan("fit", PRESET="paper", VARIANT="jump") == ["python -m pipeline.calibration --preset paper "
                                                            "--variant jump"]
    assert plan("compare", PRESET="paper", VARIANT="jump", SKIP_CYCLES="1") == [
        f"python -m pipeline.comparison --preset paper --skip-cycles 1 --params {folder}/fit-jump-skip1/params.json "
        f"--out {folder}/compare-jump-skip1"]
    assert plan("figures", PRESET="paper", WEIGHT="angles") == [
        f"python -m pipeline.figures --preset paper --fit {folder}/fit-per-angle --compare {folder}/compare-per-angle "
        f"--out {folder}/compare-per-angle"]
    assert plan("figures", PRESET="paper", STRESS="shear")[0].endswith(f"--compare {folder}/compare --out {folder}")
    assert plan("fit-angles", PRESET="reduced", ANGLES="180 90", FIT_FROM="0.005")[0].endswith(
        "--preset reduced --fit-from 0.005 --angles 180 90")
    assert plan("fit-jackknife", PRESET="reduced", STRESS="all")[0].endswith("--stress all --jackknife seeds")
    for target in ("fit-definitions", "fit-from", "fit-profile"):
        assert "--weight angles" in plan(target, PRESET="reduced", WEIGHT="angles")[0]
        assert "--weight" not in plan(target, PRESET="reduced")[0]
    assert plan("dem", THETA="90", ENGINE="lammps", RANKS="2", FRESH="1") == [
        "python -m pipeline.runs run --theta 90 --preset quick --engine lammps --threads 1 --fresh --ranks 2"]
    assert plan("bench-lammps-settings", RUN_DIR="r.run", B="atom_modify sort 0 0.0; neigh_modify every 5")[0] \
        .endswith("--a 'atom_modify sort 0 0.0' --b 'atom_modify sort 0 0.0; neigh_modify every 5' --out results/bench")
    assert plan("fidelity-table", ENGINE="lammps")[1].endswith("--table results/fidelity-lammps/table.json")
    # another ladder: its own folder, which the figure reads
    assert plan("fidelity", LADDER="tests/my.toml", ENGINE="lammps") == [
        "python -m pipeline.studies.fidelity --run --jobs 2 --engine lammps --ladder tests/my.toml "
        "--out results/fidelity-my-lammps",
        "python -m pipeline.figures.fidelity --table results/fidelity-my-lammps/table.json"]
    assert plan("fidelity-table")[0].endswith("--ladder config/fidelity.toml --out results/fidelity")
    assert plan("fit-profile", PRESET="quick", POINTS="3")[0].endswith("--phi gap --points 3")
    assert plan("bench", PRESETS="tiny", POINTS="1000") == [
        "python -m pipeline.studies.bench_model --out results/bench",
        "python -m pipeline.studies.bench_update --points 1000 --out results/bench",
        "python -m pipeline.studies.bench_dem --presets tiny --engines yade --out results/bench"]


def test_the_goals_values_are_written_by_the_standard_library_alone(tmp_path):
    """Debian's python3 writes them before anything is installed (``-S``: no site packages)."""
    path = tmp_path / "goals.stamp"
    proc = subprocess.run([sys.executable, "-S", "-m", "pipeline.targets", "makefile", str(path), "dem", "fit"],
                          cwd=ROOT, capture_output=True, text=True, env={"PRESET": "reduced", "THETA": "90"})
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "goals" / "DATA_SET").read_text() == "reduced"
    assert (tmp_path / "goals" / "CHECK_ERROR").read_text() == "" and path.read_text().startswith("#")


#: a target that reads each user variable (every one the Makefile exports: ``USER_VARIABLES``)
READER = {"THETA": "dem", "PRESET": "dem", "ENGINE": "dem", "RANKS": "dem", "ROTATE_AT": "dem", "SET": "dem",
          "FRESH": "dem", "THREADS": "dem", "ALLOW_INERTIAL": "dem", "PRESETS": "bench-dem", "ENGINES": "bench-dem",
          "FIT_FROM": "fit", "STRESS": "fit", "WEIGHT": "fit", "VARIANT": "fit", "SKIP_CYCLES": "fit",
          "CASES": "stability",
          "ANGLES": "fit-angles", "OVER": "fit-jackknife", "BOOT": "fit-bootstrap", "STRAIN": "fit-profile",
          "PHI": "fit-profile",
          "THETAS": "sweep", "ROTATE_ATS": "sweep", "SEEDS": "sweep", "LAUNCH": "sweep", "SLURM": "sweep",
          "JOBS": "sweep", "MANY": "sweep", "SWEEP": "sweep-status", "SEED": "compare-seed", "A": "versus",
          "B": "versus", "RUN_DIR": "bench-lammps-settings", "ACROSS": "models", "LAWS": "models",
          "POINTS": "fit-profile", "NAMES": "fit-profile",
          "LADDER": "fidelity"}
PAYLOADS = ("$(shell touch INJECTED)", "x;touch INJECTED", "x\ntouch INJECTED", "`touch INJECTED`",
            "$(touch INJECTED)", "x' \"y", "x" * 5000, "ü→∞", "٩٠", "２")


def test_every_user_variable_has_a_reader_and_a_check_that_refuses_every_payload_in_one_line():
    """Every variable the Makefile exports is read by some target, which refuses each payload (shell and Make
    syntax, quotes, a very long value, Unicode, digits of other scripts) in one line naming it, before anything
    runs."""
    text = (ROOT / "Makefile").read_text()
    declared = text.split("USER_VARIABLES :=", 1)[1].split("\n#", 1)[0].replace("\\", " ").split()
    assert sorted(declared) == sorted(READER)
    for name, target in READER.items():
        base = {"PRESET": "paper", "A": "paper", "B": "reduced", "RUN_DIR": "results/x.run", "THETAS": "90",
                "ANGLES": "180 90", "SEED": "2"}
        if target == "bench-lammps-settings":
            base.update(A="neighbor 0.2 bin", B="neigh_modify every 1")
        for payload in PAYLOADS:
            variables = targets.Variables({**base, name: payload})
            error = targets.goal_values(variables, [target]).CHECK_ERROR
            assert name in error and "\n" not in error, (name, payload[:30], error[-300:])


#: every variable the Makefile defines or reads that is not a user's (Make's own automatic ones aside)
MAKEFILE_TEXT = (ROOT / "Makefile").read_text()
OWN_VARIABLES = sorted((set(re.findall(r"^([A-Z_][A-Z0-9_]*) *:?=", MAKEFILE_TEXT, flags=re.MULTILINE))
                        | set(re.findall(r"\$\(([A-Z_][A-Z0-9_]*)\)", MAKEFILE_TEXT)))
                       - set(READER) - {"MAKE", "MAKECMDGOALS", "MAKEFILE_LIST", "MAKEFLAGS"})
GUARD = ("USER_VARIABLES",)


def test_every_variable_of_the_makefiles_own_is_refused_on_the_command_line_and_ignored_in_the_environment(tmp_path):
    """Given on the command line, one line naming it (or ignored, for the guard's list, ``override``)
    and nothing runs; given in the environment, Make's own value is used and nothing runs either."""
    assert {"FIT_DIR", "DATA_SET", "PY", "FIT_SUFFIX", "CHECK_ERROR", "SHELL", "MAKE_LETTERS"} <= set(OWN_VARIABLES)
    mark = tmp_path / "INJECTED"
    payload = f"$(shell touch {mark})"  # Make text: the one kind of value Make itself would run
    for variable in OWN_VARIABLES:
        said = subprocess.run(["make", "--no-print-directory", "help", "THETA=90", f"{variable}={payload}"],
                              cwd=ROOT, capture_output=True, text=True)
        if variable in GUARD:
            assert said.returncode == 0 and "make help" in said.stdout
        else:
            assert said.returncode != 0 and f"{variable}: not a variable a user sets" in said.stderr, said.stderr
        assert str(mark) not in said.stderr and not mark.exists(), variable

    def from_environment(*variables):
        said = subprocess.run(["make", "--no-print-directory", "help", "fit", "-n", "PRESET=paper"], cwd=ROOT,
                              capture_output=True, text=True, env={**os.environ, **dict.fromkeys(variables, payload)})
        return said.returncode == 0 and str(mark) not in said.stdout and not mark.exists()

    # all at once (one Make); where that fails, the message names the ones that take the environment's value alone
    assert from_environment(*OWN_VARIABLES), [v for v in OWN_VARIABLES if not from_environment(v)]


def test_no_stage_imports_the_front_door():
    """``pipeline.targets`` calls the stages; a stage that imported it would run the front door's code."""
    import re

    from pipeline.paths import ROOT

    for path in sorted((ROOT / "pipeline").rglob("*.py")):
        if path.parent.name != "targets":
            assert not re.search(r"^\s*(from\s+\S*targets\s+import|import\s+\S*targets)", path.read_text(),
                                 flags=re.MULTILINE), path


def test_make_e_is_refused_before_the_environment_reaches_any_of_the_makefiles_own_variables(tmp_path):
    """Under -e (or MAKEFLAGS=e, or with other letters) the environment would replace every variable of the
    Makefile's own: Make stops at once, in one line, and nothing of the environment runs."""
    mark = tmp_path / "INJECTED"
    payload = {v: f"$(shell touch {mark})" for v in OWN_VARIABLES if v != "SHELL"}
    for flags, extra in ((["-e"], {}), ([], {"MAKEFLAGS": "e"}), ([], {"MAKEFLAGS": "ke"}), (["-ke"], {})):
        said = subprocess.run(["make", *flags, "--no-print-directory", "runs", "fit", "-n", "PRESET=paper"], cwd=ROOT,
                              capture_output=True, text=True, env={**os.environ, **payload, **extra})
        assert said.returncode != 0 and "make -e (or MAKEFLAGS=e)" in said.stderr, (flags, said.stderr[-300:])
        assert not mark.exists(), flags


HOSTILE_NAMES = ("$(shell touch {mark})", "a:b", "a b", "a#b", "a;touch {mark}", "a$$b", "`touch {mark}`")


@pytest.mark.parametrize("name", HOSTILE_NAMES)
def test_a_run_files_name_never_reaches_make(tmp_path, name):
    """A run file whose name or folder holds Make or shell syntax (every character Make treats specially) is a file
    like any other: ``make -n fit`` runs nothing of it, writes none of it where Make reads, and a later ``make``
    reads its include file as before."""
    mark = tmp_path / "INJECTED"
    name = name.format(mark=mark)
    made = [ROOT / "results" / "tiny" / "dem" / f"{name}.h5", ROOT / "results" / f"tiny-{name}" / "dem" / "theta090.h5"]
    try:
        for path in made:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(b"not a run")
        for _ in range(2):
            said = subprocess.run(["make", "--no-print-directory", "-n", "fit", "PRESET=tiny"], cwd=ROOT,
                                  capture_output=True, text=True, timeout=120)
            assert said.returncode == 0, said.stderr[-400:]
            assert not mark.exists()
            read = [ROOT / "results" / ".make" / "goals.stamp", *(ROOT / "results" / ".make" / "goals").iterdir()]
            assert all(name not in p.read_text() for p in read)
    finally:  # what the name made below each folder, whole (a name holding the mark's path makes nested folders)
        for base, path in zip((ROOT / "results" / "tiny" / "dem", ROOT / "results"), made, strict=True):
            top = base / path.relative_to(base).parts[0]
            shutil.rmtree(top) if top.is_dir() else top.unlink(missing_ok=True)


@pytest.mark.parametrize("kind", ["fifo", "folder"])
def test_a_run_file_that_is_not_a_regular_file_is_refused_in_one_line_naming_it(kind):
    """A FIFO named like a run (whose reading would wait forever) or a folder of that name: ``make fit`` stops at the
    fit's stamp in one line naming it, within seconds."""
    path = ROOT / "results" / "tiny-notafile0" / "dem" / "theta045.h5"
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.mkfifo(path) if kind == "fifo" else path.mkdir()
        said = subprocess.run(["make", "--no-print-directory", "fit", "PRESET=tiny"],
                              cwd=ROOT, capture_output=True, text=True, timeout=60)
        assert said.returncode != 0
        kind_said = "a FIFO" if kind == "fifo" else "a folder"
        assert f"results/tiny-notafile0/dem/theta045.h5 is {kind_said}, not a regular file" in said.stderr
    finally:
        path.rmdir() if path.is_dir() else path.unlink(missing_ok=True)
        path.parent.rmdir()
        path.parent.parent.rmdir()
