"""The material-point update (``model.update``): accuracy against ``model.predict``, its symmetries,
the stationary limit, batching and threads, and its input checks."""

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import model
from model import (
    PAPER,
    History,
    Segment,
    SolverError,
    Update,
    integrate,
    material_point,
    periodic_cycle,
    predict,
    update,
)
from model.equations import fabric_within_bounds, observables
from model.kinematics import shear_velocity_gradient

STRAIN_STEP = 0.005
DOCS = Path(__file__).resolve().parents[2] / "docs" / "model.md"


def step_through_cycle(theta, rotate_at=0.7, **options):
    """The predicted cycle's start stepped through one period at 0.005 strain per update; returns the
    cycle, the updates' A, Phi, tau/p after each step and the D' of each step."""
    strains = np.arange(281) * STRAIN_STEP
    cycle = predict(theta, rotate_at=rotate_at, times=strains, rtol=1e-12, atol=1e-14)
    history = periodic_cycle(theta, rotate_at=rotate_at)
    A, phi = cycle.A[:1].copy(), cycle.packing_fraction[:1].copy()
    out = {"A": [], "phi": [], "tau": [], "D": []}
    for k in range(280):
        segment = history.segments[history.segment_index(np.array([(k + 0.5) * STRAIN_STEP]))[0]]
        result = update(A, phi, segment.L, STRAIN_STEP, **options)
        A, phi = result.A.copy(), result.phi.copy()
        out["A"].append(A[0])
        out["phi"].append(phi[0])
        out["tau"].append(result.tau_over_p[0])
        out["D"].append(segment.D_dev)
    return cycle, {key: np.array(value) for key, value in out.items()}


@pytest.mark.parametrize("theta, rotate_at", [(t, 0.7) for t in (30, 60, 90, 120, 150, 180)] + [(90, 0.1), (90, 0.2)])
def test_stepping_through_a_cycle_agrees_with_predict_within_1e6(theta, rotate_at):
    cycle, steps = step_through_cycle(theta, rotate_at)
    assert np.max(np.abs(steps["A"] - cycle.A[1:])) < 1e-6
    assert np.max(np.abs(steps["phi"] - cycle.packing_fraction[1:])) < 1e-6
    # tau/p at the end of a step uses that step's D' (predict's output at a segment end uses the next one)
    expected = observables(cycle.A[1:], steps["D"], PAPER.as_array())["tau"]
    assert np.max(np.abs(steps["tau"] - expected)) < 1e-6


def test_a_looser_tolerance_costs_less_and_is_less_accurate():
    _, tight = step_through_cycle(180, rtol=1e-10, atol=1e-12)
    cycle, loose = step_through_cycle(180, rtol=1e-4, atol=1e-6)
    err_tight = np.max(np.abs(tight["A"] - cycle.A[1:]))
    err_loose = np.max(np.abs(loose["A"] - cycle.A[1:]))
    assert err_tight < err_loose


def test_large_steps_substep_and_agree_with_integrate():
    L = shear_velocity_gradient(0.0)
    A0, phi0 = predict(180).A[0], 0.6
    reference = integrate(History((Segment(0.5, L),)), A0=A0, packing_fraction0=phi0, times=[0.5])
    result = update(A0[None], [phi0], L, 0.5)
    assert result.substeps[0] > 1
    assert np.max(np.abs(result.A[0] - reference.A[-1])) < 1e-7
    assert abs(result.phi[0] - reference.packing_fraction[-1]) < 1e-7
    assert np.max(np.abs(result.tau_over_p[0] - reference.tau[-1])) < 1e-7


def test_isotropic_start_matches_integrate_through_S_zero():
    L = shear_velocity_gradient(30.0, shear_rate=3.0)
    reference = integrate(History((Segment(0.01 / 3.0, L),), shear_rate=3.0), times=[0.01])
    result = update(np.zeros((1, 3, 3)), [PAPER.phi_c], L, 0.01 / 3.0)
    assert np.max(np.abs(result.A[0] - reference.A[-1])) < 1e-8
    assert abs(result.S[0] - reference.S[-1]) < 1e-8


def test_rate_independence_and_objectivity():
    rng = np.random.default_rng(3)
    cycle = predict(120)
    A, phi = cycle.A[::40], cycle.packing_fraction[::40]
    L = rng.normal(size=(len(phi), 3, 3))
    base = update(A, phi, L, 0.004)
    faster = update(A, phi, 2.5 * L, 0.004 / 2.5)
    assert np.max(np.abs(faster.A - base.A)) < 1e-9
    assert np.max(np.abs(faster.tau_over_p - base.tau_over_p)) < 1e-9
    Q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    Q *= np.sign(np.diag(r))
    turned = update(Q @ A @ Q.T, phi, Q @ L @ Q.T, 0.004)
    assert np.max(np.abs(turned.A - Q @ base.A @ Q.T)) < 1e-9
    assert np.max(np.abs(turned.tau_over_p - Q @ base.tau_over_p @ Q.T)) < 1e-9
    assert np.max(np.abs(turned.phi - base.phi)) < 1e-12


def test_objective_under_a_superposed_rotation():
    """Seen from a frame spinning at Omega, the velocity gradient is Q L Q^T + Omega (Q = exp(Omega t)) and
    the fabric must be Q A Q^T. Freezing Q at mid-step errs by O(dt^2) over a fixed strain: the
    difference must fall fourfold when dt halves (a non-objective rate would leave an O(1) one)."""
    cycle = predict(60)
    A0, phi0 = cycle.A[[10, 150]], cycle.packing_fraction[[10, 150]]
    L = shear_velocity_gradient(60.0)
    omega = np.array([[0.0, 0.8, -0.3], [-0.8, 0.0, 0.5], [0.3, -0.5, 0.0]])
    errors = []
    for n in (20, 40):
        dt = 0.4 / n
        A, phi, A_spun, phi_spun = A0, phi0, A0, phi0
        for k in range(n):
            Q = expm(omega * (k + 0.5) * dt)
            plain, spun = update(A, phi, L, dt), update(A_spun, phi_spun, Q @ L @ Q.T + omega, dt)
            A, phi, A_spun, phi_spun = plain.A, plain.phi, spun.A, spun.phi
        Q = expm(omega * 0.4)
        errors.append(np.max(np.abs(A_spun - Q @ A @ Q.T)))
        assert np.max(np.abs(phi_spun - phi)) < 1e-5
    assert errors[0] < 1e-4
    assert 3.0 < errors[0] / errors[1] < 5.0


def random_batch(n: int = 600):
    """n material points: fabrics from the 60-degree cycle, random Phi, velocity gradients and steps."""
    rng = np.random.default_rng(5)
    cycle = predict(60)
    A = cycle.A[rng.integers(0, len(cycle.strain), n)]
    return A, rng.uniform(0.55, 0.65, n), rng.normal(size=(n, 3, 3)), rng.uniform(0.0, 0.02, n)


def test_batch_equals_point_by_point():
    A, phi, L, dt = random_batch()
    batch = update(A, phi, L, dt)
    single = [update(A[i:i + 1], phi[i:i + 1], L[i], dt[i]) for i in range(0, len(A), 97)]
    for i, one in zip(range(0, len(A), 97), single, strict=True):
        assert np.array_equal(one.A[0], batch.A[i]) and one.phi[0] == batch.phi[i]


@pytest.mark.slow  # compiles the parallel kernel (seconds on a fresh clone)
def test_threads_agree_bit_for_bit():
    A, phi, L, dt = random_batch()
    batch, parallel = update(A, phi, L, dt), update(A, phi, L, dt, threads=2)
    for name in ("A", "phi", "tau_over_p", "S", "substeps", "stationary"):
        assert np.array_equal(getattr(parallel, name), getattr(batch, name), equal_nan=name != "substeps"), name


def test_one_thread_from_callers_own_threads_at_once_agrees_with_the_main_threads():
    """On the main thread a batch goes through numba's pool (on one thread); from a caller's own threads, which the
    pool would refuse at once, through the kernel without it: the same numbers, and no crash."""
    import threading

    A, phi, L, dt = random_batch()
    assert len(A) >= material_point.CHUNK
    expected = update(A, phi, L, dt)
    results, errors = {}, []

    def work(k):
        try:
            for _ in range(3):
                results[k] = update(A, phi, L, dt)
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    workers = [threading.Thread(target=work, args=(k,)) for k in range(3)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert not errors and len(results) == 3
    for result in results.values():
        assert np.array_equal(result.A, expected.A) and np.array_equal(result.phi, expected.phi)


#: several Python threads updating on numba's pool at once, under the threading layer ``sys.argv[1]``
CONCURRENT = """
import sys, threading
import numpy as np
import numba
numba.config.THREADING_LAYER = sys.argv[1]
from model import update
from tests.unit.test_material_point import random_batch
A, phi, L, dt = random_batch()
expected = update(A, phi, L, dt)
same = []
def work():
    for _ in range(3):
        result = update(A, phi, L, dt, threads=2)
        same.append(bool(np.array_equal(result.A, expected.A) and np.array_equal(result.phi, expected.phi)))
workers = [threading.Thread(target=work) for _ in range(3)]
[w.start() for w in workers]
[w.join() for w in workers]
print(numba.threading_layer(), len(same), all(same))
"""


def test_two_threads_each_from_callers_own_threads_at_once_under_numbas_workqueue_layer():
    """The one layer that is not thread-safe (numba's own, where TBB and OpenMP are missing) would abort the process
    when two Python threads enter the pool at once: they take turns, and agree with the serial update."""
    import subprocess
    import sys

    from pipeline.paths import ROOT

    proc = subprocess.run([sys.executable, "-c", CONCURRENT, "workqueue"], capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-800:]
    assert proc.stdout.split() == ["workqueue", "9", "True"]


def test_in_place_update_and_broadcast_forms():
    cycle = predict(90)
    A, phi = cycle.A[:50].copy(), cycle.packing_fraction[:50].copy()
    L = shear_velocity_gradient(90.0)
    expected = update(A, phi, np.broadcast_to(L, (50, 3, 3)), np.full(50, 0.005))
    state = Update.empty(50)
    state.A[:], state.phi[:] = A, phi
    result = update(state.A, state.phi, L, 0.005, out=state)
    assert result is state
    assert np.array_equal(state.A, expected.A) and np.array_equal(state.phi, expected.phi)


def test_the_kernels_compile_once_whatever_layout_the_caller_hands_them():
    """Writable, read-only and Fortran-ordered inputs, one- and two-segment histories: one compiled signature
    per entry kernel (each further one costs seconds of compilation)."""
    from model import integrator, material_point

    cycle = predict(90)
    A, phi = cycle.A[:4].copy(), cycle.packing_fraction[:4].copy()
    L = shear_velocity_gradient(90.0)
    for L_given in (np.broadcast_to(L, (4, 3, 3)), np.asfortranarray(np.stack([L] * 4)), L.copy()):
        update(A, phi, L_given, 0.01)
    integrate(History((Segment(1.0, L),)))
    integrate(periodic_cycle(90.0, rotate_at=0.1))
    for kernel in (material_point._check_inputs, material_point._update_serial, integrator.dop853,
                   integrator.outputs):
        assert len(kernel.signatures) == 1, (kernel.__name__, kernel.signatures)


def test_zero_step_keeps_the_state_and_gives_eq14_stress():
    cycle = predict(150)
    A, phi = cycle.A[:5], cycle.packing_fraction[:5]
    L = shear_velocity_gradient(150.0)
    result = update(A, phi, L, 0.0)
    assert np.array_equal(result.A, A) and np.array_equal(result.phi, phi)
    expected = observables(A, np.broadcast_to(L + L.T, (5, 3, 3)) / 2, PAPER.as_array())["tau"]
    assert np.max(np.abs(result.tau_over_p - expected)) < 1e-14


def test_without_deviatoric_stretching_fabric_co_rotates_and_stress_is_undefined():
    cycle = predict(90)
    A, phi = cycle.A[:4], cycle.packing_fraction[:4]
    W = np.array([[0.0, 0.3, -0.2], [-0.3, 0.0, 0.5], [0.2, -0.5, 0.0]])
    L = W + 0.7 * np.eye(3)  # spin plus isotropic expansion: D' = 0
    result = update(A, phi, L, 1.3)
    R = expm(W * 1.3)
    assert result.stationary.all() and (result.substeps == 0).all()
    assert np.max(np.abs(result.A - R @ A @ R.T)) < 1e-13
    assert np.array_equal(result.phi, phi)
    assert np.isnan(result.tau_over_p).all() and np.isnan(result.S).all()
    at_rest = update(A, phi, np.zeros((3, 3)), 1.0)
    assert np.array_equal(at_rest.A, A) and at_rest.stationary.all()


GOOD = {"A": np.zeros((2, 3, 3)), "phi": [0.6, 0.6], "L": shear_velocity_gradient(0.0), "dt": 0.01}


@pytest.mark.parametrize("change, message", [
    ({"A": np.zeros((2, 3))}, r"A has shape \(2, 3\), expected \(N, 3, 3\)"),
    ({"A": np.zeros((0, 3, 3))}, r"A has shape \(0, 3, 3\)"),
    ({"A": np.stack([np.zeros((3, 3)), np.diag([1e-6, 0, 0])])}, r"A\[1\] is not traceless"),
    ({"A": np.stack([np.zeros((3, 3)), np.triu(np.ones((3, 3)), 1) * 0.01])}, r"A\[1\] is not symmetric"),
    ({"A": np.full((2, 3, 3), np.nan)}, r"A\[0\] has non-finite entries"),
    ({"phi": [0.6, 1.0]}, r"phi\[1\]=1.0 must lie in \(0, 0.7405\)"),
    ({"phi": [0.6, 0.75]}, r"phi\[1\]=0.75 must lie in \(0, 0.7405\) \(pi/\(3 sqrt 2\), the densest packing"),
    ({"phi": [0.6]}, r"phi has shape \(1,\), expected \(2,\)"),
    ({"A": np.stack([np.zeros((3, 3)), np.diag([0.7, -0.35, -0.35])])}, r"A\[1\] leaves the bounds of Eq. 8"),
    ({"L": np.zeros((3, 3, 3))}, r"L has shape \(3, 3, 3\), expected \(3, 3\) or \(2, 3, 3\)"),
    ({"L": np.full((3, 3), np.inf)}, r"L\[0\] is not finite or too large"),
    ({"L": np.full((3, 3), 1e200)}, r"L\[0\] is not finite or too large: the sum of its squared entries is inf"),
    ({"dt": [0.01, -0.01]}, r"dt\[1\]=-0.01 must be finite and >= 0"),
    ({"dt": "soon"}, r"dt must be an array of numbers"),
    ({"rtol": 0.0}, r"rtol=0.0 must be a number in \(0, 1\)"),
    ({"threads": 0}, r"threads=0 must be an integer"),
    ({"params": {"C": -5.6}}, r"params must be a model.Params"),
    ({"out": Update.empty(3)}, r"out.A must be a writable C-contiguous float64 array of shape \(2, 3, 3\)"),
])
def test_bad_input_is_one_line_naming_the_value(change, message):
    with pytest.raises(SolverError, match=message) as info:
        update(**{**GOOD, **change})
    assert "\n" not in str(info.value)


def in_place(A, phi, params):
    """An ``Update`` whose fabric and packing fraction are ``A`` and ``phi`` themselves."""
    out = Update.empty(len(phi), params)
    out.A, out.phi = A, phi
    return out


def test_a_step_that_would_leave_the_physics_is_refused_naming_the_point_which_keeps_its_state():
    """Eq. 18 past the densest packing of spheres (``jump`` at its bound kappa = 0.1, where ``predict`` refuses
    too), and a fabric outside Eq. 8's bounds: the step is refused at the first such point, which keeps its start
    state, in place as in a new output."""
    dense = model.Params(variant="jump", jump_fabric=0.1)
    with pytest.raises(SolverError, match=r"denser than any packing") as info:
        model.predict(180, params=dense)
    assert "\n" not in str(info.value)
    A = np.zeros((3, 3, 3))
    phi = np.array([0.6, 0.6, 0.7404])
    L = np.stack([shear_velocity_gradient(0.0)] * 3)
    kept_A, kept_phi = A.copy(), phi.copy()
    with pytest.raises(SolverError, match=r"failed at 1 point\(s\), first at point 2: the packing fraction would "
                                          r"reach or pass pi/\(3 sqrt 2\) = 0.7405"):
        update(A, phi, L, 0.5, params=dense, out=in_place(A, phi, dense))
    assert np.array_equal(A[2], kept_A[2]) and phi[2] == kept_phi[2]  # the refused point: as it was
    assert not np.array_equal(A[0], kept_A[0]) and phi[0] != kept_phi[0]  # the others: stepped
    # a fabric without recovery (a1 = a2 = b2 = 0) near its bound, compressed along it, leaves Eq. 8's bounds
    with pytest.raises(SolverError, match=r"first at point 0: the fabric would leave the bounds of Eq. 8"):
        update(np.diag([0.6, -0.3, -0.3])[None], [0.6], np.diag([-1.0, 0.5, 0.5]), 0.05,
               params=model.PAPER.replace(a1=0.0, a2=0.0, b2=0.0))


@pytest.mark.parametrize("seed", range(3))
def test_the_closed_form_bound_of_the_fabric_agrees_with_its_eigenvalues(seed):
    rng = np.random.default_rng(seed)
    for _ in range(2000):
        B = rng.normal(size=(3, 3)) * rng.uniform(0.05, 0.6)
        A = 0.5 * (B + B.T)
        A -= np.trace(A) / 3 * np.eye(3)
        eig = np.linalg.eigvalsh(A)
        inside = eig.min() >= -1 / 3 and eig.max() <= 2 / 3
        assert fabric_within_bounds(A[0, 0], A[1, 1], A[0, 1], A[0, 2], A[1, 2], 0.0) == inside


def test_numpy_scalars_are_numbers_and_outputs_that_overlap_are_refused():
    """numpy's integers and floats pass where Python's do; an output array that shares memory with another output,
    or with an input other than its own in place, is refused before any point is touched (it would return wrong
    numbers without a word); out.A and out.phi may still be A and phi themselves."""
    base = update(**GOOD)
    assert update(**GOOD, threads=np.int64(1), rtol=np.float32(1e-6)).A.shape == (2, 3, 3)
    out = Update.empty(2)
    out.S = out.phi
    with pytest.raises(SolverError, match="out.phi and out.S share memory"):
        update(**GOOD, out=out)
    block = np.zeros((3, 3, 3))
    A, out = block[:2], Update.empty(2)
    out.A = block[1:]
    with pytest.raises(SolverError, match="out.A overlaps the input A without being it"):
        update(**{**GOOD, "A": A}, out=out)
    A, phi = np.zeros((2, 3, 3)), np.array([0.6, 0.6])
    out = Update.empty(2)
    out.A, out.phi = A, phi
    in_place = update(A, phi, GOOD["L"], GOOD["dt"], out=out)
    assert in_place.A is A and np.array_equal(A, base.A) and np.array_equal(phi, base.phi)


def test_the_documented_layer_example_runs_and_each_point_follows_its_own_history():
    code = re.search(r"## In a continuum code.*?```python\n(.*?)```", DOCS.read_text(), re.S).group(1)
    names = {}
    exec(compile(code, str(DOCS), "exec"), names)
    state, turn_at, shear_rate = names["state"], names["turn_at"], names["shear_rate"]
    for i in (0, 499, 999):
        turn = np.ceil(turn_at[i] / 0.005 - 1e-9) * 0.005  # the first step at or after the turn
        history = History((Segment(turn / shear_rate, names["L_before"]),
                           Segment((1.0 - turn) / shear_rate, names["L_after"])), shear_rate)
        reference = integrate(history, packing_fraction0=0.60, times=[1.0])
        assert np.max(np.abs(state.A[i] - reference.A[-1])) < 1e-6
        assert abs(state.phi[i] - reference.packing_fraction[-1]) < 1e-6
    assert names["tau13"].shape == (1000,) and np.all(np.isfinite(names["tau13"]))
    assert isinstance(model.update, type(update))


@pytest.mark.slow  # times the update on 1 and more threads
def test_bench_reports_errors_rates_and_thread_scaling(tmp_path):
    import json

    from pipeline.studies import bench_update

    assert bench_update.main(["--out", str(tmp_path), "--points", "300"]) == 0
    data = json.loads((tmp_path / "update.json").read_text())
    rows = {row["rtol"]: row for row in data["work_precision"]}
    assert rows[bench_update.DEFAULT_RTOL]["error"] < 1e-6
    assert rows[1e-10]["error"] < rows[1e-4]["error"]
    assert all(row["per_second"] > 0 and row["substeps"] >= 1 for row in rows.values())
    assert [row["threads"] for row in data["threads"]] == list(range(1, len(data["threads"]) + 1))
    assert "| threads | updates/s |" in (tmp_path / "update.md").read_text()


@pytest.mark.parametrize("points", ["0", "999999999"])
def test_bench_refuses_no_points_and_more_than_memory_holds(tmp_path, capsys, points):
    from pipeline.studies import bench_update

    with pytest.raises(SystemExit):
        bench_update.main(["--out", str(tmp_path), "--points", points])
    assert f"--points={points} must lie in 1..2000000" in capsys.readouterr().err
