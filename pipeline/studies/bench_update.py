"""Speed and accuracy of the material-point update, ``model.update`` (part of ``make bench``).

- Accuracy: one point stepped through whole periodic cycles (theta = 90 and 180 deg) at 0.005 strain
  per update, against ``model.predict`` at rtol 1e-12: the worst error in A, Phi and tau/p.
- Speed: point-updates per second for N points (default 1e5) whose phases are spread over the
  theta = 90 deg cycle (so reversal-adjacent steps come in their true share), 0.005 strain per update,
  each on its own velocity gradient; the best of repeated runs of ``STEPS`` updates.
- Work-precision: both for several tolerances; threads: the default tolerance on 1..cores threads (at most
  numba's thread count); each fabric-law variant (``VARIANT_PARAMS``) on one thread on its own cycle's points (each
  in its own state there: ``model.update_inputs``), with its error over that cycle; and
  the same points advanced by ``model.integrate`` one at a time, all measured side by side.

Writes results/bench/update.json and update.md.
"""

from __future__ import annotations

import os
import platform
import time
from pathlib import Path

import numba
import numpy as np

from model import (
    PAPER,
    History,
    Params,
    Segment,
    Update,
    integrate,
    laws,
    periodic_cycle,
    predict,
    update,
    update_inputs,
)
from model.material_point import DEFAULT_RTOL

from ..cli import Parser
from ..io import write_table

STRAIN_STEP = 0.005
STEPS = 10  # updates per timed run
RTOLS = (1e-4, 1e-6, DEFAULT_RTOL, 1e-10)
ACCURACY_ANGLES = (90.0, 180.0)
SPEED_ANGLE = 90.0
#: each variant timed beside Eq. 13, at parameters where its added terms act (about the paper cell's fits)
VARIANT_PARAMS = tuple(Params(variant=law, **laws.declared(law, "SPEED_EXAMPLE")) for law in laws.LAWS)


def cycle_steps(theta: float, params: Params = PAPER):
    """The velocity gradient of each 0.005-strain step of one period, and the predicted cycle."""
    history = periodic_cycle(theta)
    n = int(round(history.duration / STRAIN_STEP))
    segments = history.segment_index((np.arange(n) + 0.5) * STRAIN_STEP)
    L = np.array([history.segments[i].L for i in segments])
    cycle = predict(theta, params=params, times=np.arange(n + 1) * STRAIN_STEP, rtol=1e-12, atol=1e-14)
    return L, cycle


def worst_error(rtol: float, params: Params = PAPER, angles=ACCURACY_ANGLES) -> float:
    """Max |error| in A, Phi, the law's own state and tau/p over whole cycles stepped at 0.005 strain (worst angle);
    tau/p where the step's D' is the one the prediction's output carries (all but a segment's last step)."""
    worst = 0.0
    for theta in angles:
        L, cycle = cycle_steps(theta, params)
        states, packing, owns = update_inputs(cycle, params)
        A, phi, own = states[:1], packing[:1], owns[:1]
        for k, Lk in enumerate(L):
            step = update(A, phi, Lk, STRAIN_STEP, params=params, law_state=own, rtol=rtol, atol=rtol * 1e-2)
            A, phi, own = step.A, step.phi, step.law_state
            worst = max(worst, float(np.max(np.abs(A[0] - states[k + 1]))), abs(float(phi[0] - packing[k + 1])),
                        float(np.max(np.abs(own[0] - owns[k + 1]), initial=0.0)))
            if k + 1 < len(L) and np.array_equal(L[k + 1], Lk):
                worst = max(worst, float(np.max(np.abs(step.tau_over_p[0] - cycle.tau[k + 1]))))
    return worst


#: the most points per update the benchmark makes (states, gradients and outputs of every variant: about 2 kB each)
MAX_POINTS = 2_000_000


def spread_points(n: int, params: Params = PAPER):
    """n points at phases spread over the theta = 90 deg cycle: their states (A, phi, the law's own, as
    ``model.update`` takes them), each step's L and each point's phase."""
    L, cycle = cycle_steps(SPEED_ANGLE, params)
    phase = np.arange(n) % len(L)
    A, phi, own = update_inputs(cycle, params)
    return A[phase], phi[phase], own[phase], L, phase


def updates_per_second(n: int, rtol: float, threads: int, repeats: int = 3,
                       params: Params = PAPER) -> tuple[float, float]:
    """(point-updates per second, mean substeps) for ``STEPS`` updates of n spread points; best of repeats."""
    A0, phi0, own, L, phase = spread_points(n, params)
    gradients = [np.ascontiguousarray(L[(phase + k) % len(L)]) for k in range(STEPS)]
    state = Update.empty(n, params)
    best, substeps = np.inf, 0.0
    for _ in range(repeats):
        state.A[:], state.phi[:], state.law_state[:] = A0, phi0, own
        start = time.perf_counter()
        total = 0
        for Lk in gradients:
            update(state.A, state.phi, Lk, STRAIN_STEP, params=params, out=state, law_state=state.law_state,
                   rtol=rtol, atol=rtol * 1e-2, threads=threads)
            total += int(state.substeps.sum())
        best = min(best, time.perf_counter() - start)
        substeps = total / (n * STEPS)
    return n * STEPS / best, substeps


def integrate_per_second(n: int) -> float:
    """Point-updates per second when each point's step is a ``model.integrate`` call of its own."""
    A0, phi0, _, L, phase = spread_points(n)
    start = time.perf_counter()
    for i in range(n):
        history = History((Segment(STRAIN_STEP, L[phase[i]]),))
        integrate(history, A0=A0[i], packing_fraction0=phi0[i], times=[STRAIN_STEP])
    return n / (time.perf_counter() - start)


def markdown(data: dict) -> str:
    lines = [f"# Material-point update ({data['machine']}, N = {data['points']:,} points, "
             f"{STRAIN_STEP} strain per update)", "",
             "Error: max |A, Phi, tau/p - model.predict| over whole cycles (theta 90 and 180 deg) at 0.005 strain "
             "per update. Rate: point-updates per second on one thread, phases spread over the theta = 90 deg cycle.",
             "", "| rtol (atol = rtol/100) | max error | updates/s, 1 thread | substeps per update |",
             "|---|---|---|---|"]
    lines += [f"| {r['rtol']:g}{' (default)' if r['rtol'] == DEFAULT_RTOL else ''} | {r['error']:.2g} | "
              f"{r['per_second']:.3g} | {r['substeps']:.3f} |" for r in data["work_precision"]]
    lines += ["", "| threads | updates/s | speed-up |", "|---|---|---|"]
    base = data["threads"][0]["per_second"]
    lines += [f"| {r['threads']} | {r['per_second']:.3g} | {r['per_second'] / base:.2f}x |" for r in data["threads"]]
    lines += ["", "| fabric law | updates/s, 1 thread | against Eq. 13 | substeps per update | max error, theta = 90 |",
              "|---|---|---|---|---|"]
    first = data["variants"][0]["per_second"]
    lines += [f"| {r['variant']} | {r['per_second']:.3g} | {r['per_second'] / first:.2f}x | {r['substeps']:.3f} | "
              f"{r['error']:.2g} |" for r in data["variants"]]
    lines += ["", f"`model.integrate` one point at a time: {data['integrate_per_second']:.3g} updates/s; "
              f"`model.update` (default rtol, 1 thread) is {base / data['integrate_per_second']:.0f}x that.", ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = Parser(prog="python -m pipeline.studies.bench_update", description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("results/bench"), help="output folder")
    parser.add_argument("--points", type=int, default=100_000, help="points per update (default 1e5)")
    args = parser.parse_args(argv)
    if not 1 <= args.points <= MAX_POINTS:
        parser.error(f"--points={args.points} must lie in 1..{MAX_POINTS} (each point holds about 2 kB here)")
    args.out.mkdir(parents=True, exist_ok=True)
    cores = min(os.cpu_count() or 1, numba.config.NUMBA_NUM_THREADS)
    A, phi, _, L, _ = spread_points(4)
    for threads in range(1, cores + 1):
        for params in VARIANT_PARAMS:
            update(A, phi, L[:4], STRAIN_STEP, params=params, threads=threads)  # compile / load before timing
    rows = []
    for rtol in RTOLS:
        print(f"update: rtol {rtol:g} ...", flush=True)
        rate, substeps = updates_per_second(args.points, rtol, 1)
        rows.append(dict(rtol=rtol, error=worst_error(rtol), per_second=rate, substeps=substeps))
    threads = [dict(threads=t, per_second=updates_per_second(args.points, DEFAULT_RTOL, t)[0])
               for t in range(1, cores + 1)]
    variants = []
    for params in VARIANT_PARAMS:
        rate, substeps = updates_per_second(args.points, DEFAULT_RTOL, 1, params=params)
        variants.append(dict(variant=params.variant, params=params.to_dict(), per_second=rate, substeps=substeps,
                             error=worst_error(DEFAULT_RTOL, params, (SPEED_ANGLE,))))
    data = dict(machine=f"{platform.processor() or platform.machine()}, {cores} cores", points=args.points,
                strain_step=STRAIN_STEP, work_precision=rows, threads=threads, variants=variants,
                integrate_per_second=integrate_per_second(min(args.points, 2000)))
    path = write_table(args.out, "update", data, markdown(data))
    print(path.read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
