"""Contact law of the Couette experiment (Sec. 2): linear visco-elastic with Coulomb friction.

Constant normal stiffness k_n = p d^2 / delta (the mean overlap delta/d = ``overlap_ratio``),
tangential stiffness k_t = ``kt_over_kn`` k_n, and constant damping coefficients c_n, c_t chosen so
that the *mean pair* (two grains of diameter d) has the restitution ``restitution`` in both the
normal and the tangential spring-dashpot. A pair of other masses then has another restitution
(zeta = c / (2 sqrt(k m_eff)) changes with the reduced mass m_eff): k_n, c_n and c_t are constants,
as the paper states, rather than e. Units d = p = rho = 1.
"""

import math


def restitution_of_damping_ratio(zeta):
    """Restitution of a linear spring-dashpot collision that ends when the contact force vanishes.

    Yade's contact carries no tension, so the grains part when k x + c x' = 0, before the overlap x
    returns to zero. With x = (v0/w_d) exp(-zeta w0 t) sin(w_d t), w_d = w0 sqrt(1 - zeta^2), the force
    vanishes at w_d t* = pi - atan2(2 zeta sqrt(1 - zeta^2), 1 - 2 zeta^2), and e = -x'(t*)/v0.
    """
    if zeta >= 1:
        return 0.0
    root = math.sqrt(1 - zeta**2)
    phase = math.pi - math.atan2(2 * zeta * root, 1 - 2 * zeta**2)
    ratio = zeta / root
    return -math.exp(-ratio * phase) * (math.cos(phase) - ratio * math.sin(phase))


def damping_ratio(restitution):
    """The damping ratio zeta that gives ``restitution`` (inverse of the above, by bisection)."""
    lo, hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if restitution_of_damping_ratio(mid) > restitution else (lo, mid)
    return 0.5 * (lo + hi)


def restitution(stiffness, damping, reduced_mass):
    """Restitution of a pair with the given contact stiffness, damping and reduced mass."""
    return restitution_of_damping_ratio(damping / (2 * math.sqrt(stiffness * reduced_mass)))


def pair_reduced_mass(d1, d2):
    """Reduced mass of two unit-density spheres of diameters d1, d2."""
    m1, m2 = math.pi / 6 * d1**3, math.pi / 6 * d2**3
    return m1 * m2 / (m1 + m2)


def contact_constants(spec):
    """(k_n, k_t, c_n, c_t) of a contact, damping set for the mean pair."""
    kn = 1.0 / spec.overlap_ratio
    kt = spec.kt_over_kn * kn
    zeta = damping_ratio(spec.restitution)
    m_eff = pair_reduced_mass(1.0, 1.0)
    return kn, kt, 2 * zeta * math.sqrt(kn * m_eff), 2 * zeta * math.sqrt(kt * m_eff)


def tangential_damping_number(spec):
    """c_t dt / m_t of the lightest pair (two grains of ``diameter_min_d``), dt = dt_safety sqrt(m_min / k_n):
    the explicit step of the tangential dashpot, m_t = (2/7) m_eff the pair's mass for tangential sliding
    of rolling spheres (1/m_t = 3.5/m1 + 3.5/m2). A stiff dashpot integrated explicitly diverges when this
    is too large: on the tiny cell the energy balance closes at 2.97 and the run blows up at 3.96."""
    kn, _, _, ct = contact_constants(spec)
    d = spec.diameter_min_d
    m_min = math.pi / 6 * d**3
    dt = spec.dt_safety * math.sqrt(m_min / kn)
    return ct * dt / (2 / 7 * pair_reduced_mass(d, d))


def collision_report(argv, restitution_of, shear_of):
    """The command line of an engine's contact check (``dem.tools.yade_collision``, ``dem.tools.lammps_collision``):
    read the spec ``argv[1]``, measure the smallest, mean and largest pairs with the engine's ``restitution_of(spec,
    d)`` and ``shear_of(spec, d)`` (k_t/k_n, k_n against the design, sliding ratio), write them as JSON to
    ``argv[2]``."""
    import json

    from dem.core.spec import read_spec

    spec = read_spec(argv[1])
    d_mean = 0.5 * (spec.diameter_min_d + spec.diameter_max_d)
    out = {}
    for label, diameter in (("smallest", spec.diameter_min_d), ("mean", d_mean),
                            ("largest", spec.diameter_max_d)):
        kt_over_kn, kn_ratio, sliding = shear_of(spec, diameter)
        out[label] = {"diameter": diameter, "restitution": restitution_of(spec, diameter),
                      "kt_over_kn": kt_over_kn, "kn_over_design": kn_ratio, "sliding_ratio": sliding}
    with open(argv[2], "w") as fh:
        json.dump(out, fh, indent=1)
