"""Gaussian-process model discrepancy in O(n): the exact likelihood of residual = δ + noise.

The residual r = y^m - y(θ) of a real curve is modelled as r = δ + ε, with ε ~ N(0, σ0² I) the
measurement noise and δ a zero-mean stationary Gaussian process on a 1-D axis x (time or strain),
the model discrepancy, with covariance

    exp (Ornstein-Uhlenbeck, continuous AR(1)):  k(τ) = a² exp(-τ/ℓ)
    matern32:                                     k(τ) = a² (1 + λτ) exp(-λτ),   λ = √3/ℓ

Both kernels are exactly the covariance of a linear stochastic differential equation (order 1 and
2), so the likelihood, the whitening L⁻¹ (K = L Lᵀ, K = k(x, x) + σ0² I) and the posterior mean of
δ follow from a Kalman filter and a Rauch-Tung-Striebel smoother in O(n), exactly, on any sorted
grid (uneven steps and repeated points included; Särkkä & Solin 2019, ch. 12). The filter's
normalised innovations v_i / √S_i are the entries of L⁻¹ r for the Cholesky factor L of K in the
order of x, so generalized least squares is ordinary least squares on whitened residuals and
sensitivities.

State of the process at x_i: s = δ (exp), or s = (δ, dδ/dx) (matern32), with stationary covariance
P∞ = a² (exp) or diag(a², a² λ²) (matern32) and, over a step Δ,

    exp:       Φ = e^{-Δ/ℓ}
    matern32:  Φ = e^{-λΔ} [[1 + λΔ, Δ], [-λ²Δ, 1 - λΔ]]
    and the predicted covariance P⁻ = Φ (P - P∞) Φᵀ + P∞  (= Φ P Φᵀ + Q, Q = P∞ - Φ P∞ Φᵀ).

``celerite2`` (Foreman-Mackey et al. 2017) computes the exp kernel's likelihood exactly too, but its
Matern32Term is an approximation (a sum of two exponentials with ε = 0.01);
tests/inference/discrepancy/test_gp.py checks this module against a dense multivariate normal and
against celerite2.

All compiled functions live in this one module (numba's cache does not see changes in an imported
helper of another module).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

KERNELS = {"exp": 0, "matern32": 1}
_LOG_2PI = math.log(2.0 * math.pi)


# ------------------------------------------------------------------ one step of the state model

@njit(cache=True, inline="always", fastmath={"contract"})
def _series(u: float) -> float:
    """exp(u) for |u| <= 1/4 by its 13-term series (exact to 3e-18 relative)."""
    p = 1.0 + u * (1.0 / 13.0)
    p = 1.0 + u * (1.0 / 12.0) * p
    p = 1.0 + u * (1.0 / 11.0) * p
    p = 1.0 + u * (1.0 / 10.0) * p
    p = 1.0 + u * (1.0 / 9.0) * p
    p = 1.0 + u * (1.0 / 8.0) * p
    p = 1.0 + u * (1.0 / 7.0) * p
    p = 1.0 + u * (1.0 / 6.0) * p
    p = 1.0 + u * (1.0 / 5.0) * p
    p = 1.0 + u * (1.0 / 4.0) * p
    p = 1.0 + u * (1.0 / 3.0) * p
    p = 1.0 + u * 0.5 * p
    return 1.0 + u * p


@njit(cache=True, inline="always")
def _exp_near(x: float, x_ref: float, e_ref: float) -> float:
    """exp(-x) from e_ref = exp(-x_ref) and the series of exp(x_ref - x) when |x_ref - x| <= 1/4;
    a plain exp otherwise. Steps of a jittered grid differ little, so most steps cost a few
    multiplications instead of an exp."""
    u = x_ref - x
    if u == 0.0:
        return e_ref
    if abs(u) > 0.25:
        return math.exp(-x)
    return e_ref * _series(u)


@njit(cache=True, inline="always")
def _transition_e(kind: int, d: float, lam: float, e: float):
    """Φ over a step d as (f00, f01, f10, f11), given e = exp(-λd); λ = 1/ℓ (exp) or √3/ℓ."""
    if kind == 0:
        return e, 0.0, 0.0, 0.0
    x = lam * d
    return e * (1.0 + x), e * d, -e * lam * x, e * (1.0 - x)


@njit(cache=True, inline="always")
def _transition(kind: int, d: float, lam: float):
    """Φ over a step d as (f00, f01, f10, f11); λ = 1/ℓ (exp) or √3/ℓ (matern32)."""
    return _transition_e(kind, d, lam, math.exp(-lam * d))


@njit(cache=True, inline="always")
def _predict_cov(kind: int, f00, f01, f10, f11, p00, p01, p11, q0, q1):
    """P⁻ = Φ (P - P∞) Φᵀ + P∞ with P∞ = diag(q0, q1) (q1 unused for exp)."""
    a00 = p00 - q0
    if kind == 0:
        return f00 * f00 * a00 + q0, 0.0, 0.0
    a01 = p01
    a11 = p11 - q1
    # Φ A Φᵀ, A symmetric
    b00 = f00 * a00 + f01 * a01
    b01 = f00 * a01 + f01 * a11
    b10 = f10 * a00 + f11 * a01
    b11 = f10 * a01 + f11 * a11
    return (b00 * f00 + b01 * f01 + q0, b00 * f10 + b01 * f11, b10 * f10 + b11 * f11 + q1)


@njit(cache=True)
def _initial_cov(kind: int, gap: float, lam: float, q0: float, q1: float):
    """The state covariance at the first point: stationary (``gap`` = inf), or that of a process
    pinned to δ = 0 (and δ' = 0) ``gap`` before the first point: P∞ - Φ(gap) P∞ Φ(gap)ᵀ."""
    if not math.isfinite(gap):
        return q0, 0.0, q1
    f00, f01, f10, f11 = _transition(kind, max(gap, 0.0), lam)
    return _predict_cov(kind, f00, f01, f10, f11, 0.0, 0.0, 0.0, q0, q1)


@njit(cache=True)
def _rate(kind: int, length: float) -> float:
    return 1.0 / length if kind == 0 else math.sqrt(3.0) / length


# ------------------------------------------------------------------ the filter

@njit(cache=True)
def _valid(sigma0: float, amplitude: float, length: float) -> bool:
    return (math.isfinite(sigma0) and sigma0 > 0.0 and math.isfinite(amplitude) and amplitude >= 0.0
            and math.isfinite(length) and length > 0.0)


@njit(cache=True)
def _filter(x, V, sigma0, amplitude, length, kind, gap, out, store):
    """Kalman filter of every column of V (n, m) with the same gains.

    Writes the normalised innovations (L⁻¹ V) into ``out`` (n, m) and returns log det K. With
    ``store`` (n, 8) of at least n rows, keeps per sample the filtered and predicted covariances
    (p00, p01, p11 filtered; p00, p01, p11 predicted; S; spare) for the smoother.
    """
    n, m = V.shape
    s2 = sigma0 * sigma0
    lam = _rate(kind, length)
    q0 = amplitude * amplitude
    q1 = q0 * lam * lam
    m0 = np.zeros(m)
    m1 = np.zeros(m)
    p00, p01, p11 = _initial_cov(kind, gap, lam, q0, q1)
    d_prev = -1.0
    f00 = f01 = f10 = f11 = 0.0
    logdet = 0.0
    keep = store.shape[0] >= n
    for i in range(n):
        if i > 0:
            d = x[i] - x[i - 1]
            if d != d_prev:
                f00, f01, f10, f11 = _transition(kind, d, lam)
                d_prev = d
            if kind == 0:
                for c in range(m):
                    m0[c] = f00 * m0[c]
            else:
                for c in range(m):
                    a = m0[c]
                    m0[c] = f00 * a + f01 * m1[c]
                    m1[c] = f10 * a + f11 * m1[c]
            p00, p01, p11 = _predict_cov(kind, f00, f01, f10, f11, p00, p01, p11, q0, q1)
        if keep:
            store[i, 3] = p00
            store[i, 4] = p01
            store[i, 5] = p11
        s = p00 + s2
        root = math.sqrt(s)
        k0 = p00 / s
        k1 = p01 / s
        for c in range(m):
            v = V[i, c] - m0[c]
            out[i, c] = v / root
            m0[c] += k0 * v
            m1[c] += k1 * v
        logdet += math.log(s)
        # P - K S Kᵀ, written so that p00 stays positive
        p11 = p11 - p01 * p01 / s
        p01 = p01 * s2 / s
        p00 = p00 * s2 / s
        if keep:
            store[i, 0] = p00
            store[i, 1] = p01
            store[i, 2] = p11
            store[i, 6] = s
    return logdet


@njit(cache=True)
def _loglike(x, r, sigma0, amplitude, length, kind, gap):
    """log N(r | 0, k(x, x) + σ0² I) by the Kalman filter; -inf for invalid hyperparameters.

    The hot loop of sampling: no division and no log per sample (log det K accumulates as a
    product, taken to log when it leaves [1e-150, 1e150]), and exp only where a step differs from
    the previous reference step by more than 1/16 of the correlation length (``_exp_near``).
    """
    if not _valid(sigma0, amplitude, length):
        return -np.inf
    n = x.shape[0]
    s2 = sigma0 * sigma0
    lam = _rate(kind, length)
    q0 = amplitude * amplitude
    q1 = q0 * lam * lam
    m0 = 0.0
    m1 = 0.0
    p00, p01, p11 = _initial_cov(kind, gap, lam, q0, q1)
    x_ref = -1.0
    e_ref = 1.0
    quad = 0.0
    logdet = 0.0
    prod = 1.0
    for i in range(n):
        if i > 0:
            d = x[i] - x[i - 1]
            xd = lam * d
            if abs(x_ref - xd) > 0.25:          # a new reference step: one exp
                x_ref = xd
                e_ref = math.exp(-xd)
            e = _exp_near(xd, x_ref, e_ref)
            f00, f01, f10, f11 = _transition_e(kind, d, lam, e)
            if kind == 0:
                m0 = f00 * m0
            else:
                m0, m1 = f00 * m0 + f01 * m1, f10 * m0 + f11 * m1
            p00, p01, p11 = _predict_cov(kind, f00, f01, f10, f11, p00, p01, p11, q0, q1)
        s = p00 + s2
        inv = 1.0 / s
        v = r[i] - m0
        quad += v * v * inv
        prod *= s
        if prod > 1e150 or prod < 1e-150:
            logdet += math.log(prod)
            prod = 1.0
        k0 = p00 * inv
        k1 = p01 * inv
        m0 += k0 * v
        m1 += k1 * v
        p11 = p11 - p01 * k1
        p01 = p01 * s2 * inv
        p00 = p00 * s2 * inv
    logdet += math.log(prod)
    return -0.5 * (quad + logdet + n * _LOG_2PI)


_LANES = dict(cache=True, fastmath={"contract", "nsz", "arcp"}, error_model="numpy")


@njit(**_LANES)
def loglike_lanes(x, Rt, lo, hi, sigma0, amplitude, length, kind, gap, out):
    """The filter of ``_loglike`` for the walkers lo..hi-1 side by side, one SIMD lane each.

    Rt (n, k): residuals, one column per walker (time-major, so a step's lanes are contiguous).
    Walkers are independent, so the compiler vectorises the inner loops over them and the
    filter's division latency overlaps: about 6x faster per walker than one filter at a time.
    Writes out[lo:hi]; -inf for invalid hyperparameters. Each lane's arithmetic is the same
    whatever the other lanes hold, so results do not depend on how walkers are grouped.
    """
    n = Rt.shape[0]
    k = hi - lo
    lam = np.empty(k)
    s2 = np.empty(k)
    q0 = np.empty(k)
    q1 = np.empty(k)
    m0 = np.zeros(k)
    m1 = np.zeros(k)
    p00 = np.empty(k)
    p01 = np.zeros(k)
    p11 = np.empty(k)
    quad = np.zeros(k)
    prod = np.ones(k)
    logdet = np.zeros(k)
    e_ref = np.empty(k)
    ok = np.empty(k, dtype=np.bool_)
    root3 = math.sqrt(3.0)
    for w in range(k):
        ok[w] = _valid(sigma0[lo + w], amplitude[lo + w], length[lo + w])
        ln = length[lo + w] if ok[w] else 1.0
        lam[w] = (1.0 if kind == 0 else root3) / ln
        s2[w] = sigma0[lo + w] ** 2 if ok[w] else 1.0
        q0[w] = amplitude[lo + w] ** 2 if ok[w] else 0.0
        q1[w] = q0[w] * lam[w] * lam[w]
        p00[w], p01[w], p11[w] = _initial_cov(kind, gap, lam[w], q0[w], q1[w])
    lam_max = lam.max() if k else 0.0
    d_ref = -1.0
    for i in range(n):
        if i > 0:
            d = x[i] - x[i - 1]
            if i == 1 or abs(d - d_ref) * lam_max > 0.25:    # a new reference step: one exp a lane
                d_ref = d
                for w in range(k):
                    e_ref[w] = math.exp(-lam[w] * d)
            if kind == 0:
                for w in range(k):
                    e = e_ref[w] * _series(lam[w] * (d_ref - d))
                    m0[w] = e * m0[w]
                    p00[w] = e * e * (p00[w] - q0[w]) + q0[w]
            else:
                for w in range(k):
                    e = e_ref[w] * _series(lam[w] * (d_ref - d))
                    xl = lam[w] * d
                    f00 = e * (1.0 + xl)
                    f01 = e * d
                    f10 = -e * lam[w] * xl
                    f11 = e * (1.0 - xl)
                    a = m0[w]
                    m0[w] = f00 * a + f01 * m1[w]
                    m1[w] = f10 * a + f11 * m1[w]
                    a00 = p00[w] - q0[w]
                    a01 = p01[w]
                    a11 = p11[w] - q1[w]
                    b00 = f00 * a00 + f01 * a01
                    b01 = f00 * a01 + f01 * a11
                    b10 = f10 * a00 + f11 * a01
                    b11 = f10 * a01 + f11 * a11
                    p00[w] = b00 * f00 + b01 * f01 + q0[w]
                    p01[w] = b00 * f10 + b01 * f11
                    p11[w] = b10 * f10 + b11 * f11 + q1[w]
        if kind == 0:                  # one state: no slope terms
            for w in range(k):
                s = p00[w] + s2[w]
                inv = 1.0 / s
                v = Rt[i, lo + w] - m0[w]
                quad[w] += v * v * inv
                prod[w] *= s
                m0[w] += p00[w] * inv * v
                p00[w] = p00[w] * s2[w] * inv
        else:
            for w in range(k):
                s = p00[w] + s2[w]
                inv = 1.0 / s
                v = Rt[i, lo + w] - m0[w]
                quad[w] += v * v * inv
                prod[w] *= s
                k0 = p00[w] * inv
                k1 = p01[w] * inv
                m0[w] += k0 * v
                m1[w] += k1 * v
                p11[w] = p11[w] - p01[w] * k1
                p01[w] = p01[w] * s2[w] * inv
                p00[w] = p00[w] * s2[w] * inv
        if i % 64 == 63:                                 # log det K, without a log per sample
            for w in range(k):
                logdet[w] += math.log(prod[w])
                prod[w] = 1.0
    for w in range(k):
        ll = -0.5 * (quad[w] + logdet[w] + math.log(prod[w]) + n * _LOG_2PI)
        if ok[w] and not math.isfinite(ll):
            # 64 innovation variances below ~1e-5 each underflow the product (a discrepancy far
            # above the white noise, as matern32 on a smooth curve): the scalar filter rescales
            # its product as it goes
            ll = _loglike(x, Rt[:, lo + w], sigma0[lo + w], amplitude[lo + w], length[lo + w], kind, gap)
        out[lo + w] = ll if ok[w] and math.isfinite(ll) else -np.inf


LANE_GROUP = 8     # walkers per group: one group per thread at a time


@njit(cache=True, parallel=True)
def _loglike_batch(x, Rt, sigma0, amplitude, length, kind, gap, out):
    k = Rt.shape[1]
    groups = (k + LANE_GROUP - 1) // LANE_GROUP
    for g in prange(groups):
        lo = g * LANE_GROUP
        loglike_lanes(x, Rt, lo, min(k, lo + LANE_GROUP), sigma0, amplitude, length, kind, gap, out)


@njit(cache=True)
def _smooth_mean(x, r, sigma0, amplitude, length, kind, gap):
    """E[δ(x_i) | r] by the Kalman filter and the Rauch-Tung-Striebel smoother."""
    n = x.shape[0]
    store = np.empty((n, 8))
    V = np.empty((n, 1))
    V[:, 0] = r
    white = np.empty((n, 1))
    _filter(x, V, sigma0, amplitude, length, kind, gap, white, store)
    # filtered means again (the filter above keeps covariances only): redo the mean recursion
    lam = _rate(kind, length)
    mf = np.zeros((n, 2))
    m0 = 0.0
    m1 = 0.0
    for i in range(n):
        if i > 0:
            f00, f01, f10, f11 = _transition(kind, x[i] - x[i - 1], lam)
            if kind == 0:
                m0 = f00 * m0
            else:
                m0, m1 = f00 * m0 + f01 * m1, f10 * m0 + f11 * m1
        s = store[i, 6]
        v = r[i] - m0
        m0 += store[i, 3] / s * v
        m1 += store[i, 4] / s * v
        mf[i, 0] = m0
        mf[i, 1] = m1
    out = np.empty(n)
    out[n - 1] = mf[n - 1, 0]
    ms0 = mf[n - 1, 0]
    ms1 = mf[n - 1, 1]
    for i in range(n - 2, -1, -1):
        f00, f01, f10, f11 = _transition(kind, x[i + 1] - x[i], lam)
        # G = P_f Φᵀ (P⁻_{i+1})⁻¹
        pf00, pf01, pf11 = store[i, 0], store[i, 1], store[i, 2]
        pp00, pp01, pp11 = store[i + 1, 3], store[i + 1, 4], store[i + 1, 5]
        # predicted mean at i+1
        if kind == 0:
            mp0 = f00 * mf[i, 0]
            g = pf00 * f00 / pp00 if pp00 > 0.0 else 0.0
            m0 = mf[i, 0] + g * (ms0 - mp0)
            ms0 = m0
            out[i] = m0
            continue
        mp0 = f00 * mf[i, 0] + f01 * mf[i, 1]
        mp1 = f10 * mf[i, 0] + f11 * mf[i, 1]
        c00 = pf00 * f00 + pf01 * f01          # C = P_f Φᵀ
        c01 = pf00 * f10 + pf01 * f11
        c10 = pf01 * f00 + pf11 * f01
        c11 = pf01 * f10 + pf11 * f11
        det = pp00 * pp11 - pp01 * pp01
        if det > 0.0:
            i00 = pp11 / det
            i01 = -pp01 / det
            i11 = pp00 / det
        else:
            i00 = i01 = i11 = 0.0
        g00 = c00 * i00 + c01 * i01
        g01 = c00 * i01 + c01 * i11
        g10 = c10 * i00 + c11 * i01
        g11 = c10 * i01 + c11 * i11
        e0 = ms0 - mp0
        e1 = ms1 - mp1
        ms0 = mf[i, 0] + g00 * e0 + g01 * e1
        ms1 = mf[i, 1] + g10 * e0 + g11 * e1
        out[i] = ms0
    return out


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


def log_likelihood(x: np.ndarray, r: np.ndarray, sigma0: float, amplitude: float, length: float,
                   kind: str = "matern32", start: float | None = None) -> float:
    """log N(r | 0, K), K = k(x, x) + σ0² I, exactly in O(n); -inf for invalid hyperparameters.

    amplitude = 0 gives the white (independent) likelihood with sd σ0. ``start``: δ is pinned to
    0 (and its slope to 0, for matern32) there, at or before x[0]; None: stationary δ.
    """
    x = _axis(x)
    r = np.ascontiguousarray(r, dtype=float)
    if r.shape != x.shape:
        raise ValueError(f"residuals {r.shape} and axis {x.shape} differ")
    return float(_loglike(x, r, float(sigma0), float(amplitude), float(length), kernel_code(kind),
                          _gap(x, start)))


def log_likelihood_batch(x: np.ndarray, R: np.ndarray, sigma0: np.ndarray, amplitude: np.ndarray,
                         length: np.ndarray, kind: str = "matern32",
                         start: float | None = None) -> np.ndarray:
    """The log-likelihood of each row of R (k, n) with its own hyperparameters (k,) each; the rows
    run in parallel (numba threads), each one alone, so the result does not depend on threads."""
    x = _axis(x)
    Rt = np.ascontiguousarray(np.atleast_2d(R).T, dtype=float)
    k = Rt.shape[1]
    hyper = [np.ascontiguousarray(np.broadcast_to(np.asarray(v, dtype=float), (k,)))
             for v in (sigma0, amplitude, length)]
    out = np.empty(k)
    _loglike_batch(x, Rt, *hyper, kernel_code(kind), _gap(x, start), out)
    return out


def whiten(x: np.ndarray, V: np.ndarray, sigma0: float, amplitude: float, length: float,
           kind: str = "matern32", start: float | None = None) -> tuple[np.ndarray, float]:
    """(L⁻¹ V, log det K) for K = L Lᵀ = k(x, x) + σ0² I; V (n,) or (n, m). O(n m).

    Generalized least squares with covariance K is ordinary least squares on L⁻¹ y and L⁻¹ X.
    """
    x = _axis(x)
    V = np.asarray(V, dtype=float)
    vec = V.ndim == 1
    V2 = np.ascontiguousarray(V[:, None] if vec else V)
    if V2.shape[0] != x.size:
        raise ValueError(f"{V2.shape[0]} rows for an axis of {x.size} points")
    if not _valid(float(sigma0), float(amplitude), float(length)):
        raise ValueError(f"invalid hyperparameters sigma0 = {sigma0}, amplitude = {amplitude}, "
                         f"length = {length}")
    out = np.empty_like(V2)
    logdet = _filter(x, V2, float(sigma0), float(amplitude), float(length), kernel_code(kind),
                     _gap(x, start), out, np.empty((0, 8)))
    return (out[:, 0] if vec else out), float(logdet)


def posterior_mean(x: np.ndarray, r: np.ndarray, sigma0: float, amplitude: float, length: float,
                   kind: str = "matern32", start: float | None = None) -> np.ndarray:
    """E[δ | r]: the discrepancy the residuals imply (Kalman filter + RTS smoother), O(n)."""
    x = _axis(x)
    r = np.ascontiguousarray(r, dtype=float)
    if amplitude == 0:
        return np.zeros_like(r)
    return _smooth_mean(x, r, float(sigma0), float(amplitude), float(length), kernel_code(kind),
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
