"""The contact law of ``dem/core/contact.py`` in LAMMPS (``pair_style granular``, GRANULAR package).

Same constants: k_n = p d^2/delta, k_t = ``kt_over_kn`` k_n, constant dashpots c_n, c_t (the mean pair has
the restitution ``restitution``), Coulomb friction tan(``friction_deg``), no rolling resistance, units
d = p = rho = 1 (LAMMPS ``units lj``, grains of density 1). In LAMMPS's terms:

    pair_coeff * * hooke k_n c_n tangential linear_history k_t (c_t/c_n) mu damping velocity limit_damping cutoff d_max

``hooke`` with ``damping velocity`` is F_n = k_n delta - c_n v_n with a constant c_n; ``limit_damping``
keeps the normal force from pulling (Yade's contact carries no tension either); ``linear_history`` is a
tangential spring k_t with a dashpot x_gamma_t c_n = c_t. The cut-off is the largest grain's diameter (the largest
sum of radii), given explicitly because this LAMMPS restores the pair style from a restart file with a zero one.
Where the two engines differ: LAMMPS limits the tangential spring *and* dashpot together to mu F_n, Yade's
``ViscElPhys`` the whole tangential force too (its Coulomb test is on the spring force, the dashpot added after);
``dem.tools.lammps_collision`` measures both.
"""

import math

from dem.core.contact import contact_constants


def pair_commands(spec):
    """The LAMMPS commands of the contact law for one atom type."""
    kn, kt, cn, ct = contact_constants(spec)
    mu = math.tan(math.radians(spec.friction_deg))
    return [
        "pair_style granular",
        f"pair_coeff * * hooke {kn!r} {cn!r} tangential linear_history {kt!r} {ct / cn!r} {mu!r} "
        f"damping velocity limit_damping cutoff {float(spec.diameter_max_d)!r}",
        "comm_modify vel yes",
    ]
