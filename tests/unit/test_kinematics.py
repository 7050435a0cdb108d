import numpy as np
import pytest

from model import HistoryError, Segment, periodic_cycle, rotation_about_e2, shear_velocity_gradient
from model.kinematics import deviator, modulus, spin, stretching


def test_simple_shear_along_e1():
    L = shear_velocity_gradient(0.0, shear_rate=2.0)
    D = deviator(stretching(L))
    assert L[0, 1] == 2.0 and np.count_nonzero(L) == 1  # L_ij = dv_i/dx_j
    assert D[0, 1] == D[1, 0] == 1.0  # D'12 = gamma_dot / 2
    assert modulus(D) == pytest.approx(2.0 / np.sqrt(2))
    assert spin(L)[0, 1] == 1.0 and spin(L)[1, 0] == -1.0


def test_positive_phi_turns_e1_towards_e3():
    L = shear_velocity_gradient(90.0)
    np.testing.assert_allclose(L[:, 1], [0, 0, 1], atol=1e-15)
    R = rotation_about_e2(90.0)
    np.testing.assert_allclose(R @ shear_velocity_gradient(0.0) @ R.T, L, atol=1e-15)


def test_periodic_cycle_segments():
    h = periodic_cycle(120.0, rotate_at=0.2, shear_rate=0.5)
    assert [s.duration for s in h.segments] == pytest.approx([0.4, 2.4])
    assert h.duration * h.shear_rate == pytest.approx(1.4)
    np.testing.assert_array_equal(h.segment_index(np.array([0.0, 0.39, 0.4, 2.8])), [0, 0, 1, 1])


def test_the_packed_segments_are_read_only_and_c_contiguous():
    """A history caches its packed segments: no caller may change them, and the kernels see one layout."""
    packed = periodic_cycle(120.0, rotate_at=0.2).packed
    for name in ("end", "D_unit", "W_unit", "rate", "D_dev"):
        array = getattr(packed, name)
        assert array.flags.c_contiguous and not array.flags.writeable, name
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0.0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"theta_deg": "x"}, "theta_deg='x' is not a number"),
        ({"theta_deg": np.inf}, "theta_deg=inf is not finite"),
        ({"theta_deg": 90, "rotate_at": 0}, "rotate_at=0.0 must be > 0"),
        ({"theta_deg": 90, "rotate_at": 1.4}, "rotate_at=1.4 must be smaller than the period"),
        ({"theta_deg": 90, "shear_rate": -1}, "shear_rate=-1.0 must be > 0"),
    ],
)
def test_bad_histories(kwargs, message):
    with pytest.raises(HistoryError, match=message):
        periodic_cycle(**kwargs)


def test_segment_without_deviatoric_stretching_is_rejected():
    with pytest.raises(HistoryError, match=r"\|D'\| = 0"):
        Segment(1.0, np.eye(3))
