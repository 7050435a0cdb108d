"""Energy balance of the production scene over a stretch of shear: the walls' work against the dissipated
energy plus the change of kinetic and elastic energy.

``python3 -m dem.energy RUN_DIR STRAIN OUT.json`` (Debian's python3) builds and compacts the scene of
RUN_DIR/spec.json (``dem/profile.py``'s ``prepare``), then shears it by STRAIN (or to the end of the protocol),
one step at a time, and accounts, per step of length dt, for (Yade's energy tracker does not cover
``Law2_ScGeom_ViscElPhys_Basic``, so we do):

- the walls' work on the grains, -F_wall . v_wall dt for each wall (F_wall: the grains' force on its clump);
- the dissipation of every real contact (``dem/contact.py``'s law, relative velocity v = v1 - v2 at the
  contact point, v_n = v . n): the normal dashpot c_n v_n^2 dt while the normal force is positive; the
  tangential dashpot c_t |v_t|^2 dt while the contact sticks, or friction |F_t| |v_t| dt while it slides
  (|F_t| = tan(phi) F_n); and the elastic energy a contact held when it opened or its normal force was
  clipped to zero (released without work);
- the kinetic energy of the grains (translation and rotation) and the elastic energy of the contacts,
  (1/2) F_n^2 / k_n + (1/2) |F_t|^2 / k_t, at the start and the end.

The residual W - D - dE_kin - dE_el, relative to the energy passing through (the larger of W and D), is
what the integration and this accounting leave unexplained; it is written with every term to OUT.json.
"""

import json
import sys

from dem import couette
from dem.profile import (
    control,  # noqa: F401 - the PyRunner's command runs in this namespace
    prepare,
)
from dem.yade_lib import O


def kinetic(grains):
    total = 0.0
    for b in grains:
        v, w, inertia = b.state.vel, b.state.angVel, b.state.inertia
        total += 0.5 * b.state.mass * v.dot(v) + 0.5 * (inertia[0] * w[0] ** 2 + inertia[1] * w[1] ** 2
                                                        + inertia[2] * w[2] ** 2)
    return total


def contact_energies():
    """{(id1, id2): elastic energy} of the real contacts whose normal force is positive."""
    out = {}
    for i in O.interactions:
        ph = i.phys
        fn2, fs2 = ph.normalForce.squaredNorm(), ph.shearForce.squaredNorm()
        if fn2 > 0:
            out[(i.id1, i.id2)] = 0.5 * fn2 / ph.kn + (0.5 * fs2 / ph.ks if ph.ks > 0 else 0.0)
    return out


def dissipation_rates():
    """(normal dashpot, tangential dashpot, friction) power of the contacts in the step just made."""
    normal = tangential = friction = 0.0
    for i in O.interactions:
        g, ph = i.geom, i.phys
        fn2 = ph.normalForce.squaredNorm()
        if fn2 == 0:
            continue
        n = g.normal
        v = -g.incidentVel(i, False)  # Yade's incident velocity is v2 - v1
        vn = v.dot(n)
        vt = v - vn * n
        normal += ph.cn * vn * vn
        sliding = ph.shearForce.squaredNorm() >= fn2 * ph.tangensOfFrictionAngle ** 2 * (1 - 1e-9)
        if sliding:
            friction += ph.shearForce.norm() * vt.norm()
        else:
            tangential += ph.cs * vt.dot(vt)
    return normal, tangential, friction


def main():
    strain, out = float(sys.argv[2]), sys.argv[3]
    couette.configure(sys.argv[1])
    prepare(None)
    run = couette.RUN
    steps = int(strain / (run.gamma_dot * O.dt))
    run.state["next_checkpoint"] = 1 << 62
    walls = (run.top_clump, run.bottom_clump)
    e_kin0, held = kinetic(run.grains), contact_energies()
    e_el0 = sum(held.values())
    work = normal = tangential = friction = released = 0.0
    made = 0
    while made < steps and run.state["phase"] == "shear":
        made += 1
        velocities = [w.state.vel for w in walls]  # the velocity each wall moves with during the step
        O.step()
        dt = O.dt
        work -= sum(O.forces.f(w.id).dot(v) for w, v in zip(walls, velocities, strict=True)) * dt
        n, t, f = dissipation_rates()
        normal, tangential, friction = normal + n * dt, tangential + t * dt, friction + f * dt
        now = contact_energies()
        released += sum(e for key, e in held.items() if key not in now)
        held = now
    if run.state["phase"] == "failed":
        sys.stderr.write(f"error: {run.failure}\n")
        sys.exit(3)
    e_kin1, e_el1 = kinetic(run.grains), sum(held.values())
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
