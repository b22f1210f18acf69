"""Ensemble moves that update one block of the parameters (``sampler.moves: de-blocks``).

With the model discrepancy the posterior of (ln amplitude, ln length) is a narrow, skewed ridge
with a heavy tail toward long lengths (the data fix about a²/ℓ, not a and ℓ apart), and along it
the spread of the model parameters changes: a long length lets the discrepancy take over the
slow trend of the hardening, and G's conditional sd grows about as √ℓ (5.5× from the shortest
tenth of the lengths to the longest 3 % on a synthetic test with an exp error). A
differential-evolution step over all parameters at once is mostly rejected there. Two moves split
the work, Metropolis-within-Gibbs on an ensemble:

- ``BlockDEMove``: differential evolution on the model block only (the hyperparameters held);
- ``BlockIndependenceMove``: the hyperparameter block drawn afresh, independently of the walker's
  position, from a multivariate Student t fitted to the complementary half of the ensemble, and the
  walker's model parameters carried along: their deviation from the complement's median is scaled
  by exp(βᵀ Δh), β the regression of ln|deviation| on the hyperparameters over the complement (the
  funnel above). Metropolis-Hastings with the ratio of proposal densities and the map's Jacobian
  Σ βᵀ Δh. Every quantity of the proposal depends on the other half of the ensemble only (emcee's
  red-blue split), so each half's update leaves the posterior invariant, as emcee's KDEMove does.

Both draw from emcee's ``RandomState`` only (the chain is reproducible and resumes bit-exactly).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from bayes_dnlr.inference.mcmc.emcee_import import load_emcee
from bayes_dnlr.vocabulary import DISCREPANCY_PARAMETERS, base_name

T_DOF = 4.0          # Student t proposal: tails heavier than the ridge's own
T_SCALE = 1.2        # × the complement's covariance (on top of the t's own ν/(ν-2))
_emcee = load_emcee()


def t_logpdf(x: np.ndarray, mean: np.ndarray, chol: np.ndarray, dof: float) -> np.ndarray:
    """log density of the multivariate Student t (location ``mean``, scale ``chol cholᵀ``, ``dof``
    degrees of freedom) at the rows of x, up to a constant that cancels in a ratio."""
    u = np.linalg.solve(chol, (x - mean).T)
    return -0.5 * (dof + mean.size) * np.log1p(np.sum(u * u, axis=0) / dof)


class BlockIndependenceMove(_emcee.moves.RedBlueMove):
    """Redraw the coordinates ``block`` from a Student t fitted to the complementary walkers, and
    scale the coordinates ``carry`` about the complement's median by the fitted funnel."""

    def __init__(self, block: list[int], carry: list[int] | None = None, dof: float = T_DOF,
                 scale: float = T_SCALE) -> None:
        super().__init__()
        self.block = np.asarray(block, dtype=int)
        self.carry = np.asarray(carry if carry is not None else [], dtype=int)
        self.dof = float(dof)
        self.scale = float(scale)

    def get_proposal(self, s: np.ndarray, c: list[np.ndarray],
                     random: Any) -> tuple[np.ndarray, np.ndarray]:
        full = np.concatenate(c, axis=0)
        comp = full[:, self.block]
        ns, d = s.shape[0], self.block.size
        mean = comp.mean(axis=0)
        cov = np.atleast_2d(np.cov(comp, rowvar=False)) * self.scale**2
        cov += np.eye(d) * (1e-300 + 1e-9 * float(np.max(np.diag(cov))))   # a flat complement
        chol = np.linalg.cholesky(cov)
        z = random.randn(ns, d)
        w = random.chisquare(self.dof, size=ns) / self.dof
        new = mean + (z @ chol.T) / np.sqrt(w)[:, None]
        factors = t_logpdf(s[:, self.block], mean, chol, self.dof) - t_logpdf(new, mean, chol, self.dof)
        q = s.copy()
        q[:, self.block] = new
        if self.carry.size:
            x = np.column_stack([np.ones(full.shape[0]), comp - mean])
            th = full[:, self.carry]
            mid = np.median(th, axis=0)
            with np.errstate(divide="ignore"):
                ly = np.log(np.abs(th - mid))
            ok = np.all(np.isfinite(ly), axis=1)           # the median walker itself: left out
            beta = (np.linalg.lstsq(x[ok], ly[ok], rcond=None)[0][1:] if ok.sum() > d + 1
                    else np.zeros((d, self.carry.size)))
            log_r = (new - s[:, self.block]) @ beta          # (ns, carried)
            q[:, self.carry] = mid + np.exp(log_r) * (s[:, self.carry] - mid)
            factors = factors + log_r.sum(axis=1)            # the map's Jacobian
        return q, factors


class BlockDEMove(_emcee.moves.DEMove):
    """emcee's differential evolution on the coordinates ``block`` only (γ0 = 2.38/√(2 d_block))."""

    def __init__(self, block: list[int], **kwargs: Any) -> None:
        self.block = np.asarray(block, dtype=int)
        super().__init__(gamma0=2.38 / math.sqrt(2 * max(len(block), 1)), **kwargs)

    def get_proposal(self, s: np.ndarray, c: list[np.ndarray],
                     random: Any) -> tuple[np.ndarray, np.ndarray]:
        q, factors = super().get_proposal(s, c, random)
        out = s.copy()
        out[:, self.block] = q[:, self.block]
        return out, factors


def block_moves(names: list[str] | None) -> list[tuple[Any, float]]:
    """``de-blocks``: half the steps DE on the model block, half the discrepancy's hyperparameters
    redrawn with the model block carried along (benchmarks/chain_mixing.py); plain DE when no
    hyperparameter is sampled."""
    names = list(names or [])
    h = [j for j, k in enumerate(names) if base_name(k) in DISCREPANCY_PARAMETERS]
    m = [j for j in range(len(names)) if j not in h]
    if not h or not m:
        return [(_emcee.moves.DEMove(), 1.0)]
    return [(BlockDEMove(m), 0.5), (BlockIndependenceMove(h, carry=m), 0.5)]
