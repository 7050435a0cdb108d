"""A run asked to stop (SIGINT, SIGTERM, a scheduler's SIGUSR1) at any moment stops at a checkpoint: while it is
still being built or resumed, and while a one-rank LAMMPS run ``exec``s itself to go on from its checkpoint
(``Scene.reload``)."""

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

from dem.core import driver
from pipeline.paths import ROOT

#: a process that, told ``block``, blocks the stop signals, is warned (its main thread, the one the block holds), and
#: execs itself as a reloading scene does: the warning must reach the new process's handlers
CHILD = """
import os, signal, sys, threading
from dem.core import driver
if sys.argv[1] in ("block", "no-block"):
    signal.signal(signal.SIGUSR1, signal.SIG_DFL)  # as a scene starts (whatever its parent ignored)
    if sys.argv[1] == "block":
        driver.block_stop_signals()
    signal.pthread_kill(threading.main_thread().ident, signal.SIGUSR1)
    os.execv(sys.executable, [sys.executable, __file__, "after"])
stop = driver.stop_on_signals(lambda: "iteration 10")
print("stop count", stop["count"], "signal", stop["signal"])
"""


def run_child(tmp_path, code: str, *args: str) -> subprocess.CompletedProcess:
    script = tmp_path / "child.py"
    script.write_text(code)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, env=env, timeout=60)


def test_a_warning_during_the_exec_to_the_checkpoint_is_taken_by_the_new_process(tmp_path):
    proc = run_child(tmp_path, CHILD, "block")
    assert proc.returncode == 0, proc.stderr
    assert "stopping at the next checkpoint (iteration 10)" in proc.stdout
    assert f"stop count 1 signal {int(signal.SIGUSR1)}" in proc.stdout


def test_without_the_block_the_same_warning_ends_the_process(tmp_path):
    proc = run_child(tmp_path, CHILD, "no-block")
    assert proc.returncode == -signal.SIGUSR1 and "stop count" not in proc.stdout


def test_a_signal_while_the_run_is_being_built_names_the_first_checkpoint(tmp_path):
    code = """
import os, signal
from dem.core import driver

class Building:
    run = None

stop = driver.stop_on_signals(lambda: driver.next_stop(Building()))
os.kill(os.getpid(), signal.SIGUSR1)
print("stop count", stop["count"])
"""
    proc = run_child(tmp_path, code)
    assert proc.returncode == 0, proc.stderr
    assert "(the first checkpoint, once the run is built or resumed)" in proc.stdout and "stop count 1" in proc.stdout


def blocked_signals(thread_id: int) -> set[int]:
    """The signals thread ``thread_id`` of this process blocks (its ``SigBlk`` mask in /proc)."""
    for line in Path(f"/proc/self/task/{thread_id}/status").read_text().splitlines():
        if line.startswith("SigBlk:"):
            mask = int(line.split()[1], 16)
            return {k for k in range(1, 65) if mask >> (k - 1) & 1}
    raise AssertionError(f"no SigBlk line for thread {thread_id}")


def test_a_thread_started_while_the_stop_signals_are_held_never_takes_one():
    """A library's thread started inside ``stop_signals_held`` (MPI's, when LAMMPS starts) keeps the stop signals
    blocked, so the kernel hands a warning to the main thread alone; the main thread's own mask comes back."""
    before = blocked_signals(threading.get_native_id())
    started, release = threading.Event(), threading.Event()
    ids = {}

    def library_thread():
        ids["held"] = threading.get_native_id()
        started.set()
        release.wait(10)

    with driver.stop_signals_held():
        thread = threading.Thread(target=library_thread)
        thread.start()
        started.wait(10)
    try:
        stops = {int(s) for s in driver.STOP_SIGNALS}
        assert stops <= blocked_signals(ids["held"])
        assert blocked_signals(threading.get_native_id()) == before and not stops & before
    finally:
        release.set()
        thread.join()
