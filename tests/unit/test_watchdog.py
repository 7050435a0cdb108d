"""A scene whose engine is stuck inside one C call still answers SIGTERM and ends when it makes no progress
(``dem.core.watchdog``). The stuck engine is real C code: numpy's LAPACK, which like LAMMPS's library calls releases
Python's lock and runs for seconds without returning, so Python's own handlers cannot run."""

import os
import signal
import subprocess
import sys
import time

import pytest

from pipeline.paths import ROOT

#: each test runs a process that spends its seconds of CPU in LAPACK on purpose: with the slow tests (make test)
pytestmark = pytest.mark.slow

#: a process that starts its watchdog as ``driver.run_scene`` does, then either beats (a run that is alive) or sits
#: in C (one eigenvalue problem after another, each longer than the limits)
CHILD = """
import sys, time
import numpy as np
from dem.core import driver, watchdog
mode, stall, grace = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
with driver.stop_signals_held():
    watchdog.start(driver.STOP_SIGNALS, stall_cpu_seconds=stall, grace_seconds=grace)
stop = driver.stop_on_signals(lambda: "iteration 10")
watchdog.doing(watchdog.LOADING if mode == "loading" else "running")
print("ready", flush=True)
matrix = np.random.default_rng(0).random((1600, 1600))
if mode == "alive":
    end = None
    while end is None or time.monotonic() < end:
        watchdog.beat()
        np.linalg.eigvals(matrix[:200, :200])
        if stop["count"] and end is None:
            end = time.monotonic() + 3 * grace  # goes on beating past the grace, then stops by itself
    print("stopped by the run loop", flush=True)
    sys.exit(0)
while True:
    np.linalg.eigvals(matrix)
"""


def start(tmp_path, mode, stall, grace):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, str(script), mode, str(stall), str(grace)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    assert proc.stdout.readline().strip() == "ready"
    return proc


def finish(proc, timeout=30):
    tic = time.monotonic()
    out, err = proc.communicate(timeout=timeout)
    return proc.returncode, out, err, time.monotonic() - tic


def test_sigterm_to_an_engine_stuck_in_c_ends_the_process_after_the_grace(tmp_path):
    proc = start(tmp_path, "stuck", stall=100, grace=0.5)
    time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    status, _, err, seconds = finish(proc)
    assert status == 128 + signal.SIGTERM, err
    assert seconds < 4
    assert err.count("error:") == 1 and "signal 15: the engine has not come back to the run loop in 0.5 s" in err
    assert "resume from the last checkpoint" in err


def test_an_engine_that_spends_cpu_without_progress_is_stopped_with_one_line(tmp_path):
    status, _, err, _ = finish(start(tmp_path, "stuck", stall=0.5, grace=100))
    assert status == 3 and err.strip() == "error: no progress in 0.5 s of CPU (running): the engine is stuck"


def test_no_progress_while_loading_the_checkpoint_is_a_damaged_folder(tmp_path):
    status, _, err, _ = finish(start(tmp_path, "loading", stall=0.5, grace=100))
    assert status == 2 and "no progress in 0.5 s of CPU loading its checkpoint" in err and "FRESH=1" in err


def test_a_run_loop_that_keeps_beating_is_left_to_stop_by_itself(tmp_path):
    proc = start(tmp_path, "alive", stall=0.5, grace=0.3)
    time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    status, out, err, _ = finish(proc)
    assert status == 0 and "stopped by the run loop" in out and "error:" not in err, err
    assert "stopping at the next checkpoint (iteration 10)" in out
