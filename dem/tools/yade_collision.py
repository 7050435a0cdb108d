"""Yade check of the contact law: binary collisions and a sliding contact.

``python3 -m dem.tools.yade_collision SPEC.json OUT.json`` (Debian's python3) measures, with the scene's own material
(``dem/core/contact.py``), for pairs of equal grains of the smallest, mean and largest diameter:
the normal restitution of a head-on collision; k_t/k_n from a contact sheared at fixed overlap;
and the ratio |F_t|/|F_n| once the contact slides (Coulomb: tan of the friction angle).
"""

import math
import sys

from dem.core.contact import collision_report, contact_constants
from dem.yade.contact import contact_engines, contact_material
from dem.yade.lib import O, Vector3, utils


def reset(spec, diameter):
    O.reset()
    O.engines = contact_engines()
    mat = O.materials.append(contact_material(spec))
    kn = contact_constants(spec)[0]
    m = math.pi / 6 * diameter**3
    O.dt = 0.01 * math.sqrt(m / 2 / kn)
    return mat


def restitution(spec, diameter, speed=1e-3):
    """Head-on collision of two equal grains approaching at relative speed ``2 speed``."""
    mat = reset(spec, diameter)
    r = diameter / 2
    a = O.bodies.append(utils.sphere((0, 0, 0), r, material=mat))
    b = O.bodies.append(utils.sphere((2 * r + 1e-3 * r, 0, 0), r, material=mat))
    O.bodies[a].state.vel = Vector3(speed, 0, 0)
    O.bodies[b].state.vel = Vector3(-speed, 0, 0)
    touched = False
    for _ in range(200000):
        O.step()
        if O.interactions.countReal():
            touched = True
        elif touched:
            break
    relative = O.bodies[b].state.vel[0] - O.bodies[a].state.vel[0]
    return relative / (2 * speed)


def shear(spec, diameter, overlap_ratio=0.5):
    """Contact at a fixed overlap sheared at constant tangential speed: k_t/k_n and sliding ratio."""
    mat = reset(spec, diameter)
    r = diameter / 2
    kn = contact_constants(spec)[0]
    overlap = overlap_ratio * spec.overlap_ratio
    a = O.bodies.append(utils.sphere((0, 0, 0), r, material=mat))
    b = O.bodies.append(utils.sphere((2 * r - overlap, 0, 0), r, material=mat))
    for i in (a, b):
        O.bodies[i].dynamic = False
    speed = 1e-4 * overlap / O.dt
    O.step()  # the contact forms at rest
    O.bodies[b].state.vel = Vector3(0, speed, 0)
    samples = []
    for _ in range(20):
        O.run(10, True)
        i = O.interactions[a, b]
        samples.append((O.time, i.phys.normalForce.norm(), i.phys.shearForce.norm()))
    (t1, fn, fs1), (t2, _, fs2) = samples[2], samples[-1]
    kt_measured = (fs2 - fs1) / (speed * (t2 - t1))
    kn_measured = fn / overlap
    fs_limit = math.tan(math.radians(spec.friction_deg)) * fn
    O.run(int(3 * fs_limit / (kt_measured * speed * O.dt)) + 10, True)
    i = O.interactions[a, b]
    return kt_measured / kn_measured, kn_measured / kn, i.phys.shearForce.norm() / i.phys.normalForce.norm()


def main():
    collision_report(sys.argv, restitution, shear)


if __name__ == "__main__":
    main()
