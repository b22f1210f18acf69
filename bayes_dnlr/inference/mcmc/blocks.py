"""Independence moves for emcee, from the linearized posterior (eq. 32) or from the other walkers:

- ``LaplaceMove``, every parameter drawn afresh from a Student t around the start of the chain
  (fit.json's estimate and covariance), with the white likelihood;
- ``ConditionalMove``, the discrepancy's hyperparameters drawn from the other walkers and the model
  parameters from their conditional given them;
- ``ComplementMove``, every parameter from a Student t fitted to the other walkers, where no
  linearization can be trusted.

All are Metropolis-Hastings with the proposal densities' ratio, so where their proposal is poor
they are only less often accepted, never biased; the differential evolution beside them still
moves the walkers there. Where the linearization is known to be wrong (a parameter near a bound of
its prior, a sampled spectrum exponent) ``sample`` makes the complement move instead of the first
two (runs/sample.py, docs/sampling.md). All draw from emcee's ``RandomState`` only (the chain is
reproducible and resumes bit-exactly).

``LaplaceMove``: the least-squares posteriors of the DNLR model are close to their linearization
(the shipped examples' posterior sd agree with the Gauss-Newton sd within 5 %) but narrow and
correlated (ρ(E, tau_max) = -0.998), so differential evolution alone needs τ ≈ 8-14 steps; a
proposal θ' = θ̂ + L u', u' from a Student t (``LAPLACE_DOF`` degrees of freedom, L Lᵀ the
linearized covariance × ``LAPLACE_SCALE``²), is accepted in most cases and brings τ to 2-3
(docs/sampling.md). The ratio carries ln t(u) - ln t(u'), u = L⁻¹ (θ - θ̂).

The conditional move. With the model discrepancy the posterior of (ln amplitude, ln length) is a
narrow, skewed ridge with a heavy tail toward long lengths (the data fix about a²/ℓ, not a and ℓ
apart), and along it the spread of the model parameters changes: a long length lets the discrepancy
take over the slow trend of the hardening (on a synthetic test with an exp error, G's sd grew 5.5×
from the shortest tenth of the lengths to the longest 3 %). Differential evolution over all
parameters at once is mostly rejected there: the hyperparameters' τ was 45-48 steps against 8 for a
white chain.

``ConditionalMove`` is an independence proposal per walker, Metropolis-Hastings:

- h' (the hyperparameters, sampling coordinates) from a multivariate Student t fitted to the
  complementary half of the ensemble (mean, covariance × ``T_SCALE``², ``T_DOF`` degrees of freedom);
- the model block θ' = μ(h') + A(h') u', u' from a standard Student t, where μ(h), A(h) are the
  linearized generalized least-squares mean and Cholesky factor of the covariance given h
  (inference/posterior/conditional.py, eq. 32 under the discrepancy).

The proposal density is t(h') · t(u') / det A(h'), so the Metropolis-Hastings ratio carries
ln t(h) + ln t(u) - ln det A(h) - (the same at the proposal), u = A(h)⁻¹ (θ - μ(h)). Everything the
proposal uses comes from the other half of the ensemble and from fit.json (emcee's red-blue split),
so each half's update leaves the posterior invariant, as emcee's KDEMove does.

``ComplementMove``: where the posterior is cut by a bound of its prior (an estimate held on G = 0,
say) or far from its linearization (the spectrum exponent sampled), the linearized proposals are
hardly ever accepted and ``DEMove`` alone needed τ ≈ 23-47 steps. The complementary half of the
ensemble is a sample of the posterior itself: θ' from a Student t with its mean and covariance
(× ``T_SCALE``², ``T_DOF`` degrees of freedom), as the conditional move draws h, for every walker of
the half, brought τ to 8-22 on those posteriors (docs/sampling.md). It needs a covariance of full
rank from the half: ``ensemble.complement_fits`` asks for at least 2 d + 2 walkers in it (d parameters),
else ``sample`` keeps ``DEMove`` alone.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bayes_dnlr.inference.mcmc.emcee_import import load_emcee

T_DOF = 4.0               # Student t proposals: tails heavier than the posterior's
T_SCALE = 1.2             # × the complement's covariance of h (on top of the t's own ν/(ν-2))
CONDITIONAL_WEIGHT = 0.7  # share of the steps that make the conditional move (the rest: DEMove)
LAPLACE_DOF = 10.0        # the Laplace move's Student t: tails a little heavier than a Gaussian's
LAPLACE_SCALE = 1.1       # × the linearized covariance's square root
LAPLACE_WEIGHT = 0.7      # share of the steps that make the Laplace move (the rest: DEMove)
COMPLEMENT_WEIGHT = 0.7   # share of the steps that make the complement move (the rest: DEMove)
_emcee = load_emcee()


def _t_log_kernel(u: np.ndarray, dof: float) -> np.ndarray:
    """log density of the standard multivariate Student t at the rows of u, up to a constant."""
    return -0.5 * (dof + u.shape[1]) * np.log1p(np.sum(u * u, axis=1) / dof)


def _standard_t(random: Any, n: int, d: int, dof: float) -> np.ndarray:
    """n rows of the standard d-variate Student t (``dof``): normals over √(χ²/dof)."""
    return random.randn(n, d) / np.sqrt(random.chisquare(dof, size=n) / dof)[:, None]


def _located_t(random: Any, mean: np.ndarray, chol: np.ndarray, n: int, dof: float) -> np.ndarray:
    """n rows of the Student t (``dof``) with location ``mean`` and scale ``chol cholᵀ``."""
    return mean + (random.randn(n, mean.size) @ chol.T) / np.sqrt(
        random.chisquare(dof, size=n) / dof)[:, None]


def _rejecting_non_finite(q: np.ndarray, s: np.ndarray,
                          factors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The proposal and its factors, a walker whose factor is not finite (a non-finite point, one
    beyond a map's reach) kept where it is and rejected."""
    bad = ~np.isfinite(factors)
    q[bad] = s[bad]
    factors[bad] = -np.inf
    return q, factors


def complement_t(comp: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """The mean of the rows of ``comp`` (walkers of the other half) and the Cholesky factor of
    their covariance × ``scale``², kept positive definite for a flat complement."""
    mean = comp.mean(axis=0)
    dev = comp - mean
    cov = dev.T @ dev * (scale**2 / (comp.shape[0] - 1))
    cov += np.eye(comp.shape[1]) * (1e-300 + 1e-9 * float(np.max(np.diag(cov))))
    return mean, np.linalg.cholesky(cov)


def t_logpdf(x: np.ndarray, mean: np.ndarray, chol: np.ndarray, dof: float) -> np.ndarray:
    """log density of the multivariate Student t (location ``mean``, scale ``chol cholᵀ``, ``dof``
    degrees of freedom) at the rows of x, up to a constant that cancels in a ratio."""
    return _t_log_kernel(np.linalg.solve(chol, (x - mean).T).T, dof)


class LaplaceMove(_emcee.moves.RedBlueMove):
    """Independence proposal of every parameter: ``center`` + ``root`` u, u a standard Student t
    (``dof``) scaled by ``scale``; ``root`` is a square root of the linearized covariance in
    sampling coordinates (invertible), ``center`` the estimate."""

    def __init__(self, center: np.ndarray, root: np.ndarray, dof: float = LAPLACE_DOF,
                 scale: float = LAPLACE_SCALE) -> None:
        super().__init__()
        self.center = np.asarray(center, dtype=float)
        self.root = scale * np.asarray(root, dtype=float)
        self.dof = float(dof)

    def get_proposal(self, s: np.ndarray, c: list[np.ndarray],
                     random: Any) -> tuple[np.ndarray, np.ndarray]:
        u_new = _standard_t(random, *s.shape, self.dof)
        q = self.center + u_new @ self.root.T
        u_old = np.linalg.solve(self.root, (s - self.center).T).T
        return _rejecting_non_finite(q, s, _t_log_kernel(u_old, self.dof)
                                     - _t_log_kernel(u_new, self.dof))


class ConditionalMove(_emcee.moves.RedBlueMove):
    """Independence proposal of the hyperparameters ``mapper.hyper`` (Student t of the complement)
    and of the model block ``mapper.model`` given them (``mapper.standardize_and_place``)."""

    def __init__(self, mapper: Any, dof: float = T_DOF, scale: float = T_SCALE) -> None:
        super().__init__()
        self.mapper = mapper
        self.hyper = np.asarray(mapper.hyper, dtype=int)
        self.model = np.asarray(mapper.model, dtype=int)
        self.dof = float(dof)
        self.scale = float(scale)

    def get_proposal(self, s: np.ndarray, c: list[np.ndarray],
                     random: Any) -> tuple[np.ndarray, np.ndarray]:
        ns, p = s.shape[0], self.model.size
        mean, chol = complement_t(np.concatenate(c, axis=0)[:, self.hyper], self.scale)
        h_new = _located_t(random, mean, chol, ns, self.dof)
        u_new = _standard_t(random, ns, p, self.dof)
        h_old = s[:, self.hyper]
        u_old, ld_old, theta_new, ld_new = self.mapper.standardize_and_place(
            h_old, s[:, self.model], h_new, u_new)
        q = s.copy()
        q[:, self.hyper] = h_new
        q[:, self.model] = theta_new
        lt_h = t_logpdf(np.concatenate([h_old, h_new]), mean, chol, self.dof)
        lt_u = _t_log_kernel(np.concatenate([u_old, u_new]), self.dof)
        return _rejecting_non_finite(q, s, lt_h[:ns] - lt_h[ns:] + lt_u[:ns] - lt_u[ns:]
                                     + ld_new - ld_old)


class ComplementMove(_emcee.moves.RedBlueMove):
    """Independence proposal of every parameter from a Student t (``dof``) fitted to the
    complementary half of the ensemble (its mean, its covariance × ``scale``²)."""

    def __init__(self, dof: float = T_DOF, scale: float = T_SCALE) -> None:
        super().__init__()
        self.dof = float(dof)
        self.scale = float(scale)

    def get_proposal(self, s: np.ndarray, c: list[np.ndarray],
                     random: Any) -> tuple[np.ndarray, np.ndarray]:
        ns = s.shape[0]
        mean, chol = complement_t(np.concatenate(c, axis=0), self.scale)
        q = _located_t(random, mean, chol, ns, self.dof)
        lt = t_logpdf(np.concatenate([s, q]), mean, chol, self.dof)
        return _rejecting_non_finite(q, s, lt[:ns] - lt[ns:])
