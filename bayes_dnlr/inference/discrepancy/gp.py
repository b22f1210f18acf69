"""Gaussian-process model discrepancy in O(n): the exact likelihood of residual = δ + noise.

The residual r = y^m - y(θ) of a real curve is modelled as r = δ + ε, with ε ~ N(0, σ0² I) the
measurement noise and δ a zero-mean stationary Gaussian process on a 1-D axis x (time or strain),
the model discrepancy, with covariance

    exp (Ornstein-Uhlenbeck, continuous AR(1)):  k(τ) = a² exp(-τ/ℓ)
    matern32:                                     k(τ) = a² (1 + λτ) exp(-λτ),   λ = √3/ℓ

Both kernels are exactly the covariance of a linear stochastic differential equation, so the
likelihood, the whitening L⁻¹ (C = L Lᵀ, C = k(x, x) + σ0² I) and the posterior mean of δ follow
from a Kalman filter and a Rauch-Tung-Striebel smoother in O(n), exactly, on any sorted grid
(inference/discrepancy/kalman.py, compiled). Generalized least squares is ordinary least squares on whitened
residuals and sensitivities.

With columns V (n, p) the likelihood is that of the orthogonal discrepancy: δ conditioned on
Vᵀ δ = 0 (Plumlee 2017), covariance C - K V (Vᵀ K V)⁻¹ Vᵀ K, in the same O(n p²) pass
(inference/discrepancy/orthogonal.py says what V is).

``celerite2`` (Foreman-Mackey et al. 2017) computes the exp kernel's likelihood exactly too, but its
Matern32Term is an approximation (a sum of two exponentials with ε = 0.01);
tests/inference/discrepancy/test_gp.py checks this module against a dense multivariate normal and
against celerite2.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bayes_dnlr.inference.discrepancy import kalman, lanes
from bayes_dnlr.inference.discrepancy.kalman import KERNELS  # noqa: F401  (re-exported)
from bayes_dnlr.model import threads

# ------------------------------------------------------------------ Python API

def kernel_code(kind: str) -> int:
    """The compiled code of a kernel name (``exp`` or ``matern32``)."""
    try:
        return KERNELS[kind]
    except KeyError:
        raise ValueError(f"unknown discrepancy kernel {kind!r}; expected one of {list(KERNELS)}") from None


def _axis(x: np.ndarray) -> np.ndarray:
    x = np.ascontiguousarray(x, dtype=float)
    if x.ndim != 1 or x.size < 1:
        raise ValueError("the discrepancy axis must be a non-empty 1-D array")
    if np.any(np.diff(x) < 0) or not np.all(np.isfinite(x)):
        raise ValueError("the discrepancy axis must be finite and sorted (non-decreasing)")
    return x


def _gap(x: np.ndarray, start: float | None) -> float:
    """Distance from the pinned start to the first point (inf: stationary)."""
    if start is None:
        return math.inf
    gap = float(x[0] - start)
    if not gap >= 0:
        raise ValueError(f"the pinned start {start} lies after the first point {x[0]}")
    return gap


def _columns(V: np.ndarray | None, n: int) -> np.ndarray:
    """The orthogonality columns as a C-contiguous (n, p) array; (n, 0) for none."""
    if V is None:
        return np.zeros((n, 0))
    V = np.ascontiguousarray(np.asarray(V, dtype=float).reshape(n, -1))
    if not np.all(np.isfinite(V)):
        raise ValueError("the orthogonality columns V must be finite")
    return V


def _right_hand_side(V: np.ndarray, n: int) -> tuple[np.ndarray, bool]:
    """V (n,) or (n, m) as a C-contiguous (n, m) array, and whether it was a vector."""
    V = np.asarray(V, dtype=float)
    vec = V.ndim == 1
    V2 = np.ascontiguousarray(V[:, None] if vec else V)
    if V2.shape[0] != n:
        raise ValueError(f"{V2.shape[0]} rows for an axis of {n} points")
    return V2, vec


def _check_hyper(sigma0: float, amplitude: float, length: float) -> None:
    if not kalman.valid(sigma0, amplitude, length):
        raise ValueError(f"invalid hyperparameters sigma0 = {sigma0}, amplitude = {amplitude}, "
                         f"length = {length}")


def log_likelihood(x: np.ndarray, r: np.ndarray, sigma0: float, amplitude: float, length: float,
                   kind: str = "matern32", start: float | None = None,
                   V: np.ndarray | None = None) -> float:
    """log N(r | 0, C), C = k(x, x) + σ0² I, exactly in O(n); -inf for invalid hyperparameters.

    amplitude = 0 gives the white (independent) likelihood with sd σ0. ``start``: δ is pinned to
    0 (and its slope to 0, for matern32) there, at or before x[0]; None: stationary δ. ``V`` (n, p):
    the orthogonal discrepancy, δ conditioned on Vᵀ δ = 0: log N(r | 0, C - K V (Vᵀ K V)⁻¹ Vᵀ K),
    in O(n p²).
    """
    x = _axis(x)
    r = np.ascontiguousarray(r, dtype=float)
    if r.shape != x.shape:
        raise ValueError(f"residuals {r.shape} and axis {x.shape} differ")
    return float(kalman.loglike(x, r, _columns(V, x.size), float(sigma0), float(amplitude),
                                 float(length), kernel_code(kind), _gap(x, start)))


def log_likelihood_batch(x: np.ndarray, R: np.ndarray, sigma0: np.ndarray, amplitude: np.ndarray,
                         length: np.ndarray, kind: str = "matern32", start: float | None = None,
                         V: np.ndarray | None = None) -> np.ndarray:
    """The log-likelihood of each row of R (k, n) with its own hyperparameters (k,) each; the rows
    run in parallel (numba threads), each one alone, so the result does not depend on threads."""
    x = _axis(x)
    Rt = np.ascontiguousarray(np.atleast_2d(R).T, dtype=float)
    k = Rt.shape[1]
    # writable copies: a read-only view (broadcast_to's) is another type to numba, compiled again
    hyper = [np.array(np.broadcast_to(np.asarray(v, dtype=float), (k,)))
             for v in (sigma0, amplitude, length)]
    out = np.empty(k)
    nthreads = numba.get_num_threads() if threads.parallel_allowed() else 1
    lanes.loglike_groups(x, Rt, *hyper, kernel_code(kind), _gap(x, start), _columns(V, x.size), out,
                         nthreads)
    return out


def whiten(x: np.ndarray, V: np.ndarray, sigma0: float, amplitude: float, length: float,
           kind: str = "matern32", start: float | None = None) -> tuple[np.ndarray, float]:
    """(L⁻¹ V, log det K) for K = L Lᵀ = k(x, x) + σ0² I; V (n,) or (n, m). O(n m).

    Generalized least squares with covariance K is ordinary least squares on L⁻¹ y and L⁻¹ X.
    """
    x = _axis(x)
    V2, vec = _right_hand_side(V, x.size)
    _check_hyper(float(sigma0), float(amplitude), float(length))
    out = np.empty_like(V2)
    logdet = kalman._filter(x, V2, float(sigma0), float(amplitude), float(length), kernel_code(kind),
                            _gap(x, start), out, np.empty((0, 9)))
    return (out[:, 0] if vec else out), float(logdet)


def whitening(x: np.ndarray, V: np.ndarray, kind: str = "matern32", start: float | None = None):
    """(σ0, a, ℓ) -> (L⁻¹ V, log det K) as ``whiten`` gives them, with the axis and V (n, m) checked
    and laid out once: for a search that whitens the same columns hundreds of times. The returned
    array is a buffer the next call overwrites."""
    x = _axis(x)
    V2 = np.ascontiguousarray(np.asarray(V, dtype=float).reshape(x.size, -1))
    out, store = np.empty_like(V2), np.empty((0, 9))
    code, gap = kernel_code(kind), _gap(x, start)

    def apply(sigma0: float, amplitude: float, length: float) -> tuple[np.ndarray, float]:
        _check_hyper(sigma0, amplitude, length)
        return out, float(kalman._filter(x, V2, sigma0, amplitude, length, code, gap, out, store))

    return apply


def solve(x: np.ndarray, V: np.ndarray, sigma0: float, amplitude: float, length: float,
          kind: str = "matern32", start: float | None = None) -> np.ndarray:
    """C⁻¹ V for C = k(x, x) + σ0² I; V (n,) or (n, m). O(n m): the filter and its adjoint."""
    x = _axis(x)
    V2, vec = _right_hand_side(V, x.size)
    _check_hyper(float(sigma0), float(amplitude), float(length))
    out = kalman._solve(x, V2, float(sigma0), float(amplitude), float(length), kernel_code(kind),
                        _gap(x, start))
    return out[:, 0] if vec else out


def quadratic_form(x: np.ndarray, Z: np.ndarray, amplitude: float, length: float,
                   kind: str = "matern32", start: float | None = None) -> np.ndarray:
    """Zᵀ K Z (m, m) for K = k(x, x) without the noise; Z (n, m). O(n m²), by the recursion of the
    filter pass (inference/discrepancy/kalman.py ``_sums``, M̃)."""
    x = _axis(x)
    Z = np.ascontiguousarray(np.asarray(Z, dtype=float).reshape(x.size, -1))
    m = Z.shape[1]
    D, Mt, mu = np.empty((m, m)), np.empty((m, m)), np.empty(m)
    kalman._sums(x, np.zeros(x.size), Z, 1.0, 1.0, float(length), kernel_code(kind), _gap(x, start),
                 D, mu, Mt)
    return float(amplitude) ** 2 * Mt


def sandwich(x: np.ndarray, Z: np.ndarray, delta: np.ndarray, sigma0: float, amplitude: float,
             length: float, kind: str = "matern32", start: float | None = None) -> np.ndarray:
    """Δ Zᵀ C Z Δ for C = k(x, x) + σ0² I, Z = C_w⁻¹ X and Δ = (Xᵀ C_w⁻¹ X)⁻¹: the covariance of
    the estimate under the covariance C_w when the error has the covariance C (symmetrized)."""
    G = quadratic_form(x, Z, amplitude, length, kind, start) + sigma0**2 * (Z.T @ Z)
    return delta @ (0.5 * (G + G.T)) @ delta


def posterior_mean(x: np.ndarray, r: np.ndarray, sigma0: float, amplitude: float, length: float,
                   kind: str = "matern32", start: float | None = None) -> np.ndarray:
    """E[δ | r]: the discrepancy the residuals imply (Kalman filter + RTS smoother), O(n)."""
    x = _axis(x)
    r = np.ascontiguousarray(r, dtype=float)
    if amplitude == 0:
        return np.zeros_like(r)
    return kalman._smooth_mean(x, r, float(sigma0), float(amplitude), float(length), kernel_code(kind),
                        _gap(x, start))


def covariance(x: np.ndarray, amplitude: float, length: float, kind: str = "matern32",
               sigma0: float = 0.0, start: float | None = None) -> np.ndarray:
    """The dense covariance k(x, x) + σ0² I (for checks and small n; O(n²) memory); with ``start``
    the covariance of δ conditioned on δ(start) = 0 (and δ'(start) = 0 for matern32)."""
    x = np.asarray(x, dtype=float)

    def k(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        tau = np.abs(a[:, None] - b[None, :])
        if kind == "exp":
            return amplitude**2 * np.exp(-tau / length)
        if kind == "matern32":
            u = math.sqrt(3.0) * tau / length
            return amplitude**2 * (1.0 + u) * np.exp(-u)
        kernel_code(kind)
        raise AssertionError("unreachable")

    K = k(x, x)
    if start is not None and amplitude > 0:
        s = np.array([float(start)])
        C = k(x, s)                                  # cov(δ(x), δ(start))
        S = [[amplitude**2]]
        if kind == "matern32":
            lam = math.sqrt(3.0) / length
            tau = x - float(start)                   # >= 0: cov(δ(x), δ'(start)) = a² λ² τ e^{-λτ}
            C = np.column_stack([C[:, 0], amplitude**2 * lam**2 * tau * np.exp(-lam * tau)])
            S = [[amplitude**2, 0.0], [0.0, amplitude**2 * lam**2]]
        K = K - C @ np.linalg.solve(np.asarray(S), C.T)
    K[np.diag_indices_from(K)] += sigma0**2
    return K


def orthogonal_covariance(x: np.ndarray, amplitude: float, length: float, kind: str, V: np.ndarray,
                          sigma0: float = 0.0, start: float | None = None) -> np.ndarray:
    """The dense covariance of the orthogonal discrepancy plus noise, K - K V (Vᵀ K V)⁻¹ Vᵀ K + σ0² I
    (the conditional covariance of δ given Vᵀ δ = 0; for checks and small n)."""
    K = covariance(x, amplitude, length, kind, 0.0, start)
    U = K @ np.asarray(V, dtype=float)
    out = K - U @ np.linalg.solve(np.asarray(V).T @ U, U.T)
    out[np.diag_indices_from(out)] += sigma0**2
    return 0.5 * (out + out.T)
