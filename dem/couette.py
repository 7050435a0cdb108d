"""Yade scene: the 3D planar Couette cell of Rojas & Kamrin (2025), Sec. 2 and Fig. 1.

Run by ``python -m pipeline.runs`` (``make dem``) as ``python3 -m dem.couette RUN_DIR`` (Debian's python3, Yade imported
as a library by ``dem/yade_lib.py``: no remote console is opened); RUN_DIR holds
``spec.json`` (every parameter, resolved and validated by ``pipeline/runs/spec.py``) and receives
checkpoints and ``raw.npz``. Units: d = p = rho = 1 (time in d sqrt(rho/p)); strain t*gamma_dot.

Cell: periodic along e1 and e3 (period W), walls normal to e2. Each wall is a rigid, non-dynamic
clump of spheres of diameter d: a compact square layer plus, towards the grains, a checkerboard of
spheres in its hollows (roughness). The "inner plane" of a wall is the centre plane of that rough
layer; the gap H is the distance between the two inner planes.

Contacts: ``dem/contact.py`` (linear visco-elastic, constant k_n, damping set for the mean pair).

Protocol (strain s = t*gamma_dot measured from the start of the first period):
compaction under p -> s in [-pre_strain, 0): phi = theta -> n_cycles periods with phi = 0 for
s mod T in [0, rotate_at) and phi = theta after. The top wall moves with U s(phi) + v_y e2, the
bottom wall with -U s(phi), s(phi) = cos(phi) e1 + sin(phi) e3, U = gamma_dot H0 / 2 with H0 the
gap when shearing starts; v_y = (sigma_wall/p - 1) H (delta/d) / control_time holds the normal
stress on the top wall at p.

Exit status: 0 done (raw.npz written), 2 the run folder cannot be resumed, 3 the run went wrong
(diagnostic on stderr), 130/143/138 interrupted by SIGINT/SIGTERM/SIGUSR1 after writing a checkpoint.
"""

import json
import math
import os
import signal
import sys
import time

import numpy as np

from dem import active, checks, measure, protocol, schema
from dem.contact import contact_constants, contact_engines, contact_material
from dem.rawfile import (
    DISK_ERRORS,
    DISK_FULL,
    DiskError,
    complete_gzip,
    require_free,
    save_npz,
    stack,
    sync,
    write_raw,
    write_status,
)
from dem.yade_lib import VERSION, O, PyRunner, Vector3, pack, utils

STATUS = "status.json"  # the run's progress, read by pipeline.runs.state

ROUGH_HEIGHT = 1 / math.sqrt(2)  # rough layer above the compact layer (sphere in a square hollow)
WALL_RADIUS = checks.WALL_RADIUS


# ---------------------------------------------------------------- scene construction
def wall_spheres(y_compact, towards, width, material):
    """A wall: a compact square layer at y_compact plus a checkerboard of spheres in its hollows."""
    spheres = [utils.sphere((i + 0.5, y_compact, k + 0.5), WALL_RADIUS, material=material)
               for i in range(width) for k in range(width)]
    y_rough = y_compact + towards * ROUGH_HEIGHT
    spheres += [utils.sphere((i + 1.0, y_rough, k + 1.0), WALL_RADIUS, material=material)
                for i in range(width) for k in range(width) if (i + k) % 2 == 0]
    clump_id, member_ids = O.bodies.appendClumped(spheres)
    O.bodies[clump_id].dynamic = False
    return clump_id, list(member_ids)


#: a cloud that does not fit is tried again in a box this much taller, up to CLOUD_TRIES times
CLOUD_GROWTH, CLOUD_TRIES = 1.25, 6


def initial_cloud(spec, n_grains, width, y_bottom):
    """The grains' loose start, ``(cloud, y_top)``: a random cloud at packing fraction ~0.35 between the walls'
    rough layers, and the height of the top wall's compact layer that encloses it. Where a seed's cloud does not
    fit (random sequential placement stalls, about one seed in seven of the tiny cell), the box grows by a quarter
    and the cloud is drawn again; compaction takes the extra height out. A seed that fits at once gives the same
    cloud as ever."""
    d_min, d_max = spec["diameter_min_d"], spec["diameter_max_d"]
    loose_gap = spec["gap_d"] * spec["fill_packing_fraction"] / 0.35
    lo = y_bottom + ROUGH_HEIGHT + WALL_RADIUS
    for _ in range(CLOUD_TRIES):
        cloud = pack.SpherePack()
        y_top = y_bottom + 2 * ROUGH_HEIGHT + loose_gap + d_max
        made = cloud.makeCloud((0, lo, 0), (width, y_top - ROUGH_HEIGHT - WALL_RADIUS, width),
                               rMean=(d_min + d_max) / 4, rRelFuzz=(d_max - d_min) / (d_max + d_min), num=n_grains,
                               periodic=False, seed=int(spec["seed"]) + 1)
        if made == n_grains:
            return cloud, y_top
        loose_gap *= CLOUD_GROWTH
    raise RuntimeError(f"placed only {made} of {n_grains} grains in the initial cloud, in a box "
                       f"{CLOUD_GROWTH ** (CLOUD_TRIES - 1):.1f} times the usual height")


def build(spec):
    """Create the cell, walls, grains and engines; protocol state goes to O.tags['state']."""
    kn, kt, cn, ct = contact_constants(spec)
    width = int(spec["width_d"])
    n_grains = protocol.grain_count(spec)
    y_bottom = 1.0
    cloud, y_top = initial_cloud(spec, n_grains, width, y_bottom)
    O.periodic = True
    O.cell.setBox(width, 2 * (y_top + 2.0), width)
    material = O.materials.append(contact_material(spec))
    bottom = wall_spheres(y_bottom, +1, width, material)
    top = wall_spheres(y_top, -1, width, material)
    first_grain = len(O.bodies)
    O.bodies.append([utils.sphere(c, r, material=material) for c, r in cloud])
    m_min = min(b.state.mass for b in O.bodies if b.id >= first_grain)
    O.dt = spec["dt_safety"] * math.sqrt(m_min / kn)
    O.engines = contact_engines() + [
        PyRunner(iterPeriod=int(spec["control_every_steps"]), command=active.COMMAND, label="controller"),
    ]
    O.tags["spec"] = json.dumps(spec)
    y_rough_bottom, y_rough_top = y_bottom + ROUGH_HEIGHT, y_top - ROUGH_HEIGHT
    O.tags["state"] = json.dumps({
        "phase": "compaction", "bottom": bottom, "top": top, "first_grain": first_grain, "n_grains": n_grains,
        "bottom_inner_offset": y_rough_bottom - O.bodies[bottom[0]].state.pos[1],
        "top_inner_offset": y_rough_top - O.bodies[top[0]].state.pos[1],
        "kn": kn, "kt": kt, "cn": cn, "ct": ct, "hold_since": None, "t_shear0": None, "gap0": None,
        "wall_speed": None, "next_sample": 0, "alarm_strain": 0.0, "samples_file": None,
        "next_checkpoint": int(spec["checkpoint_steps"]), "err_sum": 0.0, "err_n": 0, "err_max": 0.0,
        "callback_seconds": 0.0, "loop_seconds": 0.0,
    })


# ---------------------------------------------------------------- runtime state (restored from O.tags)
class Run:
    """Python-side state of the running scene; everything persistent lives in ``self.state`` (``O.tags``)."""

    def __init__(self, scene):
        self.scene = scene
        self.spec = scene.spec
        self.state = json.loads(O.tags["state"])
        st = self.state
        self.top_clump, self.bottom_clump = O.bodies[st["top"][0]], O.bodies[st["bottom"][0]]
        self.grain_ids = list(range(st["first_grain"], st["first_grain"] + st["n_grains"]))
        self.grains = [O.bodies[i] for i in self.grain_ids]
        self.radius = np.array([b.shape.radius for b in self.grains])
        self.mass = np.array([b.state.mass for b in self.grains])
        self.area = self.spec["width_d"] ** 2
        self.gain = self.spec["gap_d"] * self.spec["overlap_ratio"] / self.spec["control_time"]
        self.gamma_dot = self.spec["inertial_number"]  # I = d gamma_dot / sqrt(p/rho) with d = p = rho = 1
        self.samples = load_samples(scene.run_dir, st["samples_file"])
        self.sample_strains = protocol.sample_strains(self.spec)
        self.failure = None
        self.last_print = (time.time(), O.iter)
        self.next_percent = 0.0

    def inner_planes(self):
        """Heights of the walls' inner planes (centres of their rough layers)."""
        return (self.bottom_clump.state.pos[1] + self.state["bottom_inner_offset"],
                self.top_clump.state.pos[1] + self.state["top_inner_offset"])

    def wall_stress(self):
        """Normal stress on the top wall (force of the grains along +e2 per cell area; p > 0)."""
        return O.forces.f(self.top_clump.id)[1] / self.area  # Yade sums the members' forces into the clump

    # the controller: every control_every_steps steps
    def control(self):
        tic = time.perf_counter()
        st = self.state
        err = self.wall_stress() - 1.0
        vy = self.gain * err
        if st["phase"] == "compaction":
            vy = max(-0.1, min(0.1, vy))
            self.top_clump.state.vel = Vector3(0, vy, 0)
            self.compaction_check(err)
        elif st["phase"] == "shear":
            st["err_sum"] += err
            st["err_n"] += 1
            st["err_max"] = max(st["err_max"], abs(err))
            strain = protocol.strain(O.time, st["t_shear0"], self.gamma_dot, self.spec)
            phi = math.radians(protocol.direction_deg(strain, self.spec))
            u = st["wall_speed"] * Vector3(math.cos(phi), 0, math.sin(phi))
            self.top_clump.state.vel = u + Vector3(0, vy, 0)
            self.bottom_clump.state.vel = -u
            if strain >= self.sample_strains[st["next_sample"]] - protocol.EPS:
                self.sample(strain)
        st["callback_seconds"] += time.perf_counter() - tic

    def compaction_check(self, err):
        st = self.state
        now = time.time()
        if now - self.last_print[0] > 10:
            y_bottom, y_top = self.inner_planes()
            rate = (O.iter - self.last_print[1]) / (now - self.last_print[0])
            print(f"compaction: t = {O.time:.1f}, sigma_wall/p - 1 = {err:+.3f}, gap = {y_top - y_bottom:.2f} d, "
                  f"{rate:.0f} steps/s", flush=True)
            self.last_print = (now, O.iter)
        # the wall stress rings after compaction (more so in a large cell): judge its mean over a window
        if st["hold_since"] is None:
            st.update(hold_since=O.time, hold_sum=0.0, hold_n=0)
        st["hold_sum"] += err
        st["hold_n"] += 1
        if O.time - st["hold_since"] >= self.spec["compaction_hold_time"]:
            mean = st["hold_sum"] / st["hold_n"]
            st["hold_since"] = None
            if abs(mean) < self.spec["compaction_tolerance"]:
                y_bottom, y_top = self.inner_planes()
                st.update(phase="shear", t_shear0=O.time, gap0=y_top - y_bottom,
                          wall_speed=self.gamma_dot * (y_top - y_bottom) / 2)
                print(f"compaction done at t = {O.time:.1f}: gap H0 = {st['gap0']:.3f} d, "
                      f"U = {st['wall_speed']:.3g}; shearing", flush=True)
        if O.time > self.spec["compaction_max_time"]:
            self.fail(f"compaction did not converge within t = {self.spec['compaction_max_time']} "
                      f"(sigma_wall/p - 1 = {err:+.3f})")

    # sampling
    def gather(self):
        """Contact and grain arrays for ``dem.measure`` (indexing Vector3s: unpacking them is 5x slower)."""
        contacts = []
        for i in O.interactions:  # real interactions only
            g, ph = i.geom, i.phys
            n, c, f = g.normal, g.contactPoint, ph.normalForce + ph.shearForce
            contacts.append((i.id1, i.id2, n[0], n[1], n[2], c[0], c[1], c[2], f[0], f[1], f[2],
                             g.refR1 + g.refR2 - g.penetrationDepth))
        c = np.array(contacts, dtype=float).reshape(-1, 12)
        kinematics = []
        for b in self.grains:
            x, v = b.state.pos, b.state.vel
            kinematics.append((x[0], x[1], x[2], v[0], v[1], v[2]))
        kin = np.array(kinematics, dtype=float)
        return (
            {"id1": c[:, 0].astype(np.int64), "id2": c[:, 1].astype(np.int64), "normal": c[:, 2:5],
             "point": c[:, 5:8], "force": c[:, 8:11], "branch": c[:, 11]},
            {"id": np.array(self.grain_ids), "pos": kin[:, :3], "vel": kin[:, 3:], "radius": self.radius,
             "mass": self.mass},
        )

    def sample(self, strain):
        st = self.state
        contacts, grains = self.gather()
        y_bottom, y_top = self.inner_planes()
        gap = y_top - y_bottom
        margin = self.spec["region_margin_d"]
        n_bins = max(1, int(round(st["gap0"] / self.spec["profile_bin_d"])))
        edges = np.linspace(y_bottom, y_top, n_bins + 1)
        row = measure.measure(contacts, grains, st["first_grain"], self.area, (y_bottom + margin, y_top - margin),
                              edges)
        row.update(
            iteration=O.iter, time=O.time, strain=strain, direction_deg=protocol.direction_deg(strain, self.spec),
            gap=gap, region=[y_bottom + margin, y_top - margin], profile_edges=edges,
            top_position=list(self.top_clump.state.pos), bottom_position=list(self.bottom_clump.state.pos),
            top_velocity=list(self.top_clump.state.vel), bottom_velocity=list(self.bottom_clump.state.vel),
            top_force=list(O.forces.f(self.top_clump.id)), bottom_force=list(O.forces.f(self.bottom_clump.id)),
            wall_stress_error_mean=st["err_sum"] / max(st["err_n"], 1), wall_stress_error_max=st["err_max"],
        )
        st.update(err_sum=0.0, err_n=0, err_max=0.0)
        schema.check_row(row)
        self.samples.append(row)
        st["next_sample"] += 1
        self.check(row, grains, y_bottom, y_top)
        self.progress(strain, row)
        if st["next_sample"] >= len(self.sample_strains) and self.failure is None:
            st["phase"] = "done"
            stop_after_this_step()

    def check(self, row, grains, y_bottom, y_top):
        """Stop with a diagnostic when the run goes wrong (``dem/checks.py``)."""
        st = self.state
        problem = checks.sample_problem(row, grains["id"], grains["pos"], grains["vel"], (y_bottom, y_top),
                                        st["gap0"])
        if problem is None:
            step = self.spec["sample_strain"]
            interval = row["strain"] - self.samples[-2]["strain"] if len(self.samples) > 1 else step
            st["alarm_strain"], problem = checks.stress_alarm(row["wall_stress_error_mean"], st["alarm_strain"],
                                                              interval, self.spec)
        if problem is not None:
            self.fail(problem)

    def progress(self, strain, row):
        total = protocol.end_strain(self.spec) + self.spec["pre_strain"]
        done = (strain + self.spec["pre_strain"]) / total
        now = time.time()
        if done * 100 < self.next_percent and now - self.last_print[0] < 60:
            return
        self.next_percent = math.floor(done * 50 + 1e-9) * 2 + 2
        rate = (O.iter - self.last_print[1]) / max(now - self.last_print[0], 1e-9)
        steps_left = (total - strain - self.spec["pre_strain"]) / (self.gamma_dot * O.dt)
        eta = steps_left / rate if rate > 0 else float("nan")
        print(f"[{done:4.0%}] strain {strain:+.3f} / {protocol.end_strain(self.spec):.2f}  "
              f"sigma_wall/p - 1 = {row['wall_stress_error_mean']:+.2%}  tau12/p = {row['stress_contact'][0, 1]:+.3f}  "
              f"{rate:.0f} steps/s  ETA {format_seconds(eta)}", flush=True)
        write_status(os.path.join(self.scene.run_dir, STATUS), {
            "percent": round(100 * done, 1), "strain": strain, "steps_per_second": round(rate, 1),
            "eta_seconds": eta if math.isfinite(eta) else None, "updated": time.time()})
        self.last_print = (now, O.iter)

    def fail(self, message):
        self.failure = message
        self.state["phase"] = "failed"
        stop_after_this_step()


def stop_after_this_step():
    """End the run loop once the current step is complete, all engines (this PyRunner too) included.

    ``O.pause()`` from inside a PyRunner would mark the loop stopped while the PyRunner still runs,
    so the main thread could checkpoint a half-sampled state; ``stopAtIter`` is checked by Yade's
    loop only after the whole step.
    """
    O.stopAtIter = O.iter + 1


def format_seconds(seconds):
    if not math.isfinite(seconds):
        return "?"
    seconds = int(seconds)
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    return f"{seconds // 60}m{seconds % 60:02d}s"


# ---------------------------------------------------------------- persistence (atomic: temp file, then rename)
def load_samples(run_dir, name):
    if not name:
        return []
    with np.load(os.path.join(run_dir, name), allow_pickle=False) as data:
        columns = {key: data[key] for key in data.files}
    n = len(next(iter(columns.values()))) if columns else 0
    return [{key: columns[key][i] for key in columns} for i in range(n)]


def checkpoint(run):
    """Samples first (a new file), then the scene that names it; old sample files go last. The disk's free
    space is checked first (twice the last checkpoint and the samples), the new checkpoint is checked to be a
    whole gzip stream and synced before it replaces the old one, and a disk error raises ``DiskError`` with the
    previous checkpoint intact."""
    name = f"samples_{O.iter:012d}.npz"
    run_dir = run.scene.run_dir
    columns = stack(run.samples)
    last = os.path.getsize(run.scene.checkpoint) if os.path.exists(run.scene.checkpoint) else 0
    require_free(run_dir, 2 * last + 2 * sum(a.nbytes for a in columns.values()), "a checkpoint")
    tmp = os.path.join(run_dir, "checkpoint.tmp.yade.gz")
    try:
        save_npz(os.path.join(run_dir, name), columns)
        previous = run.state["samples_file"]
        run.state["samples_file"] = name
        O.tags["state"] = json.dumps(run.state)
        O.save(tmp)
        if not complete_gzip(tmp):
            raise DiskError(f"the checkpoint written in {run_dir} is incomplete (a full disk?)")
        sync(tmp)
        os.replace(tmp, run.scene.checkpoint)
        sync(run_dir)
    except OSError as exc:
        if exc.errno in DISK_ERRORS:
            raise DiskError(f"cannot write in {run_dir} ({os.strerror(exc.errno)})") from None
        raise
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    if previous and previous != name:
        os.remove(os.path.join(run_dir, previous))


def write_run_raw(run):
    st = run.state
    meta = {
        "spec": run.spec, "yade_version": VERSION,
        "dt": O.dt, "kn": st["kn"], "kt": st["kt"], "cn": st["cn"], "ct": st["ct"], "n_grains": st["n_grains"],
        "n_wall_spheres": len(st["top"][1]) + len(st["bottom"][1]), "gap0": st["gap0"], "wall_speed": st["wall_speed"],
        "gamma_dot_nominal": run.gamma_dot, "t_shear0": st["t_shear0"], "iterations": O.iter,
        "callback_seconds": st["callback_seconds"], "loop_seconds": st["loop_seconds"],
        "grain_radius": run.radius.tolist(),
    }
    write_raw(run.scene.raw, stack(run.samples), meta)


# ---------------------------------------------------------------- the scene of a run folder
class Scene:
    """The scene of one run folder: its spec (``spec.json``), its files, and once built or loaded the running
    state ``run``. Yade's PyRunner reaches it through ``dem.active`` (its command is a string run in
    ``__main__``, whatever script that is)."""

    def __init__(self, run_dir):
        self.run_dir = run_dir
        with open(os.path.join(run_dir, "spec.json")) as fh:
            self.spec = json.load(fh)
        self.checkpoint = os.path.join(run_dir, "checkpoint.yade.gz")
        self.raw = os.path.join(run_dir, "raw.npz")
        self.run = None

    def build(self):
        """A new scene from the spec (``build``), attached."""
        build(self.spec)
        return self.attach()

    def load(self, path):
        """A saved scene (a checkpoint or a cached state), attached."""
        O.load(path)
        return self.attach()

    def attach(self):
        """Read the running state of the scene in ``O`` and let the controller drive this object (a scene saved
        by an older version named its command otherwise)."""
        next(e for e in O.engines if e.label == "controller").command = active.COMMAND
        self.run = Run(self)
        active.activate(self)
        return self.run

    def control(self):
        """The PyRunner's entry point; an exception stops the run with its message instead of hanging Yade."""
        try:
            self.run.control()
        except Exception as exc:  # noqa: BLE001 - reported to the user and turned into exit status 3
            self.run.fail(f"{type(exc).__name__}: {exc} (in the controller)")


# ---------------------------------------------------------------- main loop


def damaged(message):
    """A run folder that cannot be resumed: one line, exit status 2."""
    sys.stderr.write(f"error: {message}; rerun with FRESH=1 (--fresh) to start the run again\n")
    sys.exit(2)


def run_until_stopped(run, stop):
    """Run to the next checkpoint iteration (or until the scene stops itself) and wait for the loop.

    The loop stops itself only at the end of a whole step (``O.run(n)`` sets ``stopAtIter``), so no
    engine is still running when this returns. A second signal asks for a stop two steps ahead.
    """
    O.run(run.state["next_checkpoint"] - O.iter)
    target = None
    while O.running:
        if stop["count"] >= 2 and (target is None or O.iter >= target):
            target = O.iter + 2
            O.stopAtIter = target
        time.sleep(0.05)
    O.wait()


def run_scene(run_dir):
    """Build or resume, then run; at every checkpoint save, reload and go on (see ``checkpoint_steps``).

    Every run, interrupted or not, continues from each checkpoint as freshly loaded, so resuming is
    bit-identical (one thread). A first SIGINT/SIGTERM stops at the next checkpoint; a second one
    stops within two steps (the run then resumes correctly but not bit-identically). SIGUSR1 (a
    scheduler's warning before a time limit) only ever stops at the next checkpoint.
    """
    scene = Scene(run_dir)
    stop = {"count": 0, "signal": 0}

    def on_usr1(signum, _frame):  # a scheduler's warning before a time limit: stop at the next checkpoint
        if stop["count"] == 0:
            on_signal(signum, _frame)

    def on_signal(signum, _frame):
        stop["count"] += 1
        stop["signal"] = signum
        if stop["count"] == 1:
            print(f"signal {signum}: stopping at the next checkpoint (iteration "
                  f"{scene.run.state['next_checkpoint']}); "
                  "signal again to stop at once", flush=True)

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGUSR1, on_usr1)
    if os.path.exists(scene.checkpoint):
        try:
            O.load(scene.checkpoint)
            same_spec = json.loads(O.tags["spec"]) == scene.spec
        except Exception as exc:  # noqa: BLE001 - any damage: Yade raises RuntimeError, MemoryError, ...
            damaged(f"checkpoint {scene.checkpoint} cannot be loaded ({type(exc).__name__})")
        if not same_spec:
            damaged(f"checkpoint {scene.checkpoint} belongs to another spec")
        print(f"resumed from checkpoint at iteration {O.iter}", flush=True)
    else:
        build(scene.spec)
        print(f"built: {json.loads(O.tags['state'])['n_grains']} grains, dt = {O.dt:.4g}", flush=True)
    try:
        run = scene.attach()
    except (OSError, ValueError, KeyError, EOFError) as exc:
        damaged(f"the samples of the checkpoint cannot be read ({type(exc).__name__})")
    while True:
        tic = time.time()
        run_until_stopped(run, stop)
        run.state["loop_seconds"] += time.time() - tic
        phase = run.state["phase"]
        if phase == "failed":
            sys.stderr.write(f"error: {run.failure}\n")
            sys.exit(3)
        if phase == "done":
            for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1):  # the work is complete: no stop now
                signal.signal(signum, signal.SIG_IGN)
            write_run_raw(run)
            for name in os.listdir(run_dir):
                if name.startswith(("checkpoint", "samples_")):
                    os.remove(os.path.join(run_dir, name))
            print(f"done: {len(run.samples)} samples, {O.iter} steps", flush=True)
            return
        regular = O.iter == run.state["next_checkpoint"]
        if regular:
            run.state["next_checkpoint"] += scene.spec["checkpoint_steps"]
        checkpoint(run)
        if not regular:
            print(f"interrupted: checkpoint at iteration {O.iter} (off the regular checkpoints: "
                  "the resumed run will not be bit-identical)", flush=True)
            sys.exit(128 + stop["signal"])
        run = scene.load(scene.checkpoint)
        if stop["count"] >= 1:
            print(f"interrupted: checkpoint at iteration {O.iter}; rerun the same command to resume", flush=True)
            sys.exit(128 + stop["signal"])


def main(run_dir):
    """``run_scene``, with a disk that cannot take the run's files as one line and exit status 4 (the last
    checkpoint intact: rerun to resume)."""
    try:
        last = os.path.join(run_dir, "checkpoint.yade.gz")
        require_free(run_dir, 2 * (os.path.getsize(last) if os.path.exists(last) else 0) + 2**20, "the run")
        run_scene(run_dir)
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


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python3 -m dem.couette RUN_DIR")
    main(sys.argv[1])
