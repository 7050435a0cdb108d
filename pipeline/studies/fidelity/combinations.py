"""The parameter combinations a reversal fixes, from the seeds' scatter of their single-run fits.

Over the seeds of the reference setting, the fitted parameters of one sign (all seeds agree on it) that
the seeds move (not held) are taken as x_k = ln|θ_k|; the eigen-directions v of their covariance are
products ∏|θ_k|^v_k, the smallest eigenvalues the combinations one run pins best (a relative scatter of
sqrt(λ) per run), the largest the directions it leaves loose. A sample eigenvalue picked as the smallest
is biased low, so each direction's scatter per run is measured out of sample: every seed is projected
on the direction found without it (leave one out). Comparing these products with Table 2's says whether
our distance to the paper lies along what the DEM determines (physics or pipeline) or along what it
leaves loose (the fit's valley).
"""

from __future__ import annotations

import numpy as np

import model

MIN_SEEDS = 5


def _fits(summaries: list[dict], names: list[str]) -> np.ndarray:
    return np.array([[s["fit"]["values"][n] for n in names] for s in summaries])


def _directions(logs: np.ndarray) -> np.ndarray:
    """Unit eigen-directions of the covariance of ``logs`` (rows: runs), columns sorted by eigenvalue."""
    _, vectors = np.linalg.eigh(np.cov(logs.T))
    return vectors


def find(seeds: list[dict], candidates: tuple[str, ...]) -> dict:
    """The combinations of the ``candidates`` over the ``seeds`` (reference runs with a fit), best
    determined first: direction, its scatter per run out of sample, the seeds' mean, Table 2's value.
    Empty with fewer than ``MIN_SEEDS`` seeds or two such parameters."""
    seeds = [s for s in seeds if (s.get("fit") or {}).get("values")]
    names = [n for n in candidates if all(n in s["fit"]["values"] for s in seeds)]
    if len(seeds) < MIN_SEEDS or not names:
        return {}
    values = _fits(seeds, names)
    keep = [k for k in range(len(names))  # of one sign, and moved by the seeds (a held parameter is not)
            if (np.all(values[:, k] > 0) or np.all(values[:, k] < 0)) and np.ptp(values[:, k]) > 0]
    if len(keep) < 2:
        return {}
    names = [names[k] for k in keep]
    logs = np.log(np.abs(values[:, keep]))
    full = _directions(logs)
    out_of_sample = np.zeros((len(seeds), len(names)))
    for i in range(len(seeds)):
        rest = np.delete(logs, i, axis=0)
        vectors = _directions(rest)
        for k in range(len(names)):  # the held-out direction nearest the full one, signed alike
            j = int(np.argmax(np.abs(vectors.T @ full[:, k])))
            v = vectors[:, j] * np.sign(vectors[:, j] @ full[:, k])
            out_of_sample[i, k] = (logs[i] - rest.mean(axis=0)) @ v
    scale = np.sqrt((len(seeds) - 1) / len(seeds))  # a held-out point scatters by sd * sqrt(1 + 1/(n-1))
    paper = np.log(np.abs([getattr(model.PAPER, n) for n in names]))
    combos = []
    for k in np.argsort(np.sqrt(np.mean(out_of_sample**2, axis=0))):
        v = full[:, k] * np.sign(full[np.argmax(np.abs(full[:, k])), k])
        sd = float(np.sqrt(np.mean(out_of_sample[:, k] ** 2)) * scale)
        mean = float(logs.mean(axis=0) @ v)
        combos.append({"direction": dict(zip(names, v.tolist(), strict=True)), "sd_per_run": sd,
                       "in_sample_sd": float(np.std(logs @ v, ddof=1)), "mean": mean,
                       "standard_error": sd / np.sqrt(len(seeds)), "table2": float(paper @ v)})
    return {"names": names, "seeds": len(seeds), "combinations": combos}


def value(summary: dict, combo: dict) -> float | None:
    """ln of the product ∏|θ_k|^v_k for one run's fit (None without a fit of every factor)."""
    fit = (summary.get("fit") or {}).get("values") or {}
    if not all(fit.get(n) for n in combo["direction"]):
        return None
    return float(sum(c * np.log(abs(fit[n])) for n, c in combo["direction"].items()))
