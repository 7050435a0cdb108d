"""The experiment's driver, the same for every engine: the wall controller, compaction, the Fig. 1 protocol,
sampling, the checks, progress, checkpoints and the run loop (Sec. 2 and Fig. 1 of Rojas & Kamrin 2025).

An engine adapter (``dem/yade/scene.py`` for Yade, ``dem/lammps/scene.py`` for LAMMPS) subclasses :class:`Experiment`
with the few things only an engine knows (its clock, the walls' force and motion, the contact and grain arrays)
and gives :func:`run_scene` a scene object that builds, saves, loads and advances it. Every measurement is
``dem.core.measure``'s, on the arrays the adapter hands over. Units: d = p = rho = 1 (time in d sqrt(rho/p)); strain
t*gamma_dot.

Protocol (strain s = t*gamma_dot measured from the start of the first period): compaction under p -> s in
[-pre_strain, 0): phi = theta -> n_cycles periods with phi = 0 for s mod T in [0, rotate_at) and phi = theta after.
The top wall moves with U s(phi) + v_y e2, the bottom wall with -U s(phi), s(phi) = cos(phi) e1 + sin(phi) e3,
U = gamma_dot H0 / 2 with H0 the gap when shearing starts; v_y = (sigma_wall/p - 1) H (delta/d) / control_time holds
the normal stress on the top wall at p.

Exit status: 0 done (raw.npz written), 2 the run folder cannot be resumed, 3 the run went wrong (diagnostic on
stderr), 4 the disk cannot take the run's files, 130/143/138 interrupted by SIGINT/SIGTERM/SIGUSR1 after writing a
checkpoint.
"""

import contextlib
import math
import os
import signal
import sys
import time

import numpy as np

from dem.core import budget, checks, contract, measure, neighbours, protocol, schema, watchdog
from dem.core.rawfile import DISK_ERRORS, DISK_FULL, DiskError, require_free, save_npz, stack, write_raw, write_status
from dem.core.state import RunState

STATUS = "status.json"  # the run's progress, read by pipeline.runs.state
#: files of a run in progress, removed once its raw.npz is written
SCRATCH_PREFIXES = ("checkpoint", "samples_", "restart_")


def initial_state(spec, **engine_state):
    """The persistent state of a new run, with what the engine built (``RunState``'s cell and engine entries)."""
    return RunState(next_checkpoint=spec.checkpoint_steps, **engine_state)


class Experiment:
    """The running experiment. Everything persistent lives in ``self.state`` (saved with each checkpoint); an
    engine's subclass provides the members of ``dem.core.contract.EngineRun`` and sets ``radius`` and ``mass``
    (the grains').
    Where several processes run one scene (MPI ranks), each drives the same protocol on the same gathered data
    and only the ``writer`` writes files."""

    writer = True
    #: the near pairs searched at each tracking point (``dem.core.neighbours``); off only in ``make bench-dem``'s
    #: ``budget`` mode, which measures what the search costs (the rows then hold empty shells)
    neighbour_search = True

    def __init__(self, run_dir, spec, state):
        self.run_dir = run_dir
        self.spec = spec
        self.state = state
        self.area = spec.width_d ** 2
        self.gain = spec.gap_d * spec.overlap_ratio / spec.control_time
        self.gamma_dot = spec.inertial_number  # I = d gamma_dot / sqrt(p/rho) with d = p = rho = 1
        self.samples, tracked = load_samples(run_dir, state.samples_file)
        self.sample_strains = protocol.sample_strains(spec)
        self.track_strains = protocol.track_strains(spec)
        try:
            self.tracker = budget.ContactTracker(tracked or None) if self.track_strains else None
        except ValueError as exc:
            damaged(f"{run_dir}: {exc}")
        self.failure = None
        self.last_print = (time.time(), self.iteration())
        self.next_percent = 0.0

    def inner_planes(self):
        """Heights of the walls' inner planes (centres of their rough layers)."""
        y_bottom, y_top = self.wall_heights()
        return y_bottom + self.state.bottom_inner_offset, y_top + self.state.top_inner_offset

    def wall_stress(self):
        """Normal stress on the top wall (force of the grains along +e2 per cell area; p > 0)."""
        return self.wall_force()[1] / self.area

    # the controller: every control_every_steps steps
    def control(self):
        tic = time.perf_counter()
        watchdog.beat()
        st = self.state
        err = self.wall_stress() - 1.0
        vy = self.gain * err
        if st.phase == "compaction":
            vy = max(-0.1, min(0.1, vy))
            self.move_walls((0.0, vy, 0.0), None)
            self.compaction_check(err)
        elif st.phase == "shear":
            st.err_sum += err
            st.err_n += 1
            st.err_max = max(st.err_max, abs(err))
            strain = protocol.strain(self.time(), st.t_shear0, self.gamma_dot, self.spec)
            phi = math.radians(protocol.direction_deg(strain, self.spec))
            u = (st.wall_speed * math.cos(phi), 0.0, st.wall_speed * math.sin(phi))
            self.move_walls((u[0], u[1] + vy, u[2]), (-u[0], -u[1], -u[2]))
            if self.sample_due(strain) or (st.next_track < len(self.track_strains)
                                           and strain >= self.track_strains[st.next_track] - protocol.EPS):
                self.observe(strain)
        st.callback_seconds += time.perf_counter() - tic

    def compaction_check(self, err):
        st = self.state
        now, t = time.time(), self.time()
        # the walls' heights at every call, whatever this process's clock says: where MPI ranks run one scene they
        # are a reduction over the ranks, which every rank must make at the same step; only the printing may follow
        # a rank's own clock
        y_bottom, y_top = self.inner_planes()
        if now - self.last_print[0] > 10:
            rate = (self.iteration() - self.last_print[1]) / (now - self.last_print[0])
            print(f"compaction: t = {t:.1f}, sigma_wall/p - 1 = {err:+.3f}, gap = {y_top - y_bottom:.2f} d, "
                  f"{rate:.0f} steps/s", flush=True)
            self.last_print = (now, self.iteration())
        # the wall stress rings after compaction (more so in a large cell): judge its mean over a window
        if st.hold_since is None:
            st.hold_since, st.hold_sum, st.hold_n = t, 0.0, 0
        st.hold_sum += err
        st.hold_n += 1
        if t - st.hold_since >= self.spec.compaction_hold_time:
            mean = st.hold_sum / st.hold_n
            st.hold_since = None
            if abs(mean) < self.spec.compaction_tolerance:
                st.phase, st.t_shear0, st.gap0 = "shear", t, y_top - y_bottom
                st.wall_speed = self.gamma_dot * (y_top - y_bottom) / 2
                print(f"compaction done at t = {t:.1f}: gap H0 = {st.gap0:.3f} d, "
                      f"U = {st.wall_speed:.3g}; shearing", flush=True)
        if t > self.spec.compaction_max_time:
            self.fail(f"compaction did not converge within t = {self.spec.compaction_max_time} "
                      f"(sigma_wall/p - 1 = {err:+.3f})")

    # sampling and tracking
    def sample_due(self, strain):
        return strain >= self.sample_strains[self.state.next_sample] - protocol.EPS

    def observe(self, strain):
        """Gather the contacts once (the grains too where a sample is due or the contacts are tracked: the near
        pairs need their positions): track them where a tracking point is due (every sample is one) and sample."""
        tic = time.perf_counter()
        contacts, grains = self.gather(grains=self.sample_due(strain) or (self.tracker is not None
                                                                           and self.neighbour_search))
        y_bottom, y_top = self.inner_planes()
        region = (y_bottom + self.spec.region_margin_d, y_top - self.spec.region_margin_d)
        if self.tracker is not None:
            self.track(strain, contacts, grains, region)
        if self.sample_due(strain):
            self.sample(strain, contacts, grains, (y_bottom, y_top), region)
        else:  # a tracking point alone: what the contact budget costs beyond the samples
            self.state.track_seconds += time.perf_counter() - tic

    def track(self, strain, contacts, grains, region):
        """A tracking point of the contact budget (``dem.core.budget``) and of the near pairs
        (``dem.core.neighbours``): every target up to ``strain`` is done."""
        st = self.state
        while st.next_track < len(self.track_strains) and self.track_strains[st.next_track] < strain + protocol.EPS:
            st.next_track += 1
        id1, id2, normal = contacts["id1"], contacts["id2"], contacts["normal"]
        internal = (id1 >= st.first_grain) & (id2 >= st.first_grain)
        inside = internal & measure.in_slab(contacts["point"][:, 1], *region)
        normal_force = np.einsum("ci,ci->c", contacts["force"][inside], normal[inside])
        all_keys = np.unique(neighbours.pair_keys(id1[internal], id2[internal]))
        near = (neighbours.near_pairs(grains["id"], grains["pos"], grains["radius"], self.spec.width_d, all_keys)
                if self.neighbour_search else neighbours.NearPairs.empty())
        self.tracker.step(neighbours.pair_keys(id1[inside], id2[inside]), normal[inside], normal_force, all_keys,
                          protocol.direction_deg(strain, self.spec), near, region)

    def sample(self, strain, contacts, grains, walls, region):
        st = self.state
        y_bottom, y_top = walls
        gap = y_top - y_bottom
        n_bins = max(1, int(round(st.gap0 / self.spec.profile_bin_d)))
        edges = np.linspace(y_bottom, y_top, n_bins + 1)
        row = measure.measure(contacts, grains, st.first_grain, self.area, region, edges)
        if self.tracker is not None:
            row.update(self.tracker.row())
        row.update(
            iteration=self.iteration(), time=self.time(), strain=strain,
            direction_deg=protocol.direction_deg(strain, self.spec), gap=gap,
            region=list(region), profile_edges=edges, **self.wall_record(),
            wall_stress_error_mean=st.err_sum / max(st.err_n, 1), wall_stress_error_max=st.err_max,
        )
        st.err_sum, st.err_n, st.err_max = 0.0, 0, 0.0
        schema.check_row(row, contacts=self.tracker is not None)
        self.samples.append(row)
        st.next_sample += 1
        self.check(row, grains, y_bottom, y_top)
        self.progress(strain, row)
        if st.next_sample >= len(self.sample_strains) and self.failure is None:
            st.phase = "done"
            self.stop_after_this_step()

    def check(self, row, grains, y_bottom, y_top):
        """Stop with a diagnostic when the run goes wrong (``dem/core/checks.py``). The wall stress is judged from the
        second sample on: the first, where the shear starts, holds a single controller call's error, which still
        rings after compaction (by +54 % in LAMMPS's paper cell, whose compaction's windowed mean had passed)."""
        st = self.state
        problem = checks.sample_problem(row, grains["id"], grains["pos"], grains["vel"], (y_bottom, y_top),
                                        st.gap0)
        if problem is None and len(self.samples) > 1:
            interval = row["strain"] - self.samples[-2]["strain"]
            st.alarm_strain, problem = checks.stress_alarm(row["wall_stress_error_mean"], st.alarm_strain,
                                                              interval, self.spec)
        if problem is not None:
            self.fail(problem)

    def progress(self, strain, row):
        total = protocol.end_strain(self.spec) + self.spec.pre_strain
        done = (strain + self.spec.pre_strain) / total
        now = time.time()
        if done * 100 < self.next_percent and now - self.last_print[0] < 60:
            return
        self.next_percent = math.floor(done * 50 + 1e-9) * 2 + 2
        rate = (self.iteration() - self.last_print[1]) / max(now - self.last_print[0], 1e-9)
        steps_left = (total - strain - self.spec.pre_strain) / (self.gamma_dot * self.dt())
        eta = steps_left / rate if rate > 0 else float("nan")
        print(f"[{done:4.0%}] strain {strain:+.3f} / {protocol.end_strain(self.spec):.2f}  "
              f"sigma_wall/p - 1 = {row['wall_stress_error_mean']:+.2%}  tau12/p = {row['stress_contact'][0, 1]:+.3f}  "
              f"{rate:.0f} steps/s  ETA {format_seconds(eta)}", flush=True)
        if self.writer:
            write_status(os.path.join(self.run_dir, STATUS), {
                "percent": round(100 * done, 1), "strain": strain, "steps_per_second": round(rate, 1),
                "eta_seconds": eta if math.isfinite(eta) else None, "updated": time.time()})
        self.last_print = (now, self.iteration())

    def fail(self, message):
        self.failure = message
        self.state.phase = "failed"
        self.stop_after_this_step()


def format_seconds(seconds):
    if not math.isfinite(seconds):
        return "?"
    seconds = int(seconds)
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    return f"{seconds // 60}m{seconds % 60:02d}s"


# ---------------------------------------------------------------- persistence (atomic: temp file, then rename)
#: the contact tracker's arrays in a checkpoint's samples file (``budget.ContactTracker.to_arrays``)
TRACKER_PREFIX = "tracker__"


def load_samples(run_dir, name):
    """The sample rows saved beside a checkpoint, and the contact tracker's arrays saved with them (``{}`` for
    none)."""
    if not name:
        return [], {}
    with np.load(os.path.join(run_dir, name), allow_pickle=False) as data:
        columns = {key: data[key] for key in data.files}
    tracked = {key[len(TRACKER_PREFIX):]: columns.pop(key) for key in list(columns) if key.startswith(TRACKER_PREFIX)}
    n = len(next(iter(columns.values()))) if columns else 0
    return [{key: columns[key][i] for key in columns} for i in range(n)], tracked


def checkpoint(run, scene):
    """Samples first (a new file), then the scene that names it (``scene.save``); old sample files go last. The
    disk's free space is checked first (twice the last checkpoint and the samples); ``scene.save`` checks and syncs
    the new checkpoint before it replaces the old one; a disk error raises ``DiskError`` with the previous
    checkpoint intact."""
    name = f"samples_{run.iteration():012d}.npz"
    columns = stack(run.samples)
    if run.tracker is not None:
        columns.update({TRACKER_PREFIX + key: value for key, value in run.tracker.to_arrays().items()})
    require_free(run.run_dir, 2 * scene.checkpoint_bytes() + 2 * sum(a.nbytes for a in columns.values()),
                 "a checkpoint")
    previous = run.state.samples_file
    try:
        if run.writer:
            save_npz(os.path.join(run.run_dir, name), columns)
        run.state.samples_file = name
        scene.save(run)
    except OSError as exc:
        if exc.errno in DISK_ERRORS:
            raise DiskError(f"cannot write in {run.run_dir} ({os.strerror(exc.errno)})") from None
        raise
    if previous and previous != name and run.writer:
        os.remove(os.path.join(run.run_dir, previous))


def write_run_raw(run, engine_meta):
    """``raw.npz``: every sample and the run's meta data (the engine's entries in ``engine_meta``)."""
    st = run.state
    meta = {
        "spec": run.spec.to_dict(), **engine_meta, "dt": run.dt(), "kn": st.kn, "kt": st.kt, "cn": st.cn,
        "ct": st.ct, "n_grains": st.n_grains, "gap0": st.gap0, "wall_speed": st.wall_speed,
        "gamma_dot_nominal": run.gamma_dot, "t_shear0": st.t_shear0, "iterations": run.iteration(),
        "callback_seconds": st.callback_seconds, "track_seconds": st.track_seconds, "loop_seconds": st.loop_seconds,
        "cpu_seconds": st.cpu_seconds,
        "grain_radius": run.radius.tolist(),
    }
    write_raw(os.path.join(run.run_dir, "raw.npz"), stack(run.samples), meta)


# ---------------------------------------------------------------- main loop
def damaged(message):
    """A run folder that cannot be resumed: one line, exit status 2."""
    sys.stderr.write(f"error: {message}; rerun with FRESH=1 (--fresh) to start the run again\n")
    sys.exit(2)


#: the signals that ask a run to stop (``stop_on_signals``)
STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM, signal.SIGUSR1, signal.SIGUSR2}


def stop_on_signals(describe_stop):
    """Count SIGINT/SIGTERM/SIGUSR1 into the returned dict (``count``, ``signal``); the first one prints
    ``describe_stop()``. SIGUSR1 (a scheduler's warning before a time limit) only ever asks for the checkpoint stop;
    SIGUSR2 asks for the stop at once (the second signal, as the launcher passes it through ``mpirun``, which would
    kill its ranks on SIGINT or SIGTERM). The handlers in place, the signals are unblocked: one that came while a
    process ``exec``ed itself with them blocked (``block_stop_signals``) is taken now, not lost nor fatal."""
    stop = {"count": 0, "signal": 0}

    def on_signal(signum, _frame):
        stop["count"] += 1
        stop["signal"] = signum
        if stop["count"] == 1:
            print(f"signal {signum}: stopping at the next checkpoint ({describe_stop()}); signal again to stop at "
                  "once", flush=True)

    def on_usr1(signum, frame):
        if stop["count"] == 0:
            on_signal(signum, frame)

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    def on_usr2(signum, frame):
        if stop["count"] == 0:
            on_signal(signum, frame)
        stop["count"] = max(stop["count"], 2)

    signal.signal(signal.SIGUSR1, on_usr1)
    signal.signal(signal.SIGUSR2, on_usr2)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
    return stop


@contextlib.contextmanager
def stop_signals_held():
    """The stop signals blocked in this thread while the block runs: the threads a library starts inside it (MPI's)
    keep the block for good, so a stop signal only ever reaches the main thread. Else, while the main thread blocks
    them before it ``exec``s itself (``block_stop_signals``), the kernel hands one to such a thread: it trips the
    handler of a process about to be replaced, and the warning is lost."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def block_stop_signals():
    """Hold the stop signals back (before ``exec``: a process starts with the default actions, which would end it on
    SIGUSR1 before its handlers are in place; the mask and the pending signals pass through ``exec``)."""
    signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)


def next_stop(scene) -> str:
    """Where a run asked to stop will stop: its next checkpoint's iteration, or the first one once it is built or
    resumed."""
    if scene.run is None:
        return "the first checkpoint, once the run is built or resumed"
    return f"iteration {scene.run.state.next_checkpoint}"


def cores() -> int:
    """Cores this process's run uses: its MPI ranks (``mpirun``) times its OpenMP threads."""
    return int(os.environ.get("OMPI_COMM_WORLD_SIZE", "1")) * int(os.environ.get("OMP_NUM_THREADS", "1"))


def count_seconds(state, seconds):
    """Add ``seconds`` of the run's loop (wall time) and its cost in CPU-seconds (times ``cores()``, which may
    change between sessions) to ``state``; a checkpoint from before CPU-seconds were counted ran on one core."""
    state.loop_seconds += seconds
    state.cpu_seconds += seconds * cores()


def run_scene(scene):
    """Build or resume ``scene``'s run, then run it; at every checkpoint save, reload and go on (see
    ``checkpoint_steps``).

    Every run, interrupted or not, continues from each checkpoint as freshly loaded, so resuming is bit-identical
    (one thread). A first SIGINT/SIGTERM stops at the next checkpoint; a second one stops within a few steps (the
    run then resumes correctly but not bit-identically). ``scene`` is a ``dem.core.contract.EngineScene``."""
    if not isinstance(scene, contract.EngineScene):
        raise TypeError(f"{type(scene).__name__} does not implement dem.core.contract.EngineScene")
    with stop_signals_held():  # its thread never takes a stop signal
        watchdog.start(STOP_SIGNALS)
    stop = stop_on_signals(lambda: next_stop(scene))
    run = scene.start()
    watchdog.doing("running")
    if not (isinstance(run, Experiment) and isinstance(run, contract.EngineRun)):
        raise TypeError(f"{type(run).__name__} is not an Experiment implementing dem.core.contract.EngineRun")
    run_dir = run.run_dir
    while True:
        tic = time.time()
        scene.advance(run, stop)
        count_seconds(run.state, time.time() - tic)
        phase = run.state.phase
        if phase == "failed":
            sys.stderr.write(f"error: {run.failure}\n")
            sys.exit(3)
        if phase == "done":
            for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1):  # the work is complete: no stop now
                signal.signal(signum, signal.SIG_IGN)
            meta = scene.meta()
            if run.writer:
                write_run_raw(run, meta)
                for name in os.listdir(run_dir):
                    if name.startswith(SCRATCH_PREFIXES):
                        os.remove(os.path.join(run_dir, name))
            print(f"done: {len(run.samples)} samples, {run.iteration()} steps", flush=True)
            return
        regular = run.iteration() == run.state.next_checkpoint
        if regular:
            run.state.next_checkpoint += run.spec.checkpoint_steps
        watchdog.doing("writing a checkpoint")
        checkpoint(run, scene)
        if not regular:
            print(f"interrupted: checkpoint at iteration {run.iteration()} (off the regular checkpoints: "
                  "the resumed run will not be bit-identical)", flush=True)
            sys.exit(128 + scene.agreed_stop(stop)["signal"])
        watchdog.doing(watchdog.LOADING)
        run = scene.reload()
        watchdog.doing("running")
        asked = scene.agreed_stop(stop)
        if asked["count"] >= 1:
            print(f"interrupted: checkpoint at iteration {run.iteration()}; rerun the same command to resume",
                  flush=True)
            sys.exit(128 + asked["signal"])


def main(run_dir, make_scene, last_checkpoint_bytes):
    """``run_scene(make_scene(run_dir))``, with a disk that cannot take the run's files as one line and exit status
    4 (the last checkpoint intact: rerun to resume)."""
    try:
        require_free(run_dir, 2 * last_checkpoint_bytes + 2**20, "the run")
        run_scene(make_scene(run_dir))
    except DiskError as exc:
        sys.stderr.write(f"error: {exc}: free space, then rerun the same command to resume from the last "
                         "checkpoint\n")
        sys.exit(DISK_FULL)
    except OSError as exc:
        if exc.errno not in DISK_ERRORS:
            raise
        sys.stderr.write(f"error: cannot write in {run_dir} ({os.strerror(exc.errno)}): free space, then rerun the "
                         "same command to resume from the last checkpoint\n")
        sys.exit(DISK_FULL)
