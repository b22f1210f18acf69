"""Simulation-based calibration (Talts et al. 2018): ranks of the truth among posterior draws and
the graphical uniformity test of their ECDF with simultaneous bands (Säilynoja, Bürkner and
Vehtari 2022).

If the data are simulated from the prior and the model, and the sampler draws from the exact
posterior, the rank of the true value among L (nearly independent) posterior draws is uniform on
{0, …, L}. Ranks are turned into continuous PIT values u = (rank + U)/(L + 1), U ~ Uniform(0, 1):
exactly Uniform(0, 1) under calibration, whatever L is (so runs of different lengths mix).

The band: for N PIT values, evaluation points z_i = i/K, the pointwise binomial band of level 1-γ
at each z_i, with γ chosen by simulation so that a uniform sample's ECDF leaves the band anywhere
with probability α (1 - α = 0.95: a *simultaneous* band).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import binom


def thin_draws(draws: np.ndarray, tau: float) -> np.ndarray:
    """Draws (steps, walkers) thinned by ceil(τ) steps (τ in steps), flattened."""
    step = max(1, math.ceil(tau))
    return np.asarray(draws)[::step].ravel()


def rank_of(truth: float, draws: np.ndarray) -> tuple[int, int]:
    """(rank, L): the number of draws below the truth, and the number of draws."""
    d = np.asarray(draws, dtype=float).ravel()
    return int(np.sum(d < truth)), int(d.size)


def pit_from_ranks(ranks: np.ndarray, n_draws: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """u = (rank + U) / (L + 1): continuous PIT values, Uniform(0, 1) under calibration."""
    r = np.asarray(ranks, float)
    L = np.asarray(n_draws, float)
    return (r + rng.uniform(size=r.shape)) / (L + 1.0)


def ecdf(u: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Empirical CDF of ``u`` at ``z``."""
    return np.searchsorted(np.sort(u), z, side="right") / len(u)


def simultaneous_band(n: int, prob: float = 0.95, k: int | None = None, sims: int = 2000,
                      rng: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray,
                                                                         np.ndarray, float]:
    """(z, lower, upper, γ): the simultaneous ``prob`` band of the ECDF of n Uniform(0,1) values at
    z_i = i/k, i = 1..k-1 (k = n by default), by the simulation method of Säilynoja et al. (2022)."""
    rng = rng if rng is not None else np.random.default_rng(20220101)
    k = n if k is None else k
    z = np.arange(1, k) / k
    gammas = np.empty(sims)
    chunk = max(1, 2_000_000 // max(n, 1))
    for a in range(0, sims, chunk):
        u = np.sort(rng.uniform(size=(min(chunk, sims - a), n)), axis=1)
        counts = np.stack([np.searchsorted(row, z, side="right") for row in u])
        tails = np.minimum(binom.cdf(counts, n, z), binom.sf(counts - 1, n, z))
        gammas[a:a + len(u)] = 2.0 * tails.min(axis=1)
    gamma = float(np.quantile(gammas, 1.0 - prob))
    lower = binom.ppf(gamma / 2.0, n, z) / n
    upper = binom.ppf(1.0 - gamma / 2.0, n, z) / n
    return z, lower, upper, gamma


def inside_band(u: np.ndarray, z: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> bool:
    """True when the ECDF of ``u`` stays within [lower, upper] at every evaluation point."""
    f = ecdf(u, z)
    return bool(np.all((f >= lower - 1e-12) & (f <= upper + 1e-12)))
