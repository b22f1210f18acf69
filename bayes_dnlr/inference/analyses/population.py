"""Specimens as a population: E_k ~ Normal(μ, s) from each specimen's own posterior (two stages).

Stage 1 is each specimen's ordinary run: draws x_k,i of its modulus under its prior π_k. Stage 2
reweights them under the population model (Hogg, Myers & Bovy 2010; the hyper-likelihood of
bilby): the likelihood of (μ, s) is

    L(μ, s) = Π_k (1/N_k) Σ_i N(x_k,i | μ, s) / π_k(x_k,i),

a Monte Carlo estimate of Π_k ∫ p(data_k | E) N(E | μ, s) dE up to constants. It is evaluated on a
grid over (μ, s) (two parameters: a grid is exact to its resolution and fast), with flat μ and a
half-normal prior on s. Each specimen's estimate "shrunk" to the population comes from its own
draws reweighted by E[N(x | μ, s)] / π(x) over the posterior of (μ, s).

Monte Carlo check: for each specimen, the effective number of draws behind L,
(Σ w)² / Σ w², at the posterior mean of (μ, s). Few effective draws (< 50) mean the weights rest on a
handful of draws: the population is then narrower than one specimen's posterior, and more (or
longer) stage-1 draws are needed. Also the Monte Carlo variance of ln L̂ there,
Σ_k Var(w_k) / (N_k mean(w_k)²) (the delta method on each specimen's mean; Talbot & Golomb 2023 ask
for less than 1): above 1, the grid posterior of (μ, s) moves with the draws used.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import njit, prange

from bayes_dnlr.inference.analyses import heterogeneity
from bayes_dnlr.model import threads

MIN_EFFECTIVE = 50.0
MAX_LOG_L_VARIANCE = 1.0
SPREAD_ZERO = 0.02          # an HDI of s that starts below this share of its upper end starts at 0
N_MU, N_S = 120, 100
MAX_DRAWS = 1000        # per specimen for the grid (thinned at random): an MCMC run's worth of ESS
N_HYPER_DRAWS = 400     # (mu, s) draws from the grid posterior for the shrunk estimates
ZOOM_CELLS = 40         # a posterior over fewer cells of mu or s than this gets a second, finer grid
ZOOM_FLOOR = 1e-6       # ... over the cells above this fraction of its peak


@dataclass
class Population:
    names: list[str]
    mu: dict[str, Any]                 # mean, sd, median, hdi_90
    s: dict[str, Any]
    specimens: dict[str, dict[str, Any]]   # own (mean, sd) and shrunk (mean, sd, hdi_90)
    effective_draws: dict[str, float]  # at the posterior mean of (mu, s)
    log_l_variance: float              # Monte Carlo variance of ln L at the posterior mean of (mu, s)
    grid: dict[str, np.ndarray]        # mu, s, posterior (N_MU, N_S): the density at the points
    parameter: str = "E"
    s_prior_scale: float = 0.0
    warnings: list[str] = field(default_factory=list)
    heterogeneity: dict[str, Any] = field(default_factory=dict)   # analyses/heterogeneity.py

    @property
    def spread_resolved(self) -> bool:
        """Whether the data tell the specimens apart: the 90 % HDI of s starts above zero (at less
        than 2 % of its upper end it starts at zero: s is consistent with no spread at all)."""
        lo, hi = self.s["hdi_90"]
        return lo > SPREAD_ZERO * hi

    @property
    def passed(self) -> bool:
        """The Monte Carlo check: every specimen keeps enough effective draws and ln L is stable."""
        return (min(self.effective_draws.values()) >= MIN_EFFECTIVE
                and self.log_l_variance <= MAX_LOG_L_VARIANCE)

    def to_dict(self) -> dict[str, Any]:
        return {"parameter": self.parameter, "specimens": self.names, "mu": self.mu, "s": self.s,
                "shrunk": self.specimens,
                "monte_carlo_check": {"effective_draws": self.effective_draws,
                                      "log_likelihood_variance": self.log_l_variance,
                                      "limits": {"effective_draws_min": MIN_EFFECTIVE,
                                                 "log_likelihood_variance_max": MAX_LOG_L_VARIANCE},
                                      "passed": self.passed},
                "s_resolved": self.spread_resolved,
                "s_prior": {"prior": "half-normal", "scale": self.s_prior_scale},
                "mu_prior": "flat over the grid", "method": "two-stage reweighting of each "
                "specimen's posterior draws (Hogg et al. 2010), grid over (mu, s)",
                "heterogeneity": self.heterogeneity, "warnings": self.warnings}

    @property
    def one_material(self) -> bool:
        """The heterogeneity check passed: the pooled value may be called the material's."""
        return bool(self.heterogeneity.get("passed"))


def _stats_from_grid(x: np.ndarray, p: np.ndarray, width: np.ndarray | None = None) -> dict[str, Any]:
    """Mean, sd, median and the 90 % HDI of a 1-D distribution given as masses ``p`` on the grid
    points ``x`` (cells of ``width``, for the HDI's ordering by density; None: equal cells)."""
    p = np.maximum(p, 0.0)
    w = p / p.sum()
    mean = float(w @ x)
    sd = float(math.sqrt(max(w @ (x - mean) ** 2, 0.0)))
    cdf = np.cumsum(w)
    median = float(np.interp(0.5, cdf, x))
    order = np.argsort(w if width is None else w / width)[::-1]
    keep = order[: int(np.searchsorted(np.cumsum(w[order]), 0.9) + 1)]
    return {"mean": mean, "sd": sd, "median": median, "hdi_90": [float(x[keep].min()), float(x[keep].max())]}


def _weighted_stats(x: np.ndarray, w: np.ndarray) -> dict[str, Any]:
    w = w / w.sum()
    order = np.argsort(x)
    cdf = np.cumsum(w[order])
    lo, hi = np.interp([0.05, 0.95], cdf, x[order])
    mean = float(w @ x)
    return {"mean": mean, "sd": float(math.sqrt(max(w @ (x - mean) ** 2, 0.0))),
            "interval_90": [float(lo), float(hi)]}


@njit(cache=True)
def _add_mu_row(i, x, logpi, mu_grid, s_grid, logL):
    """Row i of ``add_log_mean_weight``: every s at μ = mu_grid[i]."""
    n = x.size
    half_log_2pi = 0.5 * math.log(2.0 * math.pi)
    mu = mu_grid[i]
    v = np.empty(n)
    for j in range(s_grid.size):
        s = s_grid[j]
        c = -math.log(s) - half_log_2pi
        m = -np.inf
        for t in range(n):
            z = (x[t] - mu) / s
            v[t] = -0.5 * z * z + c - logpi[t]
            m = max(m, v[t])
        acc = 0.0
        for t in range(n):
            acc += math.exp(v[t] - m)
        logL[i, j] += m + math.log(acc / n)


@njit(cache=True, parallel=True)
def _add_rows_threads(x, logpi, mu_grid, s_grid, logL):
    for i in prange(mu_grid.size):
        _add_mu_row(i, x, logpi, mu_grid, s_grid, logL)


@njit(cache=True)
def _add_rows_serial(x, logpi, mu_grid, s_grid, logL):
    for i in range(mu_grid.size):
        _add_mu_row(i, x, logpi, mu_grid, s_grid, logL)


def add_log_mean_weight(x: np.ndarray, logpi: np.ndarray, mu_grid: np.ndarray, s_grid: np.ndarray,
                        logL: np.ndarray) -> None:
    """logL[i, j] += ln (1/N) Σ_n N(x_n | μ_i, s_j) / π(x_n): one specimen's factor of L(μ, s), by
    the log-sum-exp of its draws (compiled: no (N_MU, N) temporaries). Threads over μ where
    ``model.threads.parallel_allowed`` (not in a forked child, which numba would terminate); each
    row is computed on its own, so the values do not depend on it."""
    if threads.parallel_allowed():
        _add_rows_threads(x, logpi, mu_grid, s_grid, logL)
    else:
        _add_rows_serial(x, logpi, mu_grid, s_grid, logL)


def _grid_posterior(x: Mapping[str, np.ndarray], logpi: Mapping[str, np.ndarray], mu_grid: np.ndarray,
                    s_grid: np.ndarray, scale: float) -> np.ndarray:
    """The posterior of (μ, s) on the grid (normalized to sum 1): L(μ, s) above times the
    half-normal prior of s."""
    logL = np.zeros((mu_grid.size, s_grid.size))
    for k in x:
        add_log_mean_weight(np.ascontiguousarray(x[k], dtype=float),
                             np.ascontiguousarray(logpi[k], dtype=float), mu_grid, s_grid, logL)
    log_prior_s = -0.5 * (s_grid / scale) ** 2
    logpost = logL + log_prior_s[None, :]
    logpost[~np.isfinite(logpost)] = -np.inf
    post = np.exp(logpost - np.max(logpost))
    return post / post.sum()


def _zoom(mu_grid: np.ndarray, s_grid: np.ndarray, post: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """A finer grid over where the posterior is (cells above ZOOM_FLOOR of its peak, one cell more on
    each side), when that region spans fewer than ZOOM_CELLS cells of μ or of s: with a batch of
    many specimens, μ's sd falls below the first grid's step (200 specimens: sd 7 MPa, step 13 MPa).
    None when the first grid resolves the posterior already."""
    mu_idx = np.flatnonzero(post.max(axis=1) >= ZOOM_FLOOR * post.max())
    s_idx = np.flatnonzero(post.max(axis=0) >= ZOOM_FLOOR * post.max())
    if mu_idx.size >= ZOOM_CELLS and s_idx.size >= ZOOM_CELLS:
        return None
    m0, m1 = max(mu_idx[0] - 1, 0), min(mu_idx[-1] + 1, mu_grid.size - 1)
    j0, j1 = max(s_idx[0] - 1, 0), min(s_idx[-1] + 1, s_grid.size - 1)
    return (np.linspace(mu_grid[m0], mu_grid[m1], mu_grid.size),
            np.linspace(s_grid[j0], s_grid[j1], s_grid.size))


def population(draws: Mapping[str, np.ndarray], priors: Mapping[str, Any], parameter: str = "E",
               s_prior_scale: float | None = None,
               own: Mapping[str, Mapping[str, float]] | None = None, labelled: bool = False,
               check: Mapping[str, Any] | None = None) -> Population:
    """The population of ``draws`` (name -> a specimen's posterior draws of the parameter) with
    each specimen's prior (``inference.priors.Prior``, for the division by π_k). ``own``: each
    specimen's posterior mean and sd as its run reports them (summary.json), shown as its own
    estimate; else those of all its draws. ``check``: the heterogeneity check of the specimens
    (heterogeneity.one_material, made by the caller on the quantity it compares, E(t) at a common
    time); None: made here on the own estimates, with ``labelled`` (the specimens are labelled as
    one material) for its words."""
    names = list(draws)
    if len(names) < 2:
        raise ValueError("a population needs at least two specimens")
    rng = np.random.default_rng(0)
    x, logpi, own_of, full = {}, {}, {}, {}
    for k in names:
        v = full[k] = np.asarray(draws[k], dtype=float).ravel()
        given = (own or {}).get(k)
        own_of[k] = ({"mean": float(given["mean"]), "sd": float(given["sd"])} if given else
                     {"mean": float(v.mean()), "sd": float(v.std(ddof=1))})
        if v.size > MAX_DRAWS:
            v = v[rng.choice(v.size, MAX_DRAWS, replace=False)]
        x[k] = v
        logpi[k] = np.asarray(priors[k].logpdf(v), dtype=float)
    if check is None:
        check = heterogeneity.one_material(names, [own_of[k]["mean"] for k in names],
                                           [own_of[k]["sd"] for k in names], labelled=labelled,
                                           quantity=parameter)
    means = np.array([x[k].mean() for k in names])
    sds = np.array([x[k].std(ddof=1) for k in names])
    spread = float(means.std(ddof=1))
    width = spread + float(sds.mean())
    scale = float(s_prior_scale) if s_prior_scale else 2.5 * width
    mu_grid = np.linspace(means.min() - 4 * width, means.max() + 4 * width, N_MU)
    # s: dense near 0, out to well past the spread
    s_grid = np.linspace(0.0, 1.0, N_S + 1)[1:] ** 2 * (5.0 * width)
    post = _grid_posterior(x, logpi, mu_grid, s_grid, scale)
    zoom = _zoom(mu_grid, s_grid, post)
    if zoom is not None:            # many specimens: the posterior is narrower than a few cells
        mu_grid, s_grid = zoom
        post = _grid_posterior(x, logpi, mu_grid, s_grid, scale)
    ess_at = {}
    # masses: the density at each point times its cell (the first grid's s cells are not equal:
    # treating its points as equal masses would put a factor s^(-1/2) on the prior of s)
    ds = np.gradient(s_grid)
    mass = post * ds[None, :]
    mass /= mass.sum()
    mu_stats = _stats_from_grid(mu_grid, mass.sum(axis=1))
    s_stats = _stats_from_grid(s_grid, mass.sum(axis=0), ds)
    # Monte Carlo check at the posterior mean of (mu, s)
    mu_hat, s_hat = mu_stats["mean"], max(s_stats["mean"], s_grid[0])
    warnings = []
    var_log_l = 0.0
    for k in names:
        lw = -0.5 * ((x[k] - mu_hat) / s_hat) ** 2 - logpi[k]
        w = np.exp(lw - lw.max())
        ess_at[k] = float(w.sum() ** 2 / max((w * w).sum(), 1e-300))
        var_log_l += float(w.var() / (w.size * max(w.mean(), 1e-300) ** 2))
    if var_log_l > MAX_LOG_L_VARIANCE:
        warnings.append(f"Monte Carlo check: the variance of ln L at the population's posterior mean is "
                        f"{var_log_l:.3g} > {MAX_LOG_L_VARIANCE:g}: the (mu, s) posterior depends on which "
                        "stage-1 draws were used; sample the specimens longer")
    few = [k for k, e in ess_at.items() if e < MIN_EFFECTIVE]
    if few:
        warnings.append(f"Monte Carlo check: {', '.join(few)} keep fewer than {MIN_EFFECTIVE:.0f} effective "
                        "draws under the population (the population is narrower than their own "
                        "posterior): sample them longer (sampler.target_ess) for a stable answer")
    # shrunk estimates: reweight each specimen's draws by E_{mu,s}[N(x | mu, s)] / pi(x), the
    # expectation over (mu, s) drawn from the grid posterior. All its draws, not the grid's thinned
    # ones: the same draws as its own estimate, so that the two differ by the shrinkage only
    flat = rng.choice(mass.size, N_HYPER_DRAWS, p=mass.ravel())
    mus, ss = mu_grid[flat // N_S], s_grid[flat % N_S]
    specimens = {}
    for k in names:
        v = full[k]
        acc = np.zeros(v.size)
        for m_j, s_j in zip(mus, ss, strict=True):      # one hyper draw at a time: no (400, N) array
            acc += np.exp(-0.5 * ((v - m_j) / s_j) ** 2) / s_j
        log_prior = np.asarray(priors[k].logpdf(v), dtype=float)
        w = acc / N_HYPER_DRAWS * np.exp(-(log_prior - log_prior.max()))
        specimens[k] = {"own": own_of[k], "shrunk": _weighted_stats(v, w)}
    return Population(names, mu_stats, s_stats, specimens, ess_at, var_log_l,
                      {"mu": mu_grid, "s": s_grid, "posterior": post}, parameter, scale, warnings,
                      dict(check))
