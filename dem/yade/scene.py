"""Yade's adapter of the Couette scene (Rojas & Kamrin 2025, Sec. 2 and Fig. 1): builds the cell of ``dem/core/cell.py``
in Yade and gives ``dem/core/driver.py`` its clock, walls and contact arrays.

Run by ``python -m pipeline.runs`` (``make dem``) as ``python3 -m dem.yade.scene RUN_DIR`` (Debian's python3, Yade
imported as a library by ``dem/yade/lib.py``: no remote console is opened); RUN_DIR holds ``spec.json`` (every
parameter, resolved and validated by ``pipeline/spec.py``) and receives checkpoints
(``checkpoint.yade.gz``, the driver's state in ``O.tags``) and ``raw.npz``. Each wall is a rigid, non-dynamic
clump of its spheres; contacts are ``dem/core/contact.py``'s (linear visco-elastic, constant k_n, damping set for the
mean pair). Exit statuses: ``dem/core/driver.py``.
"""

import json
import math
import os
import sys
import time

import numpy as np

from dem.core import driver, protocol, watchdog
from dem.core.cell import ROUGH_HEIGHT, WALL_RADIUS, Y_BOTTOM, initial_cloud, wall_centres
from dem.core.contact import contact_constants
from dem.core.rawfile import DiskError, complete_gzip, sync
from dem.core.spec import DemSpec, read_spec
from dem.core.state import RunState
from dem.yade import active
from dem.yade.contact import contact_engines, contact_material
from dem.yade.lib import VERSION, O, PyRunner, Vector3, utils


# ---------------------------------------------------------------- scene construction
def wall_spheres(y_compact, towards, width, material):
    """A wall (``dem.core.cell.wall_centres``) as a rigid, non-dynamic clump: its clump id and member ids."""
    spheres = [utils.sphere(c, WALL_RADIUS, material=material) for c in wall_centres(y_compact, towards, width)]
    clump_id, member_ids = O.bodies.appendClumped(spheres)
    O.bodies[clump_id].dynamic = False
    return clump_id, list(member_ids)


def build(spec):
    """Create the cell, walls, grains and engines; the driver's state goes to O.tags['state']."""
    kn, kt, cn, ct = contact_constants(spec)
    width = int(spec.width_d)
    n_grains = protocol.grain_count(spec)
    cloud, y_top = initial_cloud(spec, n_grains, width, Y_BOTTOM)
    O.periodic = True
    O.cell.setBox(width, 2 * (y_top + 2.0), width)
    material = O.materials.append(contact_material(spec))
    bottom = wall_spheres(Y_BOTTOM, +1, width, material)
    top = wall_spheres(y_top, -1, width, material)
    first_grain = len(O.bodies)
    O.bodies.append([utils.sphere(c, r, material=material) for c, r in cloud])
    m_min = min(b.state.mass for b in O.bodies if b.id >= first_grain)
    O.dt = spec.dt_safety * math.sqrt(m_min / kn)
    O.engines = scene_engines(spec)
    O.tags["spec"] = json.dumps(spec.to_dict())
    O.tags["state"] = json.dumps(driver.initial_state(
        spec, bottom=bottom, top=top, first_grain=first_grain, n_grains=n_grains,
        bottom_inner_offset=Y_BOTTOM + ROUGH_HEIGHT - O.bodies[bottom[0]].state.pos[1],
        top_inner_offset=y_top - ROUGH_HEIGHT - O.bodies[top[0]].state.pos[1], kn=kn, kt=kt, cn=cn, ct=ct).to_dict())


def scene_engines(spec):
    """The engines of the scene: the contact law's and the controller, a PyRunner whose Python is ``active``'s."""
    return contact_engines() + [
        PyRunner(iterPeriod=int(spec.control_every_steps), command=active.COMMAND, label="controller")]


def engine_signature(engines):
    """Each engine's type, label and dead flag, with its dispatchers' functor types: what makes a saved scene's
    engines the ones ``scene_engines`` makes (parameters and internal state aside)."""
    def functors(engine):
        return tuple(tuple(type(f).__name__ for f in getattr(engine, name).functors) for name in DISPATCHERS
                     if hasattr(engine, name))
    return [(type(e).__name__, e.label, bool(e.dead), functors(e)) for e in engines]


#: the dispatchers of Yade's engines whose functors ``engine_signature`` compares
DISPATCHERS = ("boundDispatcher", "geomDispatcher", "physDispatcher", "lawDispatcher")


class ForeignScene(ValueError):
    """A saved scene whose engines are not those ``build`` makes."""


def load_scene(path, spec):
    """Load a saved scene into ``O`` as data: its engines must be those ``build`` makes (no PyRunner but the
    controller, whose command ``Scene.attach`` sets again), and no engines may wait to replace them. A PyRunner's
    command is Python that Yade runs; anything else the file holds (bodies, interactions, tags) is data."""
    O.load(path)
    if engine_signature(O.engines) != engine_signature(scene_engines(spec)) or len(O._nextEngines):
        found = ", ".join(f"{e.__class__.__name__}:{e.label}" if e.label else e.__class__.__name__
                          for e in list(O.engines) + list(O._nextEngines))
        raise ForeignScene(f"{path} holds engines that the scene does not make ({found[:300]})")


# ---------------------------------------------------------------- the running scene (state restored from O.tags)
class Run(driver.Experiment):
    """The driver's protocol on Yade's scene ``O``."""

    def __init__(self, scene):
        self.scene = scene
        state = RunState.from_dict(json.loads(O.tags["state"]))
        self.top_clump, self.bottom_clump = O.bodies[state.top[0]], O.bodies[state.bottom[0]]
        self.grain_ids = list(range(state.first_grain, state.first_grain + state.n_grains))
        self.grains = [O.bodies[i] for i in self.grain_ids]
        self.radius = np.array([b.shape.radius for b in self.grains])
        self.mass = np.array([b.state.mass for b in self.grains])
        super().__init__(scene.run_dir, scene.spec, state)

    def iteration(self):
        return O.iter

    def time(self):
        return O.time

    def dt(self):
        return O.dt

    def wall_heights(self):
        return self.bottom_clump.state.pos[1], self.top_clump.state.pos[1]

    def wall_force(self):
        return O.forces.f(self.top_clump.id)  # Yade sums the members' forces into the clump

    def move_walls(self, top, bottom):
        self.top_clump.state.vel = Vector3(*top)
        if bottom is not None:
            self.bottom_clump.state.vel = Vector3(*bottom)

    def wall_record(self):
        top, bottom = self.top_clump, self.bottom_clump
        return {"top_position": list(top.state.pos), "bottom_position": list(bottom.state.pos),
                "top_velocity": list(top.state.vel), "bottom_velocity": list(bottom.state.vel),
                "top_force": list(O.forces.f(top.id)), "bottom_force": list(O.forces.f(bottom.id))}

    def gather(self, grains=True):
        """Contact and grain arrays for ``dem.core.measure`` (indexing Vector3s: unpacking them is 5x slower); no
        grain arrays (None) where ``grains`` is false."""
        contacts = []
        for i in O.interactions:  # real interactions only
            g, ph = i.geom, i.phys
            n, c, f = g.normal, g.contactPoint, ph.normalForce + ph.shearForce
            contacts.append((i.id1, i.id2, n[0], n[1], n[2], c[0], c[1], c[2], f[0], f[1], f[2],
                             g.refR1 + g.refR2 - g.penetrationDepth))
        c = np.array(contacts, dtype=float).reshape(-1, 12)
        contacts = {"id1": c[:, 0].astype(np.int64), "id2": c[:, 1].astype(np.int64), "normal": c[:, 2:5],
                    "point": c[:, 5:8], "force": c[:, 8:11], "branch": c[:, 11]}
        if not grains:
            return contacts, None
        kinematics = []
        for b in self.grains:
            x, v = b.state.pos, b.state.vel
            kinematics.append((x[0], x[1], x[2], v[0], v[1], v[2]))
        kin = np.array(kinematics, dtype=float)
        return contacts, {"id": np.array(self.grain_ids), "pos": kin[:, :3], "vel": kin[:, 3:], "radius": self.radius,
                          "mass": self.mass}

    def stop_after_this_step(self):
        """End the run loop once the current step is complete, all engines (this PyRunner too) included.

        ``O.pause()`` from inside a PyRunner would mark the loop stopped while the PyRunner still runs, so the main
        thread could checkpoint a half-sampled state; ``stopAtIter`` is checked by Yade's loop only after the whole
        step.
        """
        O.stopAtIter = O.iter + 1


# ---------------------------------------------------------------- the scene of a run folder
class Scene:
    """The scene of one run folder: its spec (``spec.json``), its files, and once built or loaded the running
    state ``run``. Yade's PyRunner reaches it through ``dem.yade.active`` (its command is a string run in ``__main__``,
    whatever script that is)."""

    def __init__(self, run_dir):
        self.run_dir = run_dir
        self.spec = read_spec(os.path.join(run_dir, "spec.json"))
        self.checkpoint = os.path.join(run_dir, "checkpoint.yade.gz")
        self.run = None

    def build(self):
        """A new scene from the spec (``build``), attached."""
        build(self.spec)
        return self.attach()

    def load(self, path):
        """A saved scene (a checkpoint or a cached state), checked (``load_scene``) and attached."""
        load_scene(path, self.spec)
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

    # what driver.run_scene asks of a scene
    def start(self):
        """Resume from the checkpoint (refusing one that is damaged or of another spec), else build."""
        if os.path.exists(self.checkpoint):
            watchdog.doing(watchdog.LOADING)
            try:
                load_scene(self.checkpoint, self.spec)
                same_spec = DemSpec.from_dict(json.loads(O.tags["spec"])) == self.spec
            except ForeignScene as exc:
                driver.damaged(f"checkpoint {exc}: refused, a checkpoint is data")
            except Exception as exc:  # noqa: BLE001 - any damage: Yade raises RuntimeError, MemoryError, ...
                driver.damaged(f"checkpoint {self.checkpoint} cannot be loaded ({type(exc).__name__})")
            if not same_spec:
                driver.damaged(f"checkpoint {self.checkpoint} belongs to another spec")
            print(f"resumed from checkpoint at iteration {O.iter}", flush=True)
        else:
            build(self.spec)
            print(f"built: {json.loads(O.tags['state'])['n_grains']} grains, dt = {O.dt:.4g}", flush=True)
        try:
            return self.attach()
        except (OSError, ValueError, KeyError, EOFError) as exc:
            driver.damaged(f"the samples of the checkpoint cannot be read ({type(exc).__name__})")

    def advance(self, run, stop):
        """Run to the next checkpoint iteration (or until the scene stops itself) and wait for the loop.

        The loop stops itself only at the end of a whole step (``O.run(n)`` sets ``stopAtIter``), so no engine is
        still running when this returns. A second signal asks for a stop two steps ahead.
        """
        O.run(run.state.next_checkpoint - O.iter)
        target = None
        while O.running:
            if stop["count"] >= 2 and (target is None or O.iter >= target):
                target = O.iter + 2
                O.stopAtIter = target
            time.sleep(0.05)
        O.wait()

    @staticmethod
    def agreed_stop(stop):
        """The stop this (single) process acts on: a copy, as the handlers may count on."""
        return dict(stop)

    def checkpoint_bytes(self):
        return os.path.getsize(self.checkpoint) if os.path.exists(self.checkpoint) else 0

    def save(self, run):
        """The scene with the driver's state, checked to be a whole gzip stream and synced, then renamed onto the
        checkpoint."""
        tmp = os.path.join(self.run_dir, "checkpoint.tmp.yade.gz")
        try:
            O.tags["state"] = json.dumps(run.state.to_dict())
            O.save(tmp)
            if not complete_gzip(tmp):
                raise DiskError(f"the checkpoint written in {self.run_dir} is incomplete (a full disk?)")
            sync(tmp)
            os.replace(tmp, self.checkpoint)
            sync(self.run_dir)
        finally:
            if os.path.exists(tmp):
                os.remove(tmp)

    def reload(self):
        return self.load(self.checkpoint)

    def meta(self):
        st = self.run.state
        return {"engine": "yade", "engine_version": VERSION, "yade_version": VERSION,
                "n_wall_spheres": len(st.top[1]) + len(st.bottom[1])}


def main(run_dir):
    last = os.path.join(run_dir, "checkpoint.yade.gz")
    driver.main(run_dir, Scene, os.path.getsize(last) if os.path.exists(last) else 0)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python3 -m dem.yade.scene RUN_DIR")
    main(sys.argv[1])
