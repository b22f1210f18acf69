"""The rank plot's statistics without ArviZ: fractional ranks, their Δ-ECDF per chain, and ArviZ's
multi-chain uniformity test ("mtc_c": pointwise hypergeometric mid-p tests combined by the Cauchy
combination, with Shapley contributions marking the ranks that drive a deviation; Säilynoja,
Bürkner & Vehtari). Importing ArviZ's plotting for this one figure cost the report 1-2 s (xarray,
pandas, scipy.stats); these are the same formulas in numpy (arviz_stats 1.x ``_mtc_c``,
``_compute_ranks``, ``_ecdf``), checked against ArviZ in tests/report/test_rank.py.
"""

from __future__ import annotations

import numpy as np

ENVELOPE_PROB = 0.99          # ArviZ's default stats.envelope_prob: α = 0.01


def fractional_ranks(x: np.ndarray) -> np.ndarray:
    """Ranks 1..N over all chains and draws (ties broken by position), divided by N."""
    flat = np.asarray(x, dtype=float).ravel()
    ranks = np.empty(flat.size)
    ranks[np.argsort(flat, axis=None)] = np.arange(1, flat.size + 1)
    return (ranks / flat.size).reshape(np.shape(x))


def delta_ecdf(ranks: np.ndarray, npoints: int) -> tuple[np.ndarray, np.ndarray]:
    """(points, ECDF - uniform) of each chain's fractional ranks at ``npoints`` points of [0, 1]."""
    points = np.linspace(0.0, 1.0, npoints)
    out = np.empty((ranks.shape[0], npoints))
    for j, r in enumerate(ranks):
        r = np.sort(r[np.isfinite(r)])
        out[j] = np.searchsorted(r, points, side="right") / r.size - points
    return points, out


def _shapley_mean(values: np.ndarray) -> np.ndarray:
    n = values.size
    if n <= 1:
        return np.zeros(n)
    harmonic = np.sum(1.0 / np.arange(1, n + 1))
    mean_others = (values.sum() - values) / (n - 1)
    return values / n + (harmonic - 1.0) / n * (values - mean_others)


def _hypergeom_pmf_cdf(x: np.ndarray, total: int, good: int, drawn: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """pmf and cdf at x[i, j] of Hypergeom(total, good, drawn[i]): drawn[i] items from ``total``,
    ``good`` of them marked, x marked ones among the drawn (log factorials, summed in order)."""
    lf = np.concatenate(([0.0], np.cumsum(np.log(np.arange(1, total + 1)))))

    def lchoose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        ok = (b >= 0) & (b <= a)
        out = np.full(np.broadcast(a, b).shape, -np.inf)
        a_, b_ = np.broadcast_to(a, out.shape)[ok], np.broadcast_to(b, out.shape)[ok]
        out[ok] = lf[a_] - lf[b_] - lf[a_ - b_]
        return out

    support = np.arange(good + 1)
    k = drawn[:, None]
    logp = lchoose(np.int64(good), support[None, :]) + lchoose(np.int64(total - good), k - support)
    logp = logp - lchoose(np.int64(total), drawn)[:, None]
    pmf_all = np.exp(logp)
    cdf_all = np.cumsum(pmf_all, axis=1)
    rows = np.arange(drawn.size)[:, None]
    xi = np.clip(x, 0, good)
    return pmf_all[rows, xi], np.minimum(cdf_all[rows, xi], 1.0)


def mchain_uniformity_test(ranks: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """ArviZ's multi-chain uniformity test of fractional ranks (chains, draws): the global p-value,
    the between-chain Shapley contributions (draws, chains) and the draw-wise ones (draws,)."""
    ranks = np.asarray(ranks, dtype=float)
    n_chains, n_draws = ranks.shape
    z = np.arange(1, n_draws + 1) / (n_draws + 1)
    total = n_chains * n_draws
    k = np.floor(z * total).astype(np.int64)
    ordered = np.sort(ranks, axis=1)
    ecdfs = np.stack([np.searchsorted(ordered[j], z, side="right") for j in range(n_chains)],
                     axis=1)
    pmf, cdf = _hypergeom_pmf_cdf(ecdfs, total, n_draws, k)
    lower = cdf - 0.5 * pmf                     # mid-p
    gamma = 2.0 * np.minimum(lower, 1.0 - lower)
    b_cauchy = np.tan((0.5 - gamma) * np.pi)
    ps = 0.5 - np.arctan(b_cauchy.mean(axis=1)) / np.pi
    w_cauchy = np.tan((0.5 - ps) * np.pi)
    p_value = float(0.5 - np.arctan(w_cauchy.mean()) / np.pi)
    b_shapley = np.apply_along_axis(_shapley_mean, 1, b_cauchy)
    return p_value, b_shapley, _shapley_mean(w_cauchy)


def suspicious(p_value: float, b_shapley: np.ndarray, w_shapley: np.ndarray,
               prob: float = ENVELOPE_PROB) -> np.ndarray:
    """(draws, chains) mask of the points ArviZ marks: both contributions positive and p < α."""
    return (b_shapley > 0) & (w_shapley[:, None] > 0) & (p_value < 1.0 - prob)
