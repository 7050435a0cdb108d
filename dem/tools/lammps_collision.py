"""LAMMPS check of the contact law: the binary collisions and the sliding contact of ``dem.tools.yade_collision``.

``python3 -m dem.tools.lammps_collision SPEC.json OUT.json`` (Debian's python3 with ``python3-lammps``) measures,
with ``dem/lammps/contact.py``'s law, for pairs of equal grains of the smallest, mean and largest diameter:
the normal restitution of a head-on collision; k_t/k_n from a contact sheared at fixed overlap; and the
ratio |F_t|/|F_n| once the contact slides (Coulomb: tan of the friction angle). Same output as
``dem.tools.yade_collision`` (Yade), so one test holds both engines to the same numbers.
"""

import math
import sys

from dem.core.contact import collision_report, contact_constants
from dem.lammps.contact import pair_commands
from dem.lammps.lib import new_lammps


def two_grains(spec, diameter, gap, moving_group=None):
    """A LAMMPS instance with two grains of ``diameter`` on the x axis, ``gap`` apart (negative: overlap)."""
    lmp = new_lammps()
    box = 4 * diameter
    for line in ["units lj", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "newton off", f"region box block {-box} {box} {-box} {box} {-box} {box}",
                 "create_box 1 box", *pair_commands(spec), f"neighbor {0.2 * diameter} bin",
                 "neigh_modify delay 0 every 1 check yes",
                 "create_atoms 1 single 0 0 0", f"create_atoms 1 single {diameter + gap!r} 0 0",
                 f"set atom * diameter {diameter!r}", "set atom * density 1.0"]:
        lmp.command(line)
    m = math.pi / 6 * diameter**3
    kn = contact_constants(spec)[0]
    lmp.command(f"timestep {0.01 * math.sqrt(m / 2 / kn)!r}")
    return lmp


def restitution(spec, diameter, speed=1e-3):
    """Head-on collision of two equal grains approaching at relative speed ``2 speed``."""
    lmp = two_grains(spec, diameter, 1e-3 * diameter / 2)
    lmp.command("fix integrate all nve/sphere")
    lmp.command("velocity all set NULL 0 0")
    lmp.command("group a id 1")
    lmp.command("group b id 2")
    lmp.command(f"velocity a set {speed!r} 0 0")
    lmp.command(f"velocity b set {-speed!r} 0 0")
    m = math.pi / 6 * diameter**3
    kn = contact_constants(spec)[0]
    period = math.pi * math.sqrt(m / 2 / kn)  # half an oscillation of the reduced mass
    dt = 0.01 * math.sqrt(m / 2 / kn)
    lmp.command(f"run {int(3 * period / dt) + int(2e-3 * diameter / 2 / speed / dt)} post no")
    v = lmp.numpy.extract_atom("v")
    return float(v[1, 0] - v[0, 0]) / (2 * speed)


def contact_forces(lmp):
    """(|F_n|, |F_t|) on grain 1, split along the current line of centres."""
    x = lmp.numpy.extract_atom("x")
    f = lmp.numpy.extract_atom("f")
    n = [float(x[1, k] - x[0, k]) for k in range(3)]
    length = math.sqrt(sum(c * c for c in n))
    n = [c / length for c in n]
    fn = sum(float(f[0, k]) * n[k] for k in range(3))
    ft = [float(f[0, k]) - fn * n[k] for k in range(3)]
    return abs(fn), math.sqrt(sum(c * c for c in ft))


def shear(spec, diameter, overlap_ratio=0.5):
    """Contact at a fixed overlap sheared at constant tangential speed: k_t/k_n, k_n against the design,
    and the sliding ratio |F_t|/|F_n|."""
    kn = contact_constants(spec)[0]
    overlap = overlap_ratio * spec.overlap_ratio
    lmp = two_grains(spec, diameter, -overlap)
    dt = lmp.extract_global("dt")
    speed = 1e-4 * overlap / dt
    lmp.command("group b id 2")
    lmp.command(f"fix slide b move linear 0 {speed!r} 0")  # grain 1 is not integrated: it stays put
    lmp.command("run 0 post no")
    samples = []
    for _ in range(20):
        lmp.command("run 10 post no")
        samples.append((lmp.extract_global("ntimestep") * dt, *contact_forces(lmp)))
    (t1, fn, fs1), (t2, _, fs2) = samples[2], samples[-1]
    kt_measured = (fs2 - fs1) / (speed * (t2 - t1))
    kn_measured = fn / overlap
    fs_limit = math.tan(math.radians(spec.friction_deg)) * fn
    lmp.command(f"run {int(3 * fs_limit / (kt_measured * speed * dt)) + 10} post no")
    fn, ft = contact_forces(lmp)
    return kt_measured / kn_measured, kn_measured / kn, ft / fn


def main():
    collision_report(sys.argv, restitution, shear)


if __name__ == "__main__":
    main()
