"""Energy balance of the production scene over a stretch of shear: the walls' work against the dissipated
energy plus the change of kinetic and elastic energy.

``python3 -m dem.tools.yade_energy RUN_DIR STRAIN OUT.json`` (Debian's python3) builds and compacts the scene of
RUN_DIR/spec.json (``dem/tools/yade_profile.py``'s ``prepare``), then shears it by STRAIN (or to the end of the
protocol), one step at a time, and accounts, per step of length dt, for (Yade's energy tracker does not cover
``Law2_ScGeom_ViscElPhys_Basic``, so we do):

- the walls' work on the grains, -F_wall . v_wall dt for each wall (F_wall: the grains' force on its clump);
- the dissipation of every real contact (``dem/core/contact.py``'s law, relative velocity v = v1 - v2 at the
  contact point, v_n = v . n; leapfrog: the law's force uses the velocity at the start of the step, v,
  and the step moves the contact with the velocity at its end, v'): the normal dashpot c_n v_n v_n' dt
  while the normal force is positive; the tangential dashpot c_t v_t . v_t' dt while the contact sticks,
  or friction F_t . v_t' dt while it slides (|F_t| = tan(phi) F_n); and the elastic energy a contact held
  when it opened or its normal force was clipped to zero (released without work);
- the kinetic energy of the grains (translation and rotation) and the elastic energy of the contacts,
  (1/2) F_n^2 / k_n + (1/2) |F_t|^2 / k_t, at the start and the end.

The residual W - D - dE_kin - dE_el, relative to the energy passing through (the larger of W and D), is
what the integration and this accounting leave unexplained; it is written with every term to OUT.json.
"""

import json
import sys

from dem.tools.yade_profile import prepare
from dem.yade import scene as yade_scene
from dem.yade.lib import O, Vector3


def kinetic(grains):
    total = 0.0
    for b in grains:
        v, w, inertia = b.state.vel, b.state.angVel, b.state.inertia
        total += 0.5 * b.state.mass * v.dot(v) + 0.5 * (inertia[0] * w[0] ** 2 + inertia[1] * w[1] ** 2
                                                        + inertia[2] * w[2] ** 2)
    return total


def contact_energies():
    """{(id1, id2): (normal, tangential) elastic energy} of the engaged contacts (normal force positive): the
    springs' own energies, (1/2) k_n u^2 from the elastic part k_n u of the normal force (``phys.Fn``; the
    force the law applies adds the dashpot's c_n v_n) and (1/2) |F_t|^2 / k_t of the stored, elastic,
    tangential force."""
    out = {}
    for i in O.interactions:
        ph = i.phys
        if ph.normalForce.squaredNorm() > 0:
            shear = 0.5 * ph.shearForce.squaredNorm() / ph.ks if ph.ks > 0 else 0.0
            out[(i.id1, i.id2)] = (0.5 * ph.Fn**2 / ph.kn, shear)
    return out


def body_motion():
    """{id: (position, velocity, angular velocity)} of every body (the walls' spheres included)."""
    return {b.id: (Vector3(b.state.pos), Vector3(b.state.vel), Vector3(b.state.angVel)) for b in O.bodies
            if not b.isClump}


def contact_velocity(i, motion, cell):
    """v1 - v2 at the contact point of interaction ``i`` from the bodies' ``motion``."""
    (x1, v1, w1), (x2, v2, w2) = motion[i.id1], motion[i.id2]
    shift = cell.hSize * Vector3(*i.cellDist) if O.periodic else Vector3(0, 0, 0)
    c = i.geom.contactPoint
    return (v1 + w1.cross(c - x1)) - (v2 + w2.cross(c - x2 - shift))


def dissipation_rates(before, after, held, now):
    """(normal dashpot, tangential dashpot, friction) power of the contacts in the step just made: each
    dashpot force c v (v: the velocity the law used, the half step before) times the mean of the half-step
    velocities around the step; friction, the capped tangential force's work over the step less the change
    of its spring's energy (``held`` before, ``now`` after). With the mean, leapfrog's work telescopes
    exactly into the half-step kinetic energies."""
    normal = tangential = friction = 0.0
    cell = O.cell
    for i in O.interactions:
        g, ph = i.geom, i.phys
        fn2 = ph.normalForce.squaredNorm()
        if fn2 == 0 or i.id1 not in before:
            continue
        n = g.normal
        v0, v1 = contact_velocity(i, before, cell), contact_velocity(i, after, cell)
        vm = 0.5 * (v0 + v1)
        vn0, vnm = v0.dot(n), vm.dot(n)
        vt0, vtm = v0 - vn0 * n, vm - vnm * n
        normal += ph.cn * vn0 * vnm
        if ph.shearForce.squaredNorm() >= fn2 * ph.tangensOfFrictionAngle ** 2 * (1 - 1e-9):  # sliding
            key = (i.id1, i.id2)
            stored = now[key][1] - held[key][1] if key in held and key in now else 0.0
            friction += ph.shearForce.dot(vtm) - stored / O.dt
        else:
            tangential += ph.cs * vt0.dot(vtm)
    return normal, tangential, friction


def main():
    strain, out = float(sys.argv[2]), sys.argv[3]
    scene = yade_scene.Scene(sys.argv[1])
    prepare(scene, None, shear_steps=200, chunk=500)  # into the shear, with all of the protocol left
    run = scene.run
    steps = int(strain / (run.gamma_dot * O.dt))
    run.state.next_checkpoint = 1 << 62
    walls = (run.top_clump, run.bottom_clump)
    e_kin0, held = kinetic(run.grains), contact_energies()
    e_el0 = sum(map(sum, held.values()))
    work = normal = tangential = friction = released = 0.0
    made = 0
    previous = [Vector3(w.state.vel) for w in walls]  # the walls' velocities the half step before
    before = body_motion()
    while made < steps and run.state.phase == "shear":
        made += 1
        moved = [Vector3(w.state.vel) for w in walls]  # the velocity each wall moves with in this step
        O.step()
        dt = O.dt
        work -= dt * sum(O.forces.f(w.id).dot(0.5 * (v0 + v1)) for w, v0, v1 in zip(walls, previous, moved,
                                                                                      strict=True))
        previous = moved
        now = contact_energies()
        after = body_motion()  # the next step's "before"
        n, t, f = dissipation_rates(before, after, held, now)
        normal, tangential, friction = normal + n * dt, tangential + t * dt, friction + f * dt
        # a spring gives back only what it took while engaged: the energy it holds when it lets go (opens, or its
        # force is clipped to zero) is dissipated, less what it held when it engaged (re-engaging after a clip,
        # a spring holds energy no work put in)
        released += (sum(sum(e) for key, e in held.items() if key not in now)
                     - sum(sum(e) for key, e in now.items() if key not in held))
        held, before = now, after
    if run.state.phase == "failed":
        sys.stderr.write(f"error: {run.failure}\n")
        sys.exit(3)
    e_kin1, e_el1 = kinetic(run.grains), sum(map(sum, held.values()))
    dissipated = normal + tangential + friction + released
    residual = work - dissipated - (e_kin1 - e_kin0) - (e_el1 - e_el0)
    result = {"steps": made, "strain": made * run.gamma_dot * O.dt, "dt": O.dt, "wall_work": work,
              "dissipated": {"normal_dashpot": normal, "tangential_dashpot": tangential, "friction": friction,
                             "released_on_opening": released, "total": dissipated},
              "kinetic": [e_kin0, e_kin1], "elastic": [e_el0, e_el1], "residual": residual,
              "relative_residual": residual / max(work, dissipated) if made else None}
    with open(out, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
