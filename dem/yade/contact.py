"""The contact law of ``dem/core/contact.py`` in Yade: the ``ViscElMat`` material of every sphere and the engines of a
scene of spheres (Yade's python, through ``dem/yade/lib.py``; imported by ``dem/yade/scene.py`` and
``dem/tools/yade_collision.py``)."""

import math

from dem.core.contact import contact_constants
from dem.yade import lib


def contact_material(spec):
    """The Yade material of every sphere. ViscElMat combines two materials' kn, ks, cn, cs in series,
    so each material carries twice the contact value (given kn/ks it must not be given en/et:
    Yade then silently derives the stiffness from Young's modulus instead)."""
    kn, kt, cn, ct = contact_constants(spec)
    return lib.wrapper.ViscElMat(kn=2 * kn, ks=2 * kt, cn=2 * cn, cs=2 * ct,
                                 frictionAngle=math.radians(spec.friction_deg), density=1.0)


def contact_engines():
    """The engines of a scene of spheres with this contact law: no gravity, no numerical damping."""
    w = lib.wrapper
    return [
        w.ForceResetter(),
        w.InsertionSortCollider([w.Bo1_Sphere_Aabb()]),
        w.InteractionLoop([w.Ig2_Sphere_Sphere_ScGeom()], [w.Ip2_ViscElMat_ViscElMat_ViscElPhys()],
                          [w.Law2_ScGeom_ViscElPhys_Basic()]),
        w.NewtonIntegrator(damping=0.0, gravity=(0, 0, 0)),
    ]
