"""The small-strain limit of the DNLR model as a Prony series (docs/theory.md, "Small strains").

At small strain ε_HT = exp(2ε) - exp(-ε) = 3ε + O(ε²) (eq. 7), so eq. 18 becomes linear:
dσ_j/dt = p_j E ε̇ - (σ_j - 3 p_j G ε)/τ_j. Its solution from rest is the hereditary integral
σ(t) = ∫ E(t - s) ε̇(s) ds with the uniaxial relaxation modulus

    E(t) = 3G + (E - 3G) Σ_j p_j exp(-t/τ_j),       τ_j, p_j of eq. 12-14,

a Prony series with long-term modulus E_∞ = 3G, instantaneous modulus E(0) = E and terms
E_j = (E - 3G) p_j. ``refit`` replaces the N-term series by a shorter one (non-negative least
squares on the test's time range).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.model import relaxation_times, weights
from bayes_dnlr.model.spectrum import UNIVERSAL_EXPONENT


@dataclass(frozen=True)
class Prony:
    """E(t) = e_inf + Σ moduli_i exp(-t/times_i): a uniaxial relaxation modulus (MPa, s)."""

    e_inf: float
    moduli: np.ndarray
    times: np.ndarray

    @property
    def e0(self) -> float:
        """The instantaneous modulus E(0)."""
        return float(self.e_inf + self.moduli.sum())

    @property
    def terms(self) -> int:
        return int(self.moduli.size)

    @property
    def ratios(self) -> np.ndarray:
        """g_i = E_i / E(0): the dimensionless Prony coefficients (sum = 1 - E_∞/E(0))."""
        return self.moduli / self.e0

    def scaled(self, factor: float) -> Prony:
        """The series with every relaxation time multiplied by ``factor``: the reference state's
        series at a temperature where a_T = ``factor`` (time-temperature superposition)."""
        return self if factor == 1.0 else Prony(self.e_inf, self.moduli, self.times * factor)

    def modulus(self, t: np.ndarray | float) -> np.ndarray:
        """E(t) at times t >= 0 (s)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return self.e_inf + np.exp(-np.divide.outer(t, self.times)) @ self.moduli

    def response(self, time: np.ndarray, strain: np.ndarray) -> np.ndarray:
        """Stress of the hereditary integral for a strain linear between samples, exactly.

        Each term is a Maxwell branch h_i: over a step Δ with a = exp(-Δ/τ_i),
        h_i ← a h_i + E_i τ_i (1 - a) Δε/Δ; σ = E_∞ ε + Σ h_i. A nonzero first strain is taken as
        applied instantaneously at the first time (h_i = E_i ε(t_0)).
        """
        time = np.asarray(time, dtype=float)
        strain = np.asarray(strain, dtype=float)
        h = self.moduli * strain[0]
        out = np.empty(time.size)
        out[0] = self.e_inf * strain[0] + h.sum()
        for k in range(1, time.size):
            dt = time[k] - time[k - 1]
            x = dt / self.times
            a = np.exp(-np.minimum(x, 700.0))
            phi = np.where(x > 1e-8, -np.expm1(-x) / np.where(x > 1e-8, x, 1.0), 1.0 - 0.5 * x)
            h = a * h + self.moduli * phi * (strain[k] - strain[k - 1])
            out[k] = self.e_inf * strain[k] + h.sum()
        return out


def from_parameters(E: float, G: float, tau_max: float, modes: int = 50,
                    decades: float = 6.0, alpha: float = UNIVERSAL_EXPONENT) -> Prony:
    """The N-mode Prony series of the DNLR model at small strain (eq. 12-14 and 18 with ε_HT ≈ 3ε);
    alpha is the spectrum's exponent (p_j ∝ tau_j^alpha, ½ in eq. 12)."""
    for name, v in (("E", E), ("G", G), ("tau_max", tau_max)):
        if not np.isfinite(v):
            raise BayesDnlrError(f"{name} = {v} is not a finite number")
    if not tau_max > 0:
        raise BayesDnlrError(f"tau_max = {tau_max:g} s: a relaxation time must be > 0")
    if G < 0:
        raise BayesDnlrError(f"G = {G:g} MPa: the long-term modulus 3G would be negative")
    if not E > 3.0 * G:
        raise BayesDnlrError(f"E = {E:g} MPa is not above 3G = {3 * G:g} MPa: the series would "
                             "stiffen with time, not relax")
    tau = relaxation_times(tau_max, modes, decades)
    p = weights(modes, decades, alpha)
    return Prony(3.0 * G, (E - 3.0 * G) * p, tau)


@dataclass(frozen=True)
class Refit:
    """A shorter series and how far it is from the full one."""

    prony: Prony
    t_range: tuple[float, float]      # the time range it was fitted on, s
    max_error: float                  # max |E_N(t) - E(t)| / E(t) over {0} and the range (fraction)
    requested: int                    # terms asked for (terms with a zero modulus are dropped)


def log_times(t_lo: float, t_hi: float, n: int = 400) -> np.ndarray:
    """0 and n log-spaced times from t_lo to t_hi."""
    return np.concatenate([[0.0], np.geomspace(t_lo, t_hi, n)])


HOLD_E0 = 10.0      # weight of the t = 0 row: the instantaneous modulus is the point of the card


def refit(full: Prony, terms: int, t_lo: float, t_hi: float,
          start: np.ndarray | None = None) -> Refit:
    """A ``terms``-term series with the same E_∞ fitted to E(t) of ``full`` on t = 0 and log-spaced
    times over [t_lo, t_hi], in relative error.

    Variable projection: for given relaxation times the moduli are a non-negative least-squares
    solution (``nnls``); the log relaxation times are optimised around it (trust region, bounded by
    t_lo/100 and the longest time of ``full``: E(t) is flat beyond it), from log-spaced times or
    ``start``. The row t = 0 is weighted so that E(0) stays the instantaneous modulus.
    """
    if terms < 1:
        raise BayesDnlrError(f"--terms {terms}: give at least 1 term")
    if not 0 < t_lo < t_hi:
        raise BayesDnlrError(f"time range [{t_lo:g}, {t_hi:g}] s: need 0 < low < high")
    from scipy.optimize import least_squares

    t = log_times(t_lo, t_hi)
    e_full = full.modulus(t)
    w = 1.0 / e_full
    w[0] *= HOLD_E0
    b = (e_full - full.e_inf) * w
    lb, ub = np.log(t_lo / 100.0), np.log(float(full.times.max()))

    def solve(log_tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        A = np.exp(-np.divide.outer(t, np.exp(log_tau))) * w[:, None]
        moduli, _ = nnls(A, b, maxiter=100 * terms)
        return A, moduli

    def residual(log_tau: np.ndarray) -> np.ndarray:
        A, moduli = solve(log_tau)
        return A @ moduli - b

    if start is not None and len(start) == terms:
        x0 = np.log(np.asarray(start, dtype=float))
    else:
        x0 = np.log(np.geomspace(min(t_lo / 3.0, np.exp(ub) / 10.0), np.exp(ub), terms))
    x0 = np.clip(x0, lb + 1e-9, ub - 1e-9)
    if terms > 1:
        x = least_squares(residual, x0, bounds=(lb, ub), method="trf", diff_step=1e-4,
                          max_nfev=100 * terms).x
    else:
        x = x0
    _, moduli = solve(x)
    keep = moduli > 0
    order = np.argsort(x[keep])
    short = Prony(full.e_inf, moduli[keep][order], np.exp(x[keep][order]))
    err = np.abs(short.modulus(t) - e_full) / e_full
    return Refit(short, (float(t_lo), float(t_hi)), float(err.max()), int(terms))

