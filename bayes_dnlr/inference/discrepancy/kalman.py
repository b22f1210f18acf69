"""The Kalman filter of the discrepancy's state model, compiled (the Python API is gp.py).

The residual r = δ + ε, ε ~ N(0, σ0² I), δ a stationary Gaussian process on a sorted axis x with
covariance K = a² K̃ (exp: λ = 1/ℓ; matern32: λ = √3/ℓ; inference/discrepancy/gp.py). Both kernels are linear
stochastic differential equations, so C = K + σ0² I is handled by a Kalman filter in O(n), exactly,
on any sorted grid (Särkkä & Solin 2019, ch. 12): state δ (exp) or (δ, dδ/dx) (matern32),
stationary covariance P∞ = a² or diag(a², a² λ²), and over a step Δ

    exp:       Φ = e^{-λΔ}
    matern32:  Φ = e^{-λΔ} [[1 + λΔ, Δ], [-λ²Δ, 1 - λΔ]]
    predicted covariance P⁻ = Φ (P - P∞) Φᵀ + P∞  (= Φ P Φᵀ + Q, Q = P∞ - Φ P∞ Φᵀ).

The filter's normalised innovations v_i / √S_i are L⁻¹ r for the Cholesky factor L of C in the order
of x. One pass also gives what the orthogonal discrepancy needs (inference/discrepancy/orthogonal.py): for the
columns of V (n, p), D = Vᵀ K C⁻¹ V, μ = Vᵀ K C⁻¹ r and M̃ = Vᵀ K̃ V, each accumulated sample by sample
without cancellation (``_sums``), so that

    log N(r | 0, C - K V M⁻¹ Vᵀ K) = log N(r | 0, C) - ½ μᵀ A⁻¹ μ - ½ log det A + ½ log det M,
    A = σ0² D = M - Vᵀ K C⁻¹ K V,   M = a² M̃,

the likelihood of r given s = Vᵀ δ = 0 (``combine``).

Every operation of the state model is written once, as an inlined helper used by the scalar passes
here and by the SIMD-lane pass of the sampler (inference/discrepancy/lanes.py, whose cache is keyed
on this file too: numba's cache does not see changes in an imported helper of another module).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

KERNELS = {"exp": 0, "matern32": 1}
_LOG_2PI = math.log(2.0 * math.pi)
REFERENCE_RANGE = 0.25   # a step within 0.25/λ of the reference step reuses its exp by a series


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
def decay(lam: float, d: float, d_ref: float, e_ref: float) -> float:
    """e^{-λd} from e_ref = e^{-λ d_ref}, given |λ (d - d_ref)| <= 1/4: the steps of a jittered grid
    differ little, so most steps cost a few multiplications instead of an exp."""
    return e_ref * _series(lam * (d_ref - d))


@njit(cache=True, inline="always")
def transition_e(kind: int, d: float, lam: float, e: float):
    """Φ over a step d as (f00, f01, f10, f11), given e = exp(-λd)."""
    if kind == 0:
        return e, 0.0, 0.0, 0.0
    x = lam * d
    return e * (1.0 + x), e * d, -e * lam * x, e * (1.0 - x)


@njit(cache=True, inline="always")
def _transition(kind: int, d: float, lam: float):
    return transition_e(kind, d, lam, math.exp(-lam * d))


@njit(cache=True, inline="always")
def predict_mean(kind: int, f00, f01, f10, f11, m0, m1):
    """Φ m."""
    if kind == 0:
        return f00 * m0, 0.0
    return f00 * m0 + f01 * m1, f10 * m0 + f11 * m1


@njit(cache=True, inline="always")
def predict_cov(kind: int, f00, f01, f10, f11, p00, p01, p11, q0, q1):
    """P⁻ = Φ (P - P∞) Φᵀ + P∞ with P∞ = diag(q0, q1) (q1 unused for exp)."""
    a00 = p00 - q0
    if kind == 0:
        return f00 * f00 * a00 + q0, 0.0, 0.0
    a01 = p01
    a11 = p11 - q1
    b00 = f00 * a00 + f01 * a01
    b01 = f00 * a01 + f01 * a11
    b10 = f10 * a00 + f11 * a01
    b11 = f10 * a01 + f11 * a11
    return (b00 * f00 + b01 * f01 + q0, b00 * f10 + b01 * f11, b10 * f10 + b11 * f11 + q1)


@njit(cache=True, inline="always")
def update_cov(p00, p01, p11, s2, inv):
    """P - K S Kᵀ after observing δ + ε (S = p00 + σ0², inv = 1/S), written so p00 stays positive."""
    return p00 * s2 * inv, p01 * s2 * inv, p11 - p01 * p01 * inv


@njit(cache=True)
def initial_cov(kind: int, gap: float, lam: float, q0: float, q1: float):
    """The state covariance at the first point: stationary (``gap`` = inf), or that of a process
    pinned to δ = 0 (and δ' = 0) ``gap`` before the first point: P∞ - Φ(gap) P∞ Φ(gap)ᵀ."""
    if not math.isfinite(gap):
        return q0, 0.0, q1
    f00, f01, f10, f11 = _transition(kind, max(gap, 0.0), lam)
    return predict_cov(kind, f00, f01, f10, f11, 0.0, 0.0, 0.0, q0, q1)


@njit(cache=True)
def rate(kind: int, length: float) -> float:
    return 1.0 / length if kind == 0 else math.sqrt(3.0) / length


@njit(cache=True)
def valid(sigma0: float, amplitude: float, length: float) -> bool:
    return (math.isfinite(sigma0) and sigma0 > 0.0 and math.isfinite(amplitude) and amplitude >= 0.0
            and math.isfinite(length) and length > 0.0)


# ------------------------------------------------------------------ whitening and the smoother

@njit(cache=True)
def _filter(x, V, sigma0, amplitude, length, kind, gap, out, store):
    """Kalman filter of every column of V (n, m) with the same gains.

    Writes the normalised innovations (L⁻¹ V) into ``out`` (n, m) and returns log det C. With
    ``store`` (n, 9) of at least n rows, keeps per sample what the smoother needs: the filtered
    covariance (0-2), the predicted covariance (3-5), S (6) and the filtered mean of column 0 (7-8).
    """
    n, m = V.shape
    s2 = sigma0 * sigma0
    lam = rate(kind, length)
    q0 = amplitude * amplitude
    q1 = q0 * lam * lam
    m0 = np.zeros(m)
    m1 = np.zeros(m)
    p00, p01, p11 = initial_cov(kind, gap, lam, q0, q1)
    f00 = f01 = f10 = f11 = 0.0
    logdet = 0.0
    keep = store.shape[0] >= n
    for i in range(n):
        if i > 0:
            f00, f01, f10, f11 = _transition(kind, x[i] - x[i - 1], lam)
            for c in range(m):
                m0[c], m1[c] = predict_mean(kind, f00, f01, f10, f11, m0[c], m1[c])
            p00, p01, p11 = predict_cov(kind, f00, f01, f10, f11, p00, p01, p11, q0, q1)
        s = p00 + s2
        inv = 1.0 / s
        root = math.sqrt(s)
        for c in range(m):
            v = V[i, c] - m0[c]
            out[i, c] = v / root
            m0[c] += p00 * inv * v
            m1[c] += p01 * inv * v
        logdet += math.log(s)
        if keep:
            store[i, 3], store[i, 4], store[i, 5], store[i, 6] = p00, p01, p11, s
        p00, p01, p11 = update_cov(p00, p01, p11, s2, inv)
        if keep:
            store[i, 0], store[i, 1], store[i, 2] = p00, p01, p11
            store[i, 7], store[i, 8] = m0[0], m1[0]
    return logdet


@njit(cache=True)
def _solve(x, V, sigma0, amplitude, length, kind, gap):
    """C⁻¹ V (n, m) = L⁻ᵀ (L⁻¹ V): the filter, then its adjoint run backwards.

    The filter is linear in its input: ν_i = v_i - H m⁻_i, w_i = ν_i / √S_i, m⁺_i = m⁻_i + g_i ν_i
    (g_i = P⁻_i Hᵀ / S_i), m⁻_{i+1} = Φ_{i+1} m⁺_i. Its transpose maps w̄ to v̄ with the adjoint λ of
    m⁻: λ⁺ = Φ_{i+1}ᵀ λ_{i+1}, ν̄ = w̄_i / √S_i + g_iᵀ λ⁺, v̄_i = ν̄, λ_i = λ⁺ - Hᵀ ν̄.
    """
    n, m = V.shape
    store = np.empty((n, 9))
    W = np.empty((n, m))
    _filter(x, V, sigma0, amplitude, length, kind, gap, W, store)
    lam = rate(kind, length)
    out = np.empty((n, m))
    l0 = np.zeros(m)
    l1 = np.zeros(m)
    for i in range(n - 1, -1, -1):
        if i < n - 1:         # λ⁺ = Φ_{i+1}ᵀ λ_{i+1}
            f00, f01, f10, f11 = _transition(kind, x[i + 1] - x[i], lam)
            for c in range(m):
                l0[c], l1[c] = predict_mean(kind, f00, f10, f01, f11, l0[c], l1[c])
        s = store[i, 6]
        g0 = store[i, 3] / s
        g1 = store[i, 4] / s
        root = math.sqrt(s)
        for c in range(m):
            nu = W[i, c] / root + g0 * l0[c] + g1 * l1[c]
            out[i, c] = nu
            l0[c] -= nu
    return out


@njit(cache=True)
def _smooth_mean(x, r, sigma0, amplitude, length, kind, gap):
    """E[δ(x_i) | r] by the Kalman filter and the Rauch-Tung-Striebel smoother."""
    n = x.shape[0]
    store = np.empty((n, 9))
    V = np.empty((n, 1))
    V[:, 0] = r
    _filter(x, V, sigma0, amplitude, length, kind, gap, np.empty((n, 1)), store)
    lam = rate(kind, length)
    out = np.empty(n)
    ms0 = out[n - 1] = store[n - 1, 7]
    ms1 = store[n - 1, 8]
    for i in range(n - 2, -1, -1):
        f00, f01, f10, f11 = _transition(kind, x[i + 1] - x[i], lam)
        mf0, mf1 = store[i, 7], store[i, 8]
        mp0, mp1 = predict_mean(kind, f00, f01, f10, f11, mf0, mf1)
        pf00, pf01, pf11 = store[i, 0], store[i, 1], store[i, 2]
        pp00, pp01, pp11 = store[i + 1, 3], store[i + 1, 4], store[i + 1, 5]
        # smoother gain G = P_f Φᵀ (P⁻_{i+1})⁻¹
        if kind == 0:
            g = pf00 * f00 / pp00 if pp00 > 0.0 else 0.0
            ms0 = mf0 + g * (ms0 - mp0)
            out[i] = ms0
            continue
        c00 = pf00 * f00 + pf01 * f01          # P_f Φᵀ
        c01 = pf00 * f10 + pf01 * f11
        c10 = pf01 * f00 + pf11 * f01
        c11 = pf01 * f10 + pf11 * f11
        det = pp00 * pp11 - pp01 * pp01
        if det > 0.0:
            i00, i01, i11 = pp11 / det, -pp01 / det, pp00 / det
        else:
            i00 = i01 = i11 = 0.0
        e0 = ms0 - mp0
        e1 = ms1 - mp1
        ms0 = mf0 + (c00 * i00 + c01 * i01) * e0 + (c00 * i01 + c01 * i11) * e1
        ms1 = mf1 + (c10 * i00 + c11 * i01) * e0 + (c10 * i01 + c11 * i11) * e1
        out[i] = ms0
    return out


# ------------------------------------------------------------------ the log-likelihood, one residual

@njit(cache=True)
def _sums(x, r, V, sigma0, amplitude, length, kind, gap, D, mu, Mt):
    """One filter pass over r and the columns of V (n, p), p >= 0; returns (rᵀ C⁻¹ r, log det C) and
    fills D = Vᵀ K C⁻¹ V, μ = Vᵀ K C⁻¹ r and M̃ = Vᵀ K̃ V (p, p). With a column's predicted mean m,
    innovation e = v - m and filtered mean g = m + (p⁻/S) e (m_r, e_r those of r), per sample
    v_j v_l - (σ0²/S) e_j e_l = g_j e_l + v_j m_l and v_j r - (σ0²/S) e_j e_r = g_j e_r + v_j m_r:
    terms of the size of the result for any a/σ0 (Vᵀ C⁻¹ V would cancel against Vᵀ V for small a).
    M̃ = Σ p̃_i v_i v_iᵀ + N + Nᵀ, N = Σ v_i z_iᵀ, z_i = Σ_{l<i} k̃(x_i, x_l) v_l =
    Φ_i (z_{i-1} + P̃_{i-1} Hᵀ v_{i-1}), P̃ the unit-amplitude prior state covariance."""
    n = x.shape[0]
    p = V.shape[1]
    s2 = sigma0 * sigma0
    lam = rate(kind, length)
    q0 = amplitude * amplitude
    q1 = q0 * lam * lam
    m0 = m1 = 0.0
    p00, p01, p11 = initial_cov(kind, gap, lam, q0, q1)
    u00, u01, u11 = initial_cov(kind, gap, lam, 1.0, lam * lam)
    mv0 = np.zeros(p)
    mv1 = np.zeros(p)
    z0 = np.zeros(p)
    z1 = np.zeros(p)
    e = np.empty(p)
    mp = np.empty(p)
    D[:, :] = 0.0
    mu[:] = 0.0
    Mt[:, :] = 0.0
    d_ref, e_ref = 0.0, 1.0          # the reference step and its decay e^{-λ d_ref}
    quad = logdet = 0.0
    prod = 1.0
    for i in range(n):
        if i > 0:
            d = x[i] - x[i - 1]
            if abs(d - d_ref) * lam > REFERENCE_RANGE:
                d_ref = d
                e_ref = math.exp(-lam * d)
            f00, f01, f10, f11 = transition_e(kind, d, lam, decay(lam, d, d_ref, e_ref))
            m0, m1 = predict_mean(kind, f00, f01, f10, f11, m0, m1)
            p00, p01, p11 = predict_cov(kind, f00, f01, f10, f11, p00, p01, p11, q0, q1)
            for j in range(p):
                mv0[j], mv1[j] = predict_mean(kind, f00, f01, f10, f11, mv0[j], mv1[j])
                v = V[i - 1, j]
                z0[j], z1[j] = predict_mean(kind, f00, f01, f10, f11, z0[j] + u00 * v, z1[j] + u01 * v)
            u00, u01, u11 = predict_cov(kind, f00, f01, f10, f11, u00, u01, u11, 1.0, lam * lam)
        s = p00 + s2
        inv = 1.0 / s
        c = p00 * inv
        er = r[i] - m0
        quad += er * er * inv
        prod *= s
        if prod > 1e150 or prod < 1e-150:
            logdet += math.log(prod)
            prod = 1.0
        for j in range(p):
            mp[j] = mv0[j]
            e[j] = V[i, j] - mv0[j]
            mv0[j] += c * e[j]
            mv1[j] += p01 * inv * e[j]
            mu[j] += mv0[j] * er + V[i, j] * m0
        for j in range(p):
            for k in range(j + 1):
                D[j, k] += mv0[j] * e[k] + V[i, j] * mp[k]
            for k in range(p):
                Mt[j, k] += V[i, j] * z0[k]
        for j in range(p):
            for k in range(j + 1):        # the diagonal's half: N + Nᵀ doubles it
                Mt[j, k] += (0.5 if k == j else 1.0) * u00 * V[i, j] * V[i, k]
        m0 += c * er
        m1 += p01 * inv * er
        p00, p01, p11 = update_cov(p00, p01, p11, s2, inv)
    logdet += math.log(prod)
    for j in range(p):
        for k in range(j + 1):
            Mt[j, k] = Mt[k, j] = Mt[j, k] + Mt[k, j]
            D[k, j] = D[j, k]
    return quad, logdet


@njit(cache=True)
def _chol_logdet(A) -> float:
    """Cholesky of a small A in place (lower triangle): 2 Σ ln L_jj, nan if not positive definite."""
    p = A.shape[0]
    logdet = 0.0
    for j in range(p):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        if not s > 0.0:
            return math.nan
        root = math.sqrt(s)
        A[j, j] = root
        logdet += 2.0 * math.log(root)
        for i in range(j + 1, p):
            t = A[i, j]
            for k in range(j):
                t -= A[i, k] * A[j, k]
            A[i, j] = t / root
    return logdet


@njit(cache=True)
def combine(quad, logdet, n, D, mu, Mt, s2, q0, A, M, z) -> float:
    """log N(r | 0, C - K V M⁻¹ Vᵀ K) from the sums of ``_sums`` (p = 0 or a = 0: log N(r | 0, C));
    A, M (p, p) and z (p) are work arrays. -inf when A or M is not positive definite."""
    plain = -0.5 * (quad + logdet + n * _LOG_2PI)
    p = mu.shape[0]
    if p == 0 or q0 == 0.0:
        return plain
    for j in range(p):
        for k in range(p):
            A[j, k] = s2 * D[j, k]
            M[j, k] = q0 * Mt[j, k]
    ld_a = _chol_logdet(A)
    ld_m = _chol_logdet(M)
    if not (math.isfinite(ld_a) and math.isfinite(ld_m)):
        return -np.inf
    quad_s = 0.0
    for j in range(p):                 # z = L_A⁻¹ μ
        t = mu[j]
        for k in range(j):
            t -= A[j, k] * z[k]
        z[j] = t / A[j, j]
        quad_s += z[j] * z[j]
    return plain - 0.5 * quad_s - 0.5 * ld_a + 0.5 * ld_m


@njit(cache=True)
def loglike(x, r, V, sigma0, amplitude, length, kind, gap) -> float:
    """log N(r | 0, C), or with p = V.shape[1] > 0 columns the orthogonal likelihood
    log N(r | 0, C - K V M⁻¹ Vᵀ K); -inf for invalid hyperparameters. One filter pass, a divide per
    sample, and log det C taken as a product that is logged when it leaves [1e-150, 1e150]."""
    if not valid(sigma0, amplitude, length):
        return -np.inf
    p = V.shape[1]
    D = np.empty((p, p))
    Mt = np.empty((p, p))
    mu = np.empty(p)
    quad, logdet = _sums(x, r, V, sigma0, amplitude, length, kind, gap, D, mu, Mt)
    return combine(quad, logdet, x.shape[0], D, mu, Mt, sigma0 * sigma0, amplitude * amplitude,
                    np.empty((p, p)), np.empty((p, p)), np.empty(p))
