"""The in-situ measurement functions against hand-computed contact and grain sets."""

import numpy as np
import pytest

from dem.core import measure


def contact_set():
    """Three contacts with known normals, forces and branch lengths."""
    n = np.array([[1.0, 0, 0], [0, 1.0, 0], [np.sqrt(0.5), np.sqrt(0.5), 0]])
    f = np.array([[2.0, 0, 0], [0, 1.0, 0], [0.5, 0.5, 0.0]])  # repulsive: along +normal on body 2
    length = np.array([1.0, 0.8, 1.2])
    return n, f, length


def test_love_weber_stress_by_hand():
    n, f, length = contact_set()
    sigma = measure.love_weber_stress(n, length, f, volume=10.0)
    # sum_c l_i f_j: (1,0,0)x(2,0,0) -> xx 2; (0,.8,0)x(0,1,0) -> yy .8; 1.2*(s,s)x(.5,.5) -> 0.6*s each
    s = np.sqrt(0.5) * 1.2 * 0.5
    expected = -np.array([[2 + s, s, 0], [s, 0.8 + s, 0], [0, 0, 0]]) / 10.0
    np.testing.assert_allclose(sigma, expected, atol=1e-15)
    assert np.all(np.linalg.eigvalsh(sigma) <= 1e-15), "repulsive contacts give compression (tension positive)"


def test_stress_of_an_isotropically_loaded_sphere_is_minus_p():
    # six contacts on the axes, force F on each, radius R: sigma = -(6 F R ... ) -> -(2 F R) I / V per axis pair
    normals = np.vstack([np.eye(3), -np.eye(3)])
    force, branch = 3.0, 1.0
    sigma = measure.love_weber_stress(normals, np.full(6, branch), force * normals, volume=2.0)
    np.testing.assert_allclose(sigma, -2 * force * branch / 2.0 * np.eye(3), atol=1e-15)


def test_fabric_by_hand_is_deviatoric():
    n, _, _ = contact_set()
    A = measure.fabric(n)
    expected = np.array([[1 + 0.5, 0.5, 0], [0.5, 1 + 0.5, 0], [0, 0, 0]]) / 3 - np.eye(3) / 3
    np.testing.assert_allclose(A, expected, atol=1e-15)
    assert np.trace(A) == pytest.approx(0, abs=1e-15)
    assert np.all(np.isnan(measure.fabric(np.zeros((0, 3)))))


def test_slab_volume_whole_half_and_cap():
    r = np.array([0.5, 0.5, 0.5])
    y = np.array([0.0, 1.0, 5.0])
    v = measure.slab_volume(y, r, lo=-1.0, hi=1.0)
    sphere = 4 / 3 * np.pi * 0.125
    np.testing.assert_allclose(v, [sphere, sphere / 2, 0.0])
    h = 0.2  # a cap of height h: pi h^2 (3r - h)/3
    cap = measure.slab_volume(np.array([0.0]), np.array([0.5]), lo=0.3, hi=2.0)
    assert cap[0] == pytest.approx(np.pi * h**2 * (1.5 - h) / 3)


def test_velocity_gradient_recovers_a_linear_profile():
    rng = np.random.default_rng(1)
    y = rng.uniform(0, 5, 200)
    v = np.outer(y, [0.3, 0.0, -0.1]) + [1.0, 0.0, 2.0]
    np.testing.assert_allclose(measure.velocity_gradient(y, v, rng.uniform(0.1, 1, 200)), [0.3, 0, -0.1], atol=1e-12)


def test_measure_region_and_profiles():
    # two grains inside the region touching each other, one grain in the bottom bin touching the wall (id 0)
    grains = {"id": np.array([5, 6, 7]), "pos": np.array([[1, 2.0, 1], [1, 3.0, 1], [1, 0.6, 1]]),
              "vel": np.array([[0.1, 0, 0], [0.3, 0, 0], [0.0, 0, 0]]), "radius": np.full(3, 0.5),
              "mass": np.full(3, np.pi / 6)}
    contacts = {"id1": np.array([5, 0]), "id2": np.array([6, 7]), "normal": np.array([[0, 1.0, 0], [0, 1.0, 0]]),
                "point": np.array([[1, 2.5, 1], [1, 0.1, 1]]), "force": np.array([[0, 2.0, 0], [0, 1.0, 0]]),
                "branch": np.array([1.0, 1.0])}
    out = measure.measure(contacts, grains, first_grain_id=5, area=4.0, region=(1.5, 3.5),
                          edges=np.array([0.0, 1.0, 2.0, 3.0, 4.0]))
    volume = 4.0 * 2.0
    np.testing.assert_allclose(out["stress_contact"], -np.diag([0, 2.0, 0]) / volume, atol=1e-15)
    np.testing.assert_allclose(out["fabric"], np.diag([-1, 2, -1]) / 3, atol=1e-15)
    assert out["contacts"] == 1 and out["grains"] == 2 and out["coordination"] == 1.0
    np.testing.assert_allclose(out["velocity_gradient"], [0.2, 0, 0])
    # region: two whole spheres of volume pi/6 in 8 d^3
    assert out["packing_fraction"] == pytest.approx(2 * np.pi / 6 / volume)
    # the wall contact counts in the bottom bin's stress but not in its fabric
    assert out["profile_contacts"][0] == 0 and np.isnan(out["profile_fabric"][0]).all()
    assert out["profile_stress"][0][1, 1] == pytest.approx(-1.0 / 4.0)
    np.testing.assert_allclose(out["profile_velocity"][:, 0], [0.0, np.nan, 0.1, 0.3], equal_nan=True)
    # every grain's volume lands in the profile bins
    assert out["profile_packing_fraction"].sum() * 4.0 == pytest.approx(3 * np.pi / 6)
