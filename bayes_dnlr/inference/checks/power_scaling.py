"""Power-scaling sensitivity of a posterior to its prior (Kallioinen, Paananen, Bürkner & Vehtari 2024,
"Detecting and diagnosing prior and likelihood sensitivity with power-scaling", Stat. Comput. 34:57).

The prior is raised to a power α near 1, p_α(θ | y) ∝ p(θ)^α p(y | θ), and the change of each
parameter's posterior is measured by the cumulative Jensen-Shannon distance between the base and the
power-scaled posterior, estimated from the existing draws by Pareto-smoothed importance sampling
(weights ∝ p(θ)^(α-1)); the sensitivity is its derivative in log2 α (finite differences at α = 0.99
and 1.01). Above 0.05 the prior is informative for that parameter.

The same estimators as ``arviz_stats.psense`` (tests compare the two to 1e-10): arviz_stats costs
3-4 s to import with arviz_base and xarray, more than ``sample`` takes on a typical curve, for a few
array operations.
"""

from __future__ import annotations

import math

import numpy as np

from bayes_dnlr.inference.mcmc.ess import ess_tail

ALPHAS = (0.99, 1.01)
SENSITIVE = 0.05          # Kallioinen et al.: above this the prior is informative


def _logsumexp(x: np.ndarray) -> float:
    m = float(np.max(x))
    return m + math.log(float(np.sum(np.exp(x - m))))


def _gpdfit(x: np.ndarray) -> tuple[float, float]:
    """Shape k and scale σ of a generalized Pareto distribution fitted to sorted exceedances x
    (Zhang & Stephens 2009, with the weakly informative prior on k of Vehtari et al. 2024)."""
    prior_bs, prior_k = 3, 10
    n = x.size
    m_est = 30 + int(n**0.5)
    xstar = x[int((n / 4 + 0.5) - 1)]
    if xstar <= x[0]:
        return math.nan, math.nan
    b = 1 - np.sqrt(m_est / (np.arange(1, m_est + 1, dtype=float) - 0.5))
    b /= prior_bs * xstar
    b += 1 / x[-1]
    k_ary = np.mean(np.log1p(-b[:, None] * x), axis=1)
    len_scale = n * (np.log(-b / k_ary) - k_ary - 1)
    w = np.exp(len_scale - _logsumexp(len_scale))
    keep = w >= 10 * np.finfo(float).eps
    w, b = w[keep], b[keep]
    w /= w.sum()
    b_post = float(np.sum(b * w))
    kappa = float(np.mean(np.log1p(-b_post * x)))
    sigma = -kappa / b_post
    kappa = (n * kappa + prior_k * 0.5) / (n + prior_k)
    return (math.inf, math.nan) if math.isnan(kappa) else (kappa, sigma)


def _gpinv(p: np.ndarray, kappa: float, sigma: float, mu: float) -> np.ndarray:
    if sigma <= 0:
        return np.full_like(p, np.nan)
    if kappa == 0:
        return mu - sigma * np.log1p(-p)
    return mu + sigma * np.expm1(-kappa * np.log1p(-p)) / kappa


def _tail_draws(n: int, r_eff: float) -> int:
    m = math.floor(3 * (n / r_eff) ** 0.5) if n * r_eff > 225 else math.floor(n / 5)
    return int(min(max(m, 5), n // 2))


def smoothed_log_weights(log_component: np.ndarray, alpha: float) -> np.ndarray:
    """Normalised Pareto-smoothed log weights of the draws for power-scaling a log density
    component (flat (n,) array of its values at the draws) by ``alpha``."""
    lc = np.ravel(np.asarray(log_component, dtype=float))
    lw = (alpha - 1.0) * lc
    n = lw.size
    r_eff = ess_tail(lc[None, :], 0.05) / n
    m = _tail_draws(n, r_eff)
    lw = lw - np.max(lw)
    order = np.argsort(lw)
    tail = order[n - m:]
    draws_tail = lw[tail]
    cutoff = lw[order[n - m - 1]]
    if abs(float(draws_tail.max() - draws_tail.min())) >= np.finfo(float).tiny:
        exp_tail, exp_cut = np.exp(draws_tail), math.exp(cutoff)
        kappa, sigma = _gpdfit(exp_tail - exp_cut)
        if math.isfinite(kappa):
            smoothed = _gpinv(np.arange(0.5, m) / m, kappa, sigma, exp_cut)
            smoothed = np.log(smoothed)
            smoothed[smoothed > draws_tail.max()] = draws_tail.max()
            lw = lw.copy()
            lw[tail] = smoothed
    return lw - _logsumexp(lw)


def cjs_distance(x: np.ndarray, weights: np.ndarray) -> float:
    """Cumulative Jensen-Shannon distance between the draws x and the same draws weighted."""
    order = np.argsort(x)
    x, w = x[order], weights[order]
    width = np.diff(x)
    p = np.linspace(1 / x.size, 1 - 1 / x.size, x.size - 1)
    q = np.cumsum(w / np.sum(w))[:-1]
    p_int, q_int = float(np.dot(p, width)), float(np.dot(q, width))
    log_p = np.log2(p, out=np.zeros_like(p), where=p != 0)
    log_q = np.log2(q, out=np.zeros_like(q), where=q != 0)
    mid = 0.5 * (p + q)
    log_mid = np.log2(mid, out=np.zeros_like(mid), where=mid != 0)
    pq = max(0.0, float(np.sum(width * (p * (log_p - log_mid)))) + 0.5 / math.log(2) * (q_int - p_int))
    qp = max(0.0, float(np.sum(width * (q * (log_q - log_mid)))) + 0.5 / math.log(2) * (p_int - q_int))
    return math.sqrt((pq + qp) / (p_int + q_int))


def sensitivity(draws: dict[str, np.ndarray], log_component: np.ndarray,
                alphas: tuple[float, float] = ALPHAS) -> dict[str, float]:
    """Power-scaling sensitivity of each parameter (draws: name -> any shape, flattened in the order
    of ``log_component``) to the component whose log density at the draws is ``log_component``."""
    lower = np.exp(smoothed_log_weights(log_component, alphas[0]))
    upper = np.exp(smoothed_log_weights(log_component, alphas[1]))
    out = {}
    for name, x in draws.items():
        x = np.ravel(np.asarray(x, dtype=float))
        lo = max(cjs_distance(x, lower), cjs_distance(-x, lower))
        hi = max(cjs_distance(x, upper), cjs_distance(-x, upper))
        out[name] = float((-lo / math.log2(alphas[0]) + hi / math.log2(alphas[1])) / 2)
    return out
