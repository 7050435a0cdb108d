"""A scene that answers while its engine runs C code. Python runs a signal's handler only once the engine hands
control back, so an engine stuck inside one call (a damaged restart file can make LAMMPS loop for ever) would
ignore SIGTERM and, orphaned, hold its run's lock. A thread watches instead: Python's C-level handler writes each
signal's number to a pipe at once (``signal.set_wakeup_fd``), and the driver's controller beats every few steps.

- A stop signal (or the launcher's death: the parent-death signal is SIGTERM) not followed by a beat within
  ``GRACE_SECONDS``: the process ends at once, exit status 128 + the signal, resumable from its last checkpoint.
- ``STALL_CPU_SECONDS`` of CPU without a beat (the engine is busy, not waiting): the process ends, exit status 2
  where it was loading its checkpoint (the folder cannot be resumed), else 3.
"""

import os
import select
import signal
import sys
import threading
import time

#: CPU-seconds (every thread) the process may spend between two beats; the longest legitimate stretch is a
#: checkpoint written or read, seconds in the paper's cell
STALL_CPU_SECONDS = 300.0
#: seconds a stop signal waits for the run loop before the process ends at once
GRACE_SECONDS = 60.0
LOADING = "loading its checkpoint"


class Watchdog:
    """The watching thread of this process (``start``); ``beat`` says the run loop is alive, ``doing`` what it is
    about (said in the error line)."""

    def __init__(self, stop_signals, stall_cpu_seconds=STALL_CPU_SECONDS, grace_seconds=GRACE_SECONDS):
        self.stop_signals = {int(s) for s in stop_signals}
        self.stall = float(stall_cpu_seconds)
        self.grace = float(grace_seconds)
        self.doing = "starting"
        self._beats = 0  # counted by the run loop; the thread reads the clocks, off the step loop
        self._read, write = os.pipe()
        os.set_blocking(write, False)
        signal.set_wakeup_fd(write, warn_on_full_buffer=False)  # main thread only, as signal.signal
        # created with the stop signals blocked in the caller (``driver.stop_signals_held``): they reach the main
        # thread only, whose handlers count them
        threading.Thread(target=self._watch, name="watchdog", daemon=True).start()

    def beat(self):
        self._beats += 1

    def _watch(self):
        signalled = None  # monotonic time of the first stop signal
        seen, beat_wall, beat_cpu = -1, 0.0, 0.0  # the last count seen, and when (to the poll's second) it moved
        while True:
            ready, _, _ = select.select([self._read], [], [], 1.0)
            if ready:
                for signum in os.read(self._read, 512):
                    if signum in self.stop_signals and signalled is None:
                        signalled, first = time.monotonic(), signum
            if self._beats != seen:
                seen, beat_wall, beat_cpu = self._beats, time.monotonic(), time.process_time()
            if signalled is not None and time.monotonic() - max(signalled, beat_wall) > self.grace:
                self._end(f"signal {first}: the engine has not come back to the run loop in {self.grace:g} s "
                          f"({self.doing}): stopped at once; rerun the same command to resume from the last "
                          "checkpoint", 128 + first)
            if time.process_time() - beat_cpu > self.stall:
                if self.doing == LOADING:
                    self._end(f"no progress in {self.stall:g} s of CPU {LOADING}: the checkpoint is damaged; rerun "
                              "with FRESH=1 (--fresh) to start the run again", 2)
                self._end(f"no progress in {self.stall:g} s of CPU ({self.doing}): the engine is stuck", 3)

    @staticmethod
    def _end(message, status):
        sys.stdout.flush()
        sys.stderr.write(f"error: {message}\n")
        sys.stderr.flush()
        os._exit(status)


_current = None


def start(stop_signals, **limits):
    """This process's watchdog (one per process; later calls return the first)."""
    global _current
    if _current is None:
        _current = Watchdog(stop_signals, **limits)
    return _current


def beat():
    """The run loop is alive (a no-op in a process without a watchdog)."""
    if _current is not None:
        _current.beat()


def doing(what):
    """What the run loop is about, for the error line; the CPU count starts again."""
    if _current is not None:
        _current.doing = what
        _current.beat()
