"""LAMMPS's adapter of the Couette scene: the cell of ``dem/core/cell.py`` with the contact law of
``dem/lammps/contact.py``, driven by ``dem/core/driver.py`` exactly as Yade's (``dem/yade/scene.py``).

Run by ``python -m pipeline.runs`` (``make dem ENGINE=lammps``) as ``python3 -m dem.lammps.scene RUN_DIR`` (Debian's
python3 with ``python3-lammps``; LAMMPS's log goes to RUN_DIR/lammps.log). The grains, walls, time step, controller,
protocol, sampling and measurement are the Yade scene's; what differs is how LAMMPS holds them:

- the walls are two groups of spheres moved rigidly by ``fix move`` at velocities the controller sets (string
  variables); wall-wall pairs are excluded from the neighbour lists; a wall's position is its spheres' mean
  (unwrapped), as a Yade clump's;
- the controller is ``fix python/invoke`` every ``control_every_steps`` steps at the end of the step (Yade's
  PyRunner comes after its integrator too), and ``fix halt`` ends a run when the driver stops it;
- contacts come from ``compute pair/local`` (neighbour pairs, kept where the spheres overlap): the normal force
  ``fx fy fz`` and tangential force ``p1 p2 p3`` on atom i, and ``p10 p11 p12`` = x_i - x_j.

Checkpoints: ``restart_<iteration>.lmp`` (``write_restart``: atoms, velocities, the contacts' tangential history)
named by ``checkpoint.json`` (the spec, the driver's state, the restart's size and SHA-256), replaced atomically.
Every run, interrupted or not, continues from each checkpoint as freshly read into a new LAMMPS instance, so a
resumed run is bit-identical to an uninterrupted one. Exit statuses: ``dem/core/driver.py``.
"""

import hashlib
import json
import math
import os
import re
import sys
import traceback

import numpy as np

from dem.core import driver, protocol, watchdog
from dem.core.cell import ROUGH_HEIGHT, WALL_RADIUS, Y_BOTTOM, initial_cloud, wall_centres
from dem.core.contact import contact_constants
from dem.core.rawfile import sync
from dem.core.spec import read_spec, same_spec
from dem.core.state import RunState
from dem.lammps.contact import pair_commands
from dem.lammps.lib import LMP_STYLE_GLOBAL, LMP_STYLE_LOCAL, LMP_TYPE_ARRAY, LMP_TYPE_VECTOR, new_lammps, quoted

#: MPI ranks of this run (``mpirun -np N``, ``RANKS=N``): each drives the same protocol on data gathered from all
RANKS = int(os.environ.get("OMPI_COMM_WORLD_SIZE", "1"))
if RANKS > 1:
    with driver.stop_signals_held():  # MPI's threads never take a stop signal
        from mpi4py import MPI

    COMM, RANK = MPI.COMM_WORLD, MPI.COMM_WORLD.rank
else:
    COMM, RANK = None, 0

CHECKPOINT = "checkpoint.json"
CONTINUE = "--continue"  # argument of a run going on after its own checkpoint (``Scene.reload``)
CONTROL = "dem_lammps_control"  # the function fix python/invoke calls, in __main__
SKIN = 0.3  # neighbour skin (d)
#: atoms sorted in space every 1000 steps (LAMMPS's default: the grains come from a random cloud, so in creation
#: order a grain's neighbours lie anywhere in memory) and MPI ranks side by side across the cell's period, none split
#: along e2 (the box is twice the gap tall, half of it empty). A resumed run sorts as an uninterrupted one does: both
#: go on from the restart file at each checkpoint (``Scene.reload``), and the sorting steps are multiples of 1000
DOMAIN = ("atom_modify map array sort 1000 0.0", "processors * 1 *")


def cell_commands(width, box_height):
    return ["units lj", "atom_style sphere", *DOMAIN, "boundary p p p", "newton on",
            f"region box block 0 {width} 0 {box_height!r} 0 {width}", "create_box 2 box"]


def settings(spec, dt, restarted):
    """Everything a restart file does not keep: neighbours, integration, the walls' motion, the computes the driver
    reads, the controller and the halt; and the contact law, without ``pair_style`` when ``restarted`` (a restart
    file keeps the pair style with its contacts' history, which a new ``pair_style`` would drop; its coefficients
    are given again, since this LAMMPS restores the pair style with a zero cut-off)."""
    every = int(spec.control_every_steps)
    law = pair_commands(spec)
    commands = ([c for c in law if not c.startswith("pair_style")] if restarted else law) + [
        f"neighbor {SKIN} bin", "neigh_modify delay 0 every 1 check yes exclude type 1 1", f"timestep {dt!r}",
        "fix integrate grains nve/sphere",
    ]
    for wall in ("t", "b"):
        for axis in "xyz":
            commands += [f"variable {wall}v{axis} string 0.0", f"variable {wall}v{axis}e equal v_{wall}v{axis}"]
    commands += [
        "variable halt string 0", "variable halte equal v_halt",
        "fix move_top top move variable NULL NULL NULL v_tvxe v_tvye v_tvze",
        "fix move_bottom bottom move variable NULL NULL NULL v_bvxe v_bvye v_bvze",
        "compute unwrapped all property/atom xu yu zu",
        "compute top_force top reduce sum fx fy fz", "compute bottom_force bottom reduce sum fx fy fz",
        "compute top_position top reduce ave c_unwrapped[1] c_unwrapped[2] c_unwrapped[3]",
        "compute bottom_position bottom reduce ave c_unwrapped[1] c_unwrapped[2] c_unwrapped[3]",
        "compute top_velocity top reduce ave vx vy vz", "compute bottom_velocity bottom reduce ave vx vy vz",
        "compute pairs all pair/local dist fx fy fz p1 p2 p3 p10 p11 p12",
        "compute pair_atoms all property/local patom1 patom2",
        f"fix control all python/invoke {every} end_of_step {CONTROL}",
        f"fix halt all halt {every} v_halte != 0 error continue message no",
        "thermo 0",
    ]
    return commands


def build(lmp, spec):
    """The cell, walls and grains in ``lmp``; returns the driver's initial state."""
    kn, kt, cn, ct = contact_constants(spec)
    width = int(spec.width_d)
    n_grains = protocol.grain_count(spec)
    cloud, y_top = initial_cloud(spec, n_grains, width, Y_BOTTOM)
    bottom, top = wall_centres(Y_BOTTOM, +1, width), wall_centres(y_top, -1, width)
    for command in cell_commands(width, 2 * (y_top + 2.0)):
        lmp.command(command)
    for x, y, z in bottom + top:
        lmp.command(f"create_atoms 1 single {x!r} {y!r} {z!r} units box remap yes")
    for (x, y, z), _ in cloud:
        lmp.command(f"create_atoms 2 single {x!r} {y!r} {z!r} units box remap yes")
    n_walls = len(bottom) + len(top)
    lmp.command(f"set type 1 diameter {2 * WALL_RADIUS!r}")
    for k, (_, r) in enumerate(cloud):
        lmp.command(f"set atom {n_walls + k + 1} diameter {2 * r!r}")
    lmp.command("set atom * density 1.0")
    lmp.command(f"group bottom id 1:{len(bottom)}")
    lmp.command(f"group top id {len(bottom) + 1}:{n_walls}")
    lmp.command("group grains type 2")
    m_min = min(math.pi / 6 * (2 * r) ** 3 for _, r in cloud)
    centre = [np.mean(np.array(wall)[:, 1]) for wall in (bottom, top)]
    return driver.initial_state(
        spec, first_grain=n_walls + 1, n_grains=n_grains, n_wall_spheres=n_walls, dt=spec.dt_safety
        * math.sqrt(m_min / kn), bottom_inner_offset=Y_BOTTOM + ROUGH_HEIGHT - centre[0],
        top_inner_offset=y_top - ROUGH_HEIGHT - centre[1], kn=kn, kt=kt, cn=cn, ct=ct)


def gathered(local):
    """A per-rank array joined over every rank in rank order, the same on each (itself with one rank)."""
    if COMM is None:
        return local
    return np.concatenate(COMM.allgather(np.ascontiguousarray(local)))


def atoms(lmp, *names):
    """Per-atom arrays of every atom (all ranks), ordered by atom id (1, 2, ...)."""
    tag = gathered(lmp.numpy.extract_atom("id"))
    order = np.argsort(tag)
    return [tag[order]] + [gathered(lmp.numpy.extract_atom(name))[order] for name in names]


class Run(driver.Experiment):
    """The driver's protocol on a LAMMPS instance."""

    writer = RANK == 0

    def __init__(self, scene, lmp, state):
        self.lmp = lmp
        tag, radius, mass, velocity = atoms(lmp, "radius", "rmass", "v")
        grains = tag >= state.first_grain
        self.radius, self.mass = radius[grains].copy(), mass[grains].copy()
        super().__init__(scene.run_dir, scene.spec, state)
        # the walls go on at the velocities they had (a restart file keeps the atoms', not the variables')
        first_top = state.n_wall_spheres // 2
        self.move_walls(velocity[first_top], velocity[0])

    def iteration(self):
        return int(self.lmp.extract_global("ntimestep"))

    def time(self):
        return self.iteration() * self.state.dt

    def dt(self):
        return self.state.dt

    def vector(self, compute):
        return self.lmp.numpy.extract_compute(compute, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR).tolist()

    def wall_heights(self):
        return self.vector("bottom_position")[1], self.vector("top_position")[1]

    def wall_force(self):
        return self.vector("top_force")

    def move_walls(self, top, bottom):
        for wall, v in (("t", top), ("b", bottom)):
            if v is not None:
                for axis, value in zip("xyz", v, strict=True):
                    self.lmp.set_variable(f"{wall}v{axis}", repr(float(value)))

    def wall_record(self):
        return {f"{wall}_{what}": self.vector(f"{wall}_{what}") for what in ("position", "velocity", "force")
                for wall in ("top", "bottom")}

    def gather(self, grains=True):
        """Contact and grain arrays for ``dem.core.measure``: the overlapping pairs, normal from atom i to atom j, the
        force on j, the contact point in the middle of the overlap (Yade's ``ScGeom``); no grain arrays (None, and
        no velocities gathered) where ``grains`` is false."""
        lmp = self.lmp
        pairs = lmp.numpy.extract_compute("pairs", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY)
        ends = lmp.numpy.extract_compute("pair_atoms", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY)
        pairs = gathered(np.zeros((0, 10)) if pairs is None else np.asarray(pairs, dtype=float).reshape(-1, 10))
        ends = gathered(np.zeros((0, 2)) if ends is None else np.asarray(ends, dtype=float).reshape(-1, 2))
        ends = ends.astype(np.int64)
        tag, x, radius, *v = atoms(lmp, "x", "radius", *(("v",) if grains else ()))
        i, j = ends[:, 0], ends[:, 1]
        dist = pairs[:, 0]
        overlap = radius[i - 1] + radius[j - 1] - dist
        touching = overlap > 0
        pairs, i, j, dist, overlap = pairs[touching], i[touching], j[touching], dist[touching], overlap[touching]
        normal = -pairs[:, 7:10] / dist[:, None]
        point = x[i - 1] + (radius[i - 1] - overlap / 2)[:, None] * normal
        contacts = {"id1": i, "id2": j, "normal": normal, "point": point, "force": -(pairs[:, 1:4] + pairs[:, 4:7]),
                    "branch": dist}
        if not grains:
            return contacts, None
        own = slice(self.state.first_grain - 1, None)
        return contacts, {"id": tag[own].astype(np.int64), "pos": x[own], "vel": v[0][own], "radius": self.radius,
                          "mass": self.mass}

    def stop_after_this_step(self):
        """``fix halt`` (after the controller in the same step) ends the run command once this step is done."""
        self.lmp.set_variable("halt", "1")


class Scene:
    """The LAMMPS scene of one run folder (``driver.run_scene``'s scene)."""

    def __init__(self, run_dir, continued=False):
        # LAMMPS's input parser mangles non-ASCII characters: its files are named relative to the run folder, the
        # working folder of every rank
        self.run_dir = os.path.abspath(run_dir)
        os.chdir(self.run_dir)
        self.continued = continued
        self.spec = read_spec(os.path.join(self.run_dir, "spec.json"))
        self.lmp = None
        self.run = None
        self.stop = {"count": 0, "signal": 0}  # the driver's (``stop_on_signals``) from the first ``advance``
        import __main__

        setattr(__main__, CONTROL, self.control)

    def control(self, _ptr=None):
        """``fix python/invoke``'s entry point; an exception stops the run with its message (exit status 3). With
        several ranks it ends every rank at once (``end_every_rank``): the others may not share it, and a rank
        that halted alone would wait in the run's end for the others, which wait for it in the next step."""
        try:
            if self.agreed_stop(self.stop)["count"] >= 2:  # a second signal: stop now
                self.run.stop_after_this_step()
            self.run.control()
        except Exception as exc:  # noqa: BLE001 - reported to the user and turned into exit status 3
            self.run.fail(f"{type(exc).__name__}: {exc} (in the controller)")
            if COMM is not None:
                sys.stderr.write(f"error: {self.run.failure}\n")
                end_every_rank(SystemExit(3))

    def new_lammps(self):
        with driver.stop_signals_held():  # at one rank LAMMPS starts MPI here, and its threads
            self.lmp = new_lammps(COMM, log="lammps.log")
        return self.lmp

    def attach(self, state, restarted):
        lmp = self.lmp
        for command in settings(self.spec, state.dt, restarted):
            lmp.command(command)
        self.run = Run(self, lmp, state)
        return self.run

    def start(self):
        """Resume from the checkpoint (refusing one that is damaged or of another spec), else build."""
        if os.path.exists(os.path.join(self.run_dir, CHECKPOINT)):
            run = self.read_checkpoint()
            if not self.continued:
                print(f"resumed from checkpoint at iteration {run.iteration()}", flush=True)
            return run
        state = build(self.new_lammps(), self.spec)
        print(f"built: {state.n_grains} grains, dt = {state.dt:.4g}", flush=True)
        return self.attach(state, restarted=False)

    def advance(self, run, stop):
        """Run to the next checkpoint iteration, or until the driver stops the run (``fix halt``)."""
        self.stop = stop
        self.lmp.command(f"run {run.state.next_checkpoint - run.iteration()}")

    @staticmethod
    def agreed_stop(stop):
        """The stop every rank acts on: the most signals any rank has counted (with that rank's signal), taken at
        one collective call. A signal reaches the ranks at different moments (rank 0 alone syncs and hashes each
        checkpoint), so a rank deciding on its own count could go on running while another stops, and both would
        wait for each other for ever. The handlers may count on after the call: decide on the returned copy."""
        if COMM is None:
            return dict(stop)
        count, signum = COMM.allreduce((stop["count"], stop["signal"]), op=MPI.MAX)
        return {"count": count, "signal": signum}

    def checkpoint_bytes(self):
        return sum(os.path.getsize(os.path.join(self.run_dir, name)) for name in os.listdir(self.run_dir)
                   if name.startswith("restart_"))

    def save(self, run):
        """``write_restart`` to a new file (every rank), synced, then ``checkpoint.json`` naming it (atomically); the
        previous restart file goes last."""
        name = f"restart_{run.iteration():012d}.lmp"
        path = os.path.join(self.run_dir, name)
        self.lmp.command("run 0 post no")  # atoms back in the box, neighbour lists and contact history current
        self.lmp.command(f"write_restart {quoted(name)} noinit")
        digest = atoms_sha256(self.lmp)  # every rank: the atoms are gathered
        if not run.writer:
            return
        sync(path)
        previous = self.checkpoint_record().get("restart") if os.path.exists(
            os.path.join(self.run_dir, CHECKPOINT)) else None
        record = {"spec": self.spec.to_dict(), "state": run.state.to_dict(), "restart": name,
                  "bytes": os.path.getsize(path), "sha256": file_sha256(path), "atoms_sha256": digest}
        tmp = os.path.join(self.run_dir, f"{CHECKPOINT}.tmp{os.getpid()}")
        try:
            with open(tmp, "w") as fh:
                json.dump(record, fh)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, os.path.join(self.run_dir, CHECKPOINT))
            sync(self.run_dir)
        finally:
            if os.path.exists(tmp):
                os.remove(tmp)
        if previous and previous != name and os.path.exists(os.path.join(self.run_dir, previous)):
            os.remove(os.path.join(self.run_dir, previous))

    def checkpoint_record(self):
        path = os.path.join(self.run_dir, CHECKPOINT)
        try:
            with open(path) as fh:
                record = json.load(fh)
            checkpoint_record_problem(record)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            driver.damaged(f"checkpoint {path} cannot be read ({type(exc).__name__}: {exc})")
        return record

    def reload(self):
        """Go on from the checkpoint just written in a new process (``exec``: the same process id, run lock and
        output), which reads it as a resumed run does. A LAMMPS instance of this build that reads a restart file
        after another instance ran in the same process can fail in its next run's set-up; a process that holds
        one instance at a time does not. When the driver is about to stop, and with MPI ranks (``mpirun`` cannot
        be ``exec``ed into), the run goes on as it is: a resumed run of several ranks is then not bit-identical to an
        uninterrupted one."""
        if COMM is not None:
            return self.run
        driver.block_stop_signals()  # a warning from here on waits for the new process's handlers
        if self.stop["count"]:
            return self.run
        self.lmp.finalize()  # LAMMPS and MPI: its log file and sockets would stay open across ``exec``
        sys.stdout.flush()
        sys.stderr.flush()
        os.execv(sys.executable, [sys.executable, "-m", "dem.lammps.scene", self.run_dir, CONTINUE])

    def read_checkpoint(self):
        """A LAMMPS instance from the checkpoint, checked first: its spec, the restart file's size and hash."""
        watchdog.doing(watchdog.LOADING)
        record = self.checkpoint_record()
        if not same_spec(record.get("spec"), self.spec):
            driver.damaged(f"checkpoint {os.path.join(self.run_dir, CHECKPOINT)} belongs to another spec")
        restart = os.path.join(self.run_dir, record["restart"])
        if (not os.path.isfile(restart) or os.path.getsize(restart) != record.get("bytes")
                or file_sha256(restart) != record.get("sha256")):
            driver.damaged(f"restart file {restart} is missing or damaged")
        lmp = self.new_lammps()
        for command in DOMAIN:
            lmp.command(command)
        lmp.command(f"read_restart {quoted(record['restart'])}")
        if "atoms_sha256" in record and atoms_sha256(lmp) != record["atoms_sha256"]:  # every rank: collective
            driver.damaged(f"restart file {restart} does not hold the atoms it was written with")
        try:
            return self.attach(RunState.from_dict(record["state"]), restarted=True)
        except (OSError, ValueError, KeyError, TypeError, EOFError) as exc:
            driver.damaged(f"the samples of the checkpoint cannot be read ({type(exc).__name__})")

    def meta(self):
        return {"engine": "lammps", "engine_version": self.lmp.version(),
                "n_wall_spheres": self.run.state.n_wall_spheres}


#: the name of a restart file the scene writes (``save``): a checkpoint naming another is not the scene's
RESTART_NAME = re.compile(r"restart_[0-9]{12}\.lmp")


def checkpoint_record_problem(record) -> None:
    """Raise ``ValueError`` unless ``record`` is a checkpoint the scene wrote: a state (a JSON object) and a restart
    file of its own name in the run folder (not a path elsewhere, which the next checkpoint would delete)."""
    if not isinstance(record, dict) or not isinstance(record.get("state"), dict):
        raise ValueError("no state")
    if not isinstance(record.get("restart"), str) or not RESTART_NAME.fullmatch(record["restart"]):
        raise ValueError(f"restart {record.get('restart')!r} is not a restart file of the run folder")
    if not isinstance(record.get("atoms_sha256", ""), str):
        raise ValueError("atoms_sha256 is not a digest")


#: what each atom's state is read back as: the restart file's atoms, compared after reading with the digest taken
#: when it was written (a file damaged before its own hash was taken reads as other grains, or as none)
ATOM_FIELDS = ("type", "mask", "image", "x", "v", "omega", "radius", "rmass")


def atoms_sha256(lmp):
    """SHA-256 of every atom's ``ATOM_FIELDS``, in atom-id order (the same on every rank)."""
    digest = hashlib.sha256()
    for array in atoms(lmp, *ATOM_FIELDS):
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()


def file_sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def main(run_dir, continued=False):
    if RANK > 0:  # one voice: rank 0 prints; the others' errors go to rank<k>.log
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - for the life of the process
        sys.stderr = open(os.path.join(run_dir, f"rank{RANK}.log"), "a", buffering=1)  # noqa: SIM115
    last = sum(os.path.getsize(os.path.join(run_dir, n)) for n in os.listdir(run_dir) if n.startswith("restart_"))
    try:
        driver.main(run_dir, lambda path: Scene(path, continued), last)
    except BaseException as exc:
        end_every_rank(exc)
        raise


def end_every_rank(exc):
    """Where this rank ends with an error the others may not share (rank 0 alone writes the files: a full disk, a
    quota), end them all with its exit status (``MPI_Abort``, after its error line): a rank that exits alone waits
    in ``MPI_Finalize`` for the others, which wait for it in the next step, for ever. A stop on a signal is agreed
    by every rank (``Scene.agreed_stop``), and so is the end of the run."""
    code = exc.code if isinstance(exc, SystemExit) else 1
    status = 0 if code is None else code if isinstance(code, int) else 1
    if COMM is None or COMM.size == 1 or status == 0 or status - 128 in driver.STOP_SIGNALS:
        return
    if not isinstance(exc, SystemExit):
        traceback.print_exception(exc)  # the abort ends this process before Python would print it
    sys.stdout.flush()
    sys.stderr.flush()
    COMM.Abort(status)


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3) or sys.argv[2:] not in ([], [CONTINUE]):
        sys.exit("usage: python3 -m dem.lammps.scene RUN_DIR")
    main(sys.argv[1], continued=sys.argv[2:] == [CONTINUE])
