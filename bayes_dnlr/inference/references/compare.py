"""A reference against the model's prediction at its time scale: the prediction's mean, sd and 90 %
interval (from posterior draws, or linearized from a fit's covariance), the z of the reference,
its discrepancy in %, and the check.

The check is a held-out posterior predictive comparison: the reference's sd and the prediction's
combined, s_c² = s² + sd_pred², z = (v − mean)/s_c. It fires when the reference lies outside the
99 % interval of that combined spread (|z| > 2.576, a two-sided p below ``CHECK_P``); a sweep, whose
elements share the posterior's uncertainty, by χ² = rᵀ (C_pred + S)⁻¹ r on its m elements against
the same p. At 1 % a run with a handful of references and the package's other checks keeps false
alarms on clean data rare; the benchmark (benchmarks/reference_moduli.py) measures them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.inference.mcmc import ess
from bayes_dnlr.vocabulary import Z90

CHECK_P = 0.01
CHECK_Z = 2.5758293035489004     # the normal's two-sided 99 % point: |z| > CHECK_Z is p < CHECK_P
HDI_PROB = 0.9


@dataclass(frozen=True)
class Prediction:
    """The prediction of a reference's m elements: mean, covariance, median and 90 % interval."""

    mean: np.ndarray          # (m,)
    covariance: np.ndarray    # (m, m)
    median: np.ndarray        # (m,)
    hdi: np.ndarray           # (m, 2)
    how: str                  # "posterior" | "white" | "generalized"

    @property
    def sd(self) -> np.ndarray:
        return np.sqrt(np.maximum(np.diag(self.covariance), 0.0))


def from_draws(values: np.ndarray) -> Prediction:
    """The prediction over posterior draws ``values`` (k, m)."""
    v = np.atleast_2d(np.asarray(values, dtype=float))
    cov = np.atleast_2d(np.cov(v, rowvar=False)) if v.shape[0] > 1 else np.zeros((v.shape[1],) * 2)
    hdi = np.array([ess.hdi(v[:, i], HDI_PROB) for i in range(v.shape[1])])
    return Prediction(v.mean(axis=0), cov, np.median(v, axis=0), hdi, "posterior")


def linearized(value: np.ndarray, jacobian: np.ndarray, covariance: np.ndarray, how: str) -> Prediction:
    """The prediction at an estimate, g(θ̂), with the delta method's covariance G Δ Gᵀ (eq. 32) and
    the normal 90 % interval."""
    g = np.atleast_1d(np.asarray(value, dtype=float))
    G = np.atleast_2d(np.asarray(jacobian, dtype=float))
    C = np.nan_to_num(G @ np.asarray(covariance, dtype=float) @ G.T)
    sd = np.sqrt(np.maximum(np.diag(C), 0.0))
    return Prediction(g, C, g.copy(), np.column_stack([g - Z90 * sd, g + Z90 * sd]), how)


@dataclass(frozen=True)
class Agreement:
    """A reference against its prediction: per element z and discrepancy; the check's statistic."""

    z: np.ndarray             # (m,) (v − mean)/s_c, NaN where s_c is 0
    discrepancy_pct: np.ndarray   # (m,) 100 (v − mean)/mean
    chi2: float | None        # a sweep's statistic (None for a point)
    dof: int
    p_value: float | None
    fired: bool | None        # None: nothing to check (no sd anywhere, or no prediction)


def agreement(value: np.ndarray, sd: np.ndarray, pred: Prediction, sweep: bool) -> Agreement:
    """The reference's values and sd (NaN: not given, taken as 0 beside the prediction's) against
    ``pred`` (module doc)."""
    v = np.asarray(value, dtype=float)
    s = np.nan_to_num(np.asarray(sd, dtype=float), nan=0.0)
    combined = np.sqrt(s**2 + pred.sd**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(combined > 0, (v - pred.mean) / combined, np.nan)
        disc = 100.0 * (v - pred.mean) / pred.mean
    if not sweep:
        zi = float(z[0])
        fired = None if not math.isfinite(zi) else abs(zi) > CHECK_Z
        p = None if not math.isfinite(zi) else math.erfc(abs(zi) / math.sqrt(2.0))
        return Agreement(z, disc, None, 1, p, fired)
    r = v - pred.mean
    C = pred.covariance + np.diag(s**2)
    try:
        chi2 = float(r @ np.linalg.solve(C, r))
    except np.linalg.LinAlgError:
        chi2 = float(np.nansum(z**2))
    from scipy.special import gammaincc  # the χ² survival function, without scipy.stats

    p = float(gammaincc(0.5 * r.size, 0.5 * max(chi2, 0.0)))
    return Agreement(z, disc, chi2, int(r.size), p, p < CHECK_P)
