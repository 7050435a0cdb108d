"""The real Yade: contact law, a tiny run end to end into HDF5, bit-identical resume, failures."""

import json
import shutil
import signal
import subprocess
import sys

import numpy as np
import pytest

from dem.core import protocol
from pipeline import spec as run_spec
from pipeline.dataset.dem_file import SCHEMA, load
from pipeline.paths import ROOT
from pipeline.runs import scripts
from tests.helpers import assert_contact_law

pytestmark = pytest.mark.yade


def launcher(*args, results):
    return [sys.executable, "-m", "pipeline.runs", "run", *args, "--results", str(results)]


def run(*args, results, **kw):
    return subprocess.run(launcher(*args, results=results), capture_output=True, text=True, cwd=ROOT, **kw)


def test_yade_is_installed():
    assert shutil.which("yade"), "Yade is missing: `make system` installs it (the DEM tests must not be skipped)"


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    results = tmp_path_factory.mktemp("results")
    proc = run("--theta", "90", "--preset", "tiny", results=results)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return results, proc.stdout


def test_collisions_restitution_stiffness_ratio_and_sliding(tmp_path):
    spec = run_spec.resolve(90, "paper")
    (tmp_path / "spec.json").write_text(json.dumps(spec.to_dict()))
    subprocess.run(scripts.command("dem.tools.yade_collision", tmp_path / "spec.json", tmp_path / "out.json"),
                   check=True, capture_output=True, cwd=tmp_path, env=scripts.environment())
    assert_contact_law(json.loads((tmp_path / "out.json").read_text()), spec)


def test_tiny_run_end_to_end_into_hdf5(tiny_run):
    results, stdout = tiny_run
    assert "ETA" in stdout and "steps/s" in stdout
    spec = run_spec.resolve(90, "tiny")
    run_file = load(run_spec.output_path(spec, results))
    assert run_file.provenance["preset"] == "tiny" and run_file.provenance["yade_version"].startswith("20")
    assert run_file.spec == spec
    n = len(run_file.raw["strain"])
    expected = int(round((spec.pre_strain + spec.period_strain) / spec.sample_strain)) + 1
    assert n == expected
    assert run_file.raw["fabric"].shape == (n, 3, 3) and run_file.raw["profile_velocity"].shape[::2] == (n, 3)
    assert all(unit for unit in run_file.units.values())
    assert run_file.units["raw/stress_contact"] == "p" and run_file.units["raw/time"] == "d*sqrt(rho/p)"
    with __import__("h5py").File(run_file.path) as f:  # raw, contacts and provenance only: nothing derived is stored
        assert set(f) == {"provenance", "parameters", "raw", "contacts"} and f.attrs["schema_version"] == 4
    A = run_file.series["A"]
    np.testing.assert_allclose(np.trace(A, axis1=1, axis2=2), 0, atol=1e-12)
    np.testing.assert_allclose(A, np.swapaxes(A, 1, 2), atol=1e-15)
    assert np.all(run_file.series["S"] >= -1e-12)
    # the wall holds p on average; the bulk carries it (tension-positive stress: mean stress > 0 is compression)
    assert abs(np.mean(run_file.raw["wall_stress_error_mean"])) < 0.1
    assert np.mean(run_file.series["mean_stress_over_p"]) == pytest.approx(1.0, abs=0.3)
    # the shear stress follows the wall direction: tau12 > 0 while phi = 0, tau32 > 0 while phi = 90
    first = (run_file.raw["strain"] > 0.1) & (run_file.raw["strain"] < 0.2)
    second = run_file.raw["strain"] > 0.3
    assert run_file.series["tau_over_p"][first, 0, 1].mean() > 0.1
    assert run_file.series["tau_over_p"][second, 1, 2].mean() > 0.1
    cycle = run_file.cycle
    assert cycle["strain"].shape == (41,) and cycle["tau_over_p"].shape == (41, 3, 3)
    with __import__("h5py").File(run_file.path) as f:
        assert f.attrs["schema"] == SCHEMA and "conventions" in f.attrs
    assert not list(results.rglob("*.tmp*")) and not list(results.rglob("checkpoint*"))
    # rerunning the same command does nothing
    again = run("--theta", "90", "--preset", "tiny", results=results)
    assert again.returncode == 0 and "up to date" in again.stdout


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory):
    """A results folder whose tiny run was interrupted at strain 0.1: its run folder holds a checkpoint."""
    results = tmp_path_factory.mktemp("interrupted")
    proc = subprocess.Popen(launcher("--theta", "90", "--preset", "tiny", results=results), cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for line in proc.stdout:
        if "strain +0.100" in line:
            proc.send_signal(signal.SIGINT)
            break
    output = proc.stdout.read()
    assert proc.wait() == 130, output
    assert "interrupted: checkpoint" in output
    assert not run_spec.output_path(run_spec.resolve(90, "tiny"), results).exists()
    return results


def test_interrupted_and_resumed_run_is_bit_identical(tiny_run, interrupted, tmp_path):
    reference = load(run_spec.output_path(run_spec.resolve(90, "tiny"), tiny_run[0]))
    shutil.copytree(interrupted, tmp_path, dirs_exist_ok=True)
    resumed = run("--theta", "90", "--preset", "tiny", results=tmp_path)
    assert resumed.returncode == 0 and "resumed from checkpoint" in resumed.stdout
    again = load(run_spec.output_path(run_spec.resolve(90, "tiny"), tmp_path))
    for key, value in reference.raw.items():
        np.testing.assert_array_equal(again.raw[key], value, err_msg=key)


#: Python that changes a saved scene's engines (``sys.argv[1]`` the checkpoint, ``sys.argv[2]`` a file that the
#: planted engine would create): every way a saved scene can carry an engine that ``build`` does not make
TAMPERINGS = {
    "a second PyRunner": "O.engines = O.engines + [PyRunner(iterPeriod=1, command=touch)]",
    "engines waiting for the next step": (  # the controller saves the scene after it set engines for the next step
        "O.engines[-1].iterPeriod = 1\nO.engines[-1].command = 'O.engines = list(O.engines) + "
        "[PyRunner(iterPeriod=1, command=touch)]; O.save(sys.argv[1]); O.stopAtIter = O.iter + 1'\nO.run()\nO.wait()\n"
        "O.load(sys.argv[1])\nassert len(O._nextEngines) == 6"),
    "an engine that writes files": "O.engines = O.engines + [wrapper.VTKRecorder(iterPeriod=1, fileName=sys.argv[2])]",
    "the controller's label on another engine": "O.engines[-1].label = ''; O.engines[0].label = 'controller'",
    "a dead engine": "O.engines[1].dead = True",
}


def tamper(checkpoint, planted, how):
    """Plant ``TAMPERINGS[how]`` in the saved scene ``checkpoint`` (Yade's python)."""
    touch = f"open({str(planted)!r}, 'w').close()"
    code = (f"import sys\nfrom dem.yade.lib import O, PyRunner, wrapper\ntouch = {touch!r}\nO.load(sys.argv[1])\n"
            f"{TAMPERINGS[how]}\nO.save(sys.argv[1])\n")
    proc = subprocess.run([scripts.engine_python(), "-c", code, str(checkpoint), str(planted)], capture_output=True,
                          text=True, cwd=ROOT, env=scripts.environment())
    assert proc.returncode == 0, proc.stderr[-500:]


def test_a_checkpoint_with_a_planted_pyrunner_is_refused_and_runs_nothing(interrupted, tmp_path):
    """A checkpoint is data (docs/dem.md): the launcher refuses it in one line, and the planted Python never runs."""
    shutil.copytree(interrupted, tmp_path, dirs_exist_ok=True)
    tamper(run_spec.work_dir(run_spec.resolve(90, "tiny"), tmp_path) / "checkpoint.yade.gz", tmp_path / "planted",
           "a second PyRunner")
    resumed = run("--theta", "90", "--preset", "tiny", results=tmp_path)
    output = resumed.stdout + resumed.stderr
    assert resumed.returncode == 2, output
    assert "holds engines that the scene does not make" in output and "a checkpoint is data" in output
    assert not (tmp_path / "planted").exists()


def test_every_way_of_planting_an_engine_in_a_saved_scene_is_refused(interrupted, tmp_path):
    """``load_scene`` on the interrupted run's checkpoint (accepted) and on a copy carrying each of ``TAMPERINGS``
    (each refused, nothing planted run), in one Yade process."""
    work = run_spec.work_dir(run_spec.resolve(90, "tiny"), interrupted)
    paths = [str(work / "checkpoint.yade.gz")] + [str(tmp_path / f"{i}.yade.gz") for i in range(len(TAMPERINGS))]
    for path, how in zip(paths[1:], TAMPERINGS, strict=True):
        shutil.copy(paths[0], path)
        tamper(path, tmp_path / "planted", how)
    code = ("import json, sys\nfrom dem.yade import scene\nfrom dem.core.spec import read_spec\n"
            "spec = read_spec(sys.argv[1])\nrefused = {}\nfor path in sys.argv[2:]:\n"
            "    try:\n        scene.load_scene(path, spec)\n        refused[path] = False\n"
            "    except scene.ForeignScene as exc:\n        refused[path] = 'does not make' in str(exc)\n"
            "print(json.dumps(refused))\n")
    proc = subprocess.run([scripts.engine_python(), "-c", code, str(work / "spec.json"), *paths], capture_output=True,
                          text=True, cwd=ROOT, env=scripts.environment())
    assert proc.returncode == 0, proc.stderr[-500:]
    refused = json.loads(proc.stdout.strip().splitlines()[-1])
    assert refused == {path: path != paths[0] for path in paths}
    assert not (tmp_path / "planted").exists()


def test_a_run_that_goes_wrong_stops_with_a_diagnostic(tmp_path):
    proc = run("--theta", "90", "--preset", "tiny", "--set", "compaction_max_time=5", results=tmp_path)
    assert proc.returncode == 3
    assert "error: compaction did not converge within t = 5.0" in proc.stdout
    assert not list(tmp_path.rglob("*.h5"))


def test_bad_input_fails_before_yade_starts_as_a_process(tmp_path):
    """The launcher as a shell runs it (every bad value in-process: tests/unit/test_bad_inputs.py)."""
    proc = run("--theta", "ninety", results=tmp_path)
    assert proc.returncode == 2 and proc.stderr.strip() == "error: theta='ninety' is not a number"
    assert not any(tmp_path.iterdir())


def test_a_second_run_of_the_same_spec_is_refused(tmp_path):
    import fcntl

    lock_path = run_spec.work_dir(run_spec.resolve(90, "tiny"), tmp_path).with_suffix(".lock")
    lock_path.parent.mkdir(parents=True)
    with open(lock_path, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        proc = run("--theta", "90", "--preset", "tiny", results=tmp_path)
    assert proc.returncode == 2 and "is in use by another run of the same spec" in proc.stderr


@pytest.mark.parametrize("preset, seed, box_growth", [("tiny", 1, 1.0), ("tiny", 4, 1.25), ("quick", 2, 1.0),
                                                      ("paper", 3, 1.0)])
def test_the_numpy_cloud_is_yades_makecloud_bit_for_bit(preset, seed, box_growth):
    """``dem.core.cell.random_cloud`` against Yade's ``SpherePack.makeCloud`` in Debian's Yade, one process per cloud
    (Yade seeds its generator once per process): the same centres and radii to the last bit, so the committed runs'
    grains are the ones drawn without Yade."""
    code = (
        "import json, sys\n"
        "import numpy as np\n"
        "from dem.yade.lib import pack\n"
        "from dem.core import cell\n"
        "lo, hi, r, fuzz, n, seed = json.loads(sys.argv[1])\n"
        "ours = cell.random_cloud(lo, hi, r, fuzz, n, cell.canonical_uniforms(seed))\n"
        "sp = pack.SpherePack()\n"
        "made = sp.makeCloud(tuple(lo), tuple(hi), rMean=r, rRelFuzz=fuzz, num=n, periodic=False, seed=seed)\n"
        "yade = (np.array([tuple(c) for c, _ in sp]).reshape(-1, 3), np.array([r for _, r in sp]))\n"
        "print(json.dumps([made, len(ours[1]), bool(np.array_equal(ours[0], yade[0])),\n"
        "                  bool(np.array_equal(ours[1], yade[1]))]))\n")
    spec = run_spec.resolve(180, preset)
    n = protocol.grain_count(spec)
    width, top = spec.width_d, 1 + spec.gap_d * spec.fill_packing_fraction / 0.35 * box_growth
    args = [[0, 1.7, 0], [width, top, width], 0.25, 0.5, n, seed + 1]
    proc = subprocess.run([scripts.engine_python(), "-c", code, json.dumps(args)], capture_output=True, text=True,
                          cwd=ROOT, env=scripts.environment())
    assert proc.returncode == 0, proc.stderr[-500:]
    made, ours, same_centres, same_radii = json.loads(proc.stdout.strip().splitlines()[-1])
    assert made == ours and same_centres and same_radii
