"""Run the DEM experiment: ``python -m pipeline.runs run --theta 90 --preset quick [...]`` (``make dem``).

Validates everything before the engine starts, runs the engine's scene (``pipeline.engines``: ``dem/yade/scene.py``,
``dem/lammps/scene.py``) under Debian's python3 in the run folder ``results/<folder>/dem/<name>.run/`` (resuming from
its checkpoint when there is one), then writes the self-describing HDF5 file ``results/<preset>/dem/<name>.h5``
atomically. """

from __future__ import annotations

import ctypes
import datetime as dt
import fcntl
import functools
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
from pathlib import Path

from dem.core.rawfile import DISK_FULL

from .. import engines, io
from .. import spec as run_spec
from ..cli import Parser, disk_full, one_line_errors
from ..dataset.dem_file import run_provenance, write_h5
from ..errors import DemFileError, SpecError
from ..paths import REFERENCE_DIR, RESULTS_DIR, ROOT
from . import scripts
from .state import FAILED


def git_commit() -> str:
    try:
        out = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True, check=True)
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
        return out.stdout.strip() + ("-dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def lock_run(spec: run_spec.DemSpec, results_dir: Path) -> int:
    """Take the run's lock (``<name>.lock`` beside its folder); returns its file descriptor, held until this
    process and the scene it starts (which inherits it) have both ended.

    The lock comes before anything is created or deleted, so ``--fresh`` can never remove the folder of a
    live run; a scene that outlives a killed launcher still holds it, so no second scene can start in the
    same folder. The lock file is opened without following links; a lock or run folder of another kind
    (a link, a folder, a device) is a one-line error.
    """
    run_dir = run_spec.work_dir(spec, results_dir)
    lock_path = run_dir.with_suffix(".lock")
    lock_path.parent.mkdir(parents=True, exist_ok=True)
    if run_dir.is_symlink() or (run_dir.exists() and not run_dir.is_dir()):
        raise SpecError(f"{run_dir} is not a folder (a link or a file): move it away, then rerun")
    try:
        fd = os.open(lock_path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
    except OSError as exc:
        raise SpecError(f"{lock_path} cannot be the run's lock ({exc.strerror}: a link or a folder?): move it "
                        "away, then rerun") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise SpecError(f"{lock_path} is not a regular file: move it away, then rerun")
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise SpecError(f"{run_dir} is in use by another run of the same spec (or by its scene, still "
                        "stopping; FRESH=1 does not stop a live run)") from None
    return fd


def stored_spec(h5: Path) -> dict | None:
    """The spec a run file records (its provenance), or None where it cannot be read."""
    try:
        return run_provenance(h5)[2].to_dict()
    except DemFileError:
        return None


def read_spec_file(path: Path):
    """A run folder's ``spec.json``; a damaged one is a one-line error that says how to recover."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        raise SpecError(f"{path} is damaged (not JSON): rerun with FRESH=1 (--fresh) to start the run again") from None


def adopt_committed(spec: run_spec.DemSpec, run_dir: Path, reference: Path = REFERENCE_DIR) -> bool:
    """Copy a committed run in progress of ``spec`` into ``run_dir`` (which has none) so that it resumes from its
    checkpoint; whether there was one. Its spec must be ``spec``'s."""
    committed = run_spec.work_dir(spec, reference)
    if run_dir.exists() or not (committed / "spec.json").is_file():
        return False
    if not run_spec.same_spec(read_spec_file(committed / "spec.json"), spec):
        raise SpecError(f"{committed} holds a run of another spec: move it away, or rerun with FRESH=1")
    shutil.copytree(committed, run_dir)
    print(f"{spec.label()}: taking up the run in progress committed in {committed}", flush=True)
    return True


def commit_in_progress(spec: run_spec.DemSpec, results_dir: Path, reference: Path = REFERENCE_DIR) -> Path:
    """Copy the stopped run's folder (spec, checkpoint, the samples saved beside it, provenance, status; not its
    logs) to ``data/reference/`` to be committed and taken up on another machine (``adopt_committed``). Taken under
    the run's lock: a live run is refused."""
    run_dir = run_spec.work_dir(spec, results_dir)
    if not (run_dir / "spec.json").is_file() or (run_dir / "raw.npz").exists():
        raise SpecError(f"{run_dir}: no run in progress here (a finished run's file goes to data/reference/ itself)")
    fd = lock_run(spec, results_dir)
    try:
        target = run_spec.work_dir(spec, reference)
        tmp = target.with_name(f".{target.name}.tmp")
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir(parents=True)
        for path in sorted(run_dir.iterdir()):
            if path.is_file() and path.suffix != ".log" and path.name != "log.txt" and ".tmp" not in path.name:
                shutil.copy2(path, tmp / path.name)
        shutil.rmtree(target, ignore_errors=True)
        tmp.rename(target)
    finally:
        os.close(fd)
    return target


def read_provenance(path: Path) -> dict:
    """A run folder's ``provenance.json`` (its start, commit and sessions); a damaged one is a one-line error."""
    try:
        provenance = json.loads(path.read_text())
        if not isinstance(provenance, dict) or not isinstance(provenance.get("sessions"), list):
            raise ValueError("no sessions")
    except (OSError, ValueError) as exc:
        raise SpecError(f"{path} is damaged ({exc}): rerun with FRESH=1 (--fresh) to start the run again") from None
    return provenance


def prepare(spec: run_spec.DemSpec, results_dir: Path, fresh: bool, reference: Path = REFERENCE_DIR) -> Path:
    """The run folder with its ``spec.json``; refuses to mix a checkpoint with another spec. Call under the lock.
    A run in progress committed under ``data/reference/`` is taken up where no folder exists here."""
    run_dir = run_spec.work_dir(spec, results_dir)
    if fresh and run_dir.exists():
        shutil.rmtree(run_dir)
    if not fresh:
        adopt_committed(spec, run_dir, reference)
    run_dir.mkdir(parents=True, exist_ok=True)
    spec_file = run_dir / "spec.json"
    if spec_file.exists() and not run_spec.same_spec(read_spec_file(spec_file), spec):
        for pattern in (*engines.ENGINES[spec.engine].checkpoint_files, "checkpoint.json", "raw.npz"):
            for leftover in run_dir.glob(pattern):
                raise SpecError(f"{run_dir} holds a {leftover.name} of another spec: rerun with --fresh (FRESH=1)")
        spec_file.unlink()
    if not spec_file.exists():
        io.write_json(spec_file, spec.to_dict())
    return run_dir


#: the scene's line once it has read its checkpoint
RESUMED = "resumed from checkpoint"
#: signals passed on to the scene: each stops it at its next checkpoint (SIGUSR1: a scheduler's warning
#: before a time limit); a second SIGINT/SIGTERM stops it within two steps
FORWARDED = (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1)


def _prepare_scene() -> None:
    """In the scene's process, before Yade starts: SIGTERM when the launcher dies (Linux's parent-death
    signal), which stops the scene at its next checkpoint; at once if the launcher is already gone. And the
    scheduler group of its new session (Linux's autogroup) at the launcher's niceness: else ``nice make dem`` would
    leave the scene at full weight against every other session's work."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() == 1:
        os.kill(os.getpid(), signal.SIGTERM)
    niceness = os.getpriority(os.PRIO_PROCESS, 0)
    if niceness > 0:
        try:
            with open("/proc/self/autogroup", "w") as f:
                f.write(str(niceness))
        except OSError:  # no autogroups here: the niceness alone holds
            pass


PR_SET_PDEATHSIG = 1


def mpi_command(ranks: int) -> list[str]:
    """``mpirun -np RANKS`` (Debian's OpenMPI), allowed to run as root where this is root and more ranks than cores
    where asked for (OpenMPI refuses both by default); none for one rank. Where every rank runs here, in a network
    namespace of its own with only the loopback (``loopback_only``): mpirun's listeners, which bind every interface,
    then answer nobody outside it."""
    if ranks == 1:
        return []
    mpirun = shutil.which("mpirun")
    if mpirun is None:
        raise SpecError("mpirun not found: run `make system-lammps` (apt-get install openmpi-bin)")
    isolated = loopback_only() if scripts.on_this_machine(ranks) else []
    if isolated is None:
        print("note: mpirun listens on every network interface here (this machine gives no network namespace: user "
              "namespaces are off or `unshare`/`ip` missing); only its own ranks connect", file=sys.stderr)
    root_inside = bool(isolated) or os.geteuid() == 0  # unshare -r maps this user to root inside
    return [*(isolated or []), mpirun, "-np", str(ranks), *(["--allow-run-as-root"] if root_inside else []),
            *(["--oversubscribe"] if ranks > (os.cpu_count() or 1) else [])]


#: the seconds ``loopback_only`` waits for its trial ``unshare`` (it returns within milliseconds where it works)
UNSHARE_WAIT = 10.0
#: runs what follows its arguments with the loopback up, in the network namespace ``unshare -rn`` made
LOOPBACK_UP = 'ip link set lo up && exec "$@"'


@functools.lru_cache(maxsize=1)
def loopback_only() -> list[str] | None:
    """The prefix that runs a command in a new network namespace holding only the loopback (``unshare -rn``: a
    user namespace of this user too, so no privilege is needed), or None where the machine gives none."""
    unshare, ip = shutil.which("unshare"), shutil.which("ip")
    if unshare is None or ip is None:
        return None
    prefix = [unshare, "-rn", "/bin/sh", "-c", LOOPBACK_UP, "loopback-only"]
    try:
        works = subprocess.run([*prefix, "true"], capture_output=True, timeout=UNSHARE_WAIT).returncode == 0
    except subprocess.TimeoutExpired:
        print(f"note: `unshare -rn true` did not return within {UNSHARE_WAIT:g} s: running without a network "
              "namespace of its own", file=sys.stderr)
        return None
    return prefix if works else None


def run_scene(run_dir: Path, engine: str, threads: int, label: str, lock_fd: int, ranks: int = 1) -> tuple[int, str]:
    """Run the scene, echoing its progress lines (prefixed by ``label``) and logging them to ``run_dir/log.txt``;
    returns its exit status and its last error line. The scene inherits the run's lock (``lock_fd``), gets SIGTERM
    if this launcher dies and runs at its niceness (``_prepare_scene``). With ``ranks`` > 1 it runs under
    ``mpirun``, which kills its ranks on SIGINT or SIGTERM and passes SIGUSR1 and SIGUSR2 on: the first signal
    reaches the scene as SIGUSR1 (stop at the next checkpoint), a second as SIGUSR2 (stop at once)."""
    try:
        command = mpi_command(ranks) + scripts.command(engines.engine(engine).scene, run_dir)
        scripts.require(engine)
    except scripts.EngineMissing as exc:
        raise SpecError(str(exc)) from None
    env = scripts.environment(threads, ranks)
    with open(run_dir / "log.txt", "a", buffering=1) as log:
        log.write(f"# {dt.datetime.now().isoformat(timespec='seconds')} {' '.join(command)}\n")
        proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                                cwd=run_dir, start_new_session=True, pass_fds=(lock_fd,),
                                preexec_fn=_prepare_scene)

        received = []

        def forward(signum, _frame):
            received.append(signum)
            if ranks > 1:
                signum = signal.SIGUSR1 if len(received) == 1 or signum == signal.SIGUSR1 else signal.SIGUSR2
            proc.send_signal(signum)

        previous = {s: signal.signal(s, forward) for s in FORWARDED}
        error = ""
        loading = any(run_dir.glob("checkpoint*"))  # until the scene says it resumed
        try:
            for line in proc.stdout:
                log.write(line)
                loading = loading and not line.startswith(RESUMED)
                if line.startswith("error:"):  # said once the scene has ended (what it means may change)
                    error = line.strip()
                elif line.strip() and not line.startswith(engines.engine(engine).noise):
                    print(f"{label}: {line}", end="", flush=True)
            status = proc.wait()
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
        if status != 0 and not error:
            error = engines.engine(engine).last_error(run_dir)
        if loading and status not in (0, 2) and status - 128 not in FORWARDED and -status not in FORWARDED:
            died = f"died by signal {-status} ({signal.Signals(-status).name})" if status < 0 else "failed"
            why = f" ({error.removeprefix('error: ')})" if error else ""
            error = (f"error: the scene {died} loading its checkpoint{why}: the checkpoint is damaged; rerun with "
                     "FRESH=1 (--fresh) to start the run again")
            status = 2
        if error:
            print(f"{label}: {error}", flush=True)
        return status, error


def run(spec: run_spec.DemSpec, results_dir: Path = RESULTS_DIR, fresh: bool = False, threads: int = 1,
        ranks: int = 1) -> Path:
    """Run (or resume) one DEM run and write its HDF5 file; returns the file's path. ``ranks``: MPI ranks of a
    LAMMPS run."""
    engines.check_parallel(spec.engine, ranks, threads)
    out = run_spec.output_path(spec, results_dir)
    if out.exists() and not fresh:
        stored = stored_spec(out)
        if not run_spec.same_spec(stored, spec):
            why = "its file is unreadable" if stored is None else "its values differ"
            raise SpecError(f"{out} holds a run of another spec ({why}): rerun with --fresh (FRESH=1) to replace it")
        print(f"{out} is up to date (FRESH=1 / --fresh reruns it)")
        return out
    lock_fd = lock_run(spec, results_dir)  # held until this process and the scene have ended
    run_dir = prepare(spec, results_dir, fresh)
    provenance_file = run_dir / "provenance.json"
    provenance = read_provenance(provenance_file) if provenance_file.exists() else {
        "started": dt.datetime.now().isoformat(timespec="seconds"), "git_commit": git_commit(), "sessions": []}
    provenance["sessions"].append({"command": " ".join(sys.argv), "at": dt.datetime.now().isoformat(timespec="seconds"),
                                   "threads": threads, "ranks": ranks, "git_commit": git_commit()})
    io.write_json(provenance_file, provenance)
    (run_dir / FAILED).unlink(missing_ok=True)
    if not (run_dir / "raw.npz").exists():
        c = run_spec.cost(spec)
        print(f"{spec.label()}: {c['grains']} grains, about {c['steps'] / 1e6:.3g} M steps of shear, {c['samples']} "
              f"samples (~{c['megabytes']:.2g} MB); progress and ETA follow", flush=True)
        status, error = run_scene(run_dir, spec.engine, threads, spec.label(), lock_fd, ranks)
        if status in (1, 2, 3):  # a crash, a damaged folder, a failed run: not resumable as it is
            reason = error or f"exit status {status} (see {run_dir / 'log.txt'})"
            io.write_json(run_dir / FAILED, {"exit_status": status, "reason": reason,
                                             "at": dt.datetime.now().isoformat(timespec="seconds")})
        if status != 0 and (run_dir / "raw.npz").exists():  # stopped after it had written its samples
            status = 0
        if status < 0:
            print(f"error: the scene was killed by signal {-status} ({signal.Signals(-status).name}); "
                  f"rerun the same command to resume from its last checkpoint", file=sys.stderr)
            raise SystemExit(128 - status)
        if status != 0:
            raise SystemExit(status)
    provenance["finished"] = dt.datetime.now().isoformat(timespec="seconds")
    previous = signal.signal(signal.SIGUSR1, signal.SIG_IGN)  # a scheduler's warning now: the file is seconds away
    try:
        write_h5(run_dir / "raw.npz", out, provenance)
    finally:
        signal.signal(signal.SIGUSR1, previous)
    return out


@one_line_errors
def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.runs", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    p = sub.add_parser("run", help="run (or resume) one DEM run and write its HDF5 file")
    p.add_argument("--theta", required=True, help="rotation angle of the second half period, degrees (e1 towards e3)")
    p.add_argument("--preset", default="quick", help="preset of config/dem.toml: paper, reduced, quick, tiny")
    p.add_argument("--rotate-at", default=None, help="strain within each period at which the direction turns to "
                   "theta (default: half the period, Fig. 1; Fig. 7 uses 0.1 and 0.2)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a preset value (repeatable); the results go to results/<preset>-<hash>/")
    p.add_argument("--fresh", action="store_true", help="discard the run's checkpoint and start again")
    p.add_argument("--allow-inertial", action="store_true", help="admit an inertial number past the "
                   "quasi-static regime (I > 1e-2)")
    p.add_argument("--engine", default=engines.DEFAULT_ENGINE, help=f"DEM engine: {', '.join(engines.ENGINES)} "
                   "(the first, the default, is the reference)")
    p.add_argument("--threads", type=int, default=1, help="Yade threads (default 1: reproducible, resumable "
                   "bit for bit)")
    p.add_argument("--ranks", type=int, default=1, help="MPI ranks of a LAMMPS run (default 1; each rank a core)")
    p.add_argument("--results", type=Path, default=RESULTS_DIR, help="results folder (default: results/)")
    p.add_argument("--print-path", action="store_true", help="print the HDF5 path this run writes, then exit")
    p.add_argument("--commit", action="store_true", help="copy the stopped run's folder (checkpoint and samples so "
                   "far) to data/reference/ to be committed; `make dem` on another machine takes it up, then exit")
    args = parser.parse_args(argv)
    spec = run_spec.resolve(args.theta, args.preset, args.rotate_at, run_spec.parse_overrides(args.set),
                            allow_inertial=args.allow_inertial, engine=args.engine)
    engines.check_parallel(spec.engine, args.ranks, args.threads)
    if args.print_path:
        print(run_spec.output_path(spec, args.results))
        return 0
    if args.commit:
        print(f"copied the run in progress to {commit_in_progress(spec, args.results)}: commit it; `make dem` with "
              "the same values takes it up where no folder of it exists")
        return 0
    try:
        out = run(spec, args.results, args.fresh, args.threads, args.ranks)
    except OSError as exc:
        if not disk_full(exc):
            raise
        print(f"error: cannot write in {args.results} ({exc.strerror or exc}): free space, then rerun the same "
              "command to resume (the run's folder keeps its checkpoint or samples)", file=sys.stderr)
        return DISK_FULL
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
