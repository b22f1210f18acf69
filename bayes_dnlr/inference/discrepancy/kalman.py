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

the likelihood of r given s = Vᵀ δ = 0 (``_combine``).

Every operation of the state model is written once, as an inlined helper used by the scalar passes
and by the SIMD-lane pass of the sampler. All compiled functions live in this one module (numba's
cache does not see changes in an imported helper of another module).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

KERNELS = {"exp": 0, "matern32": 1}
_LOG_2PI = math.log(2.0 * math.pi)
_REF = 0.25          # a step within 0.25/λ of the reference step reuses its exp by a series
LANE_GROUP = 16      # the most walkers side by side in one filter (one thread)
_NCF = 8             # per-sample lane coefficients of the orthogonal sums


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
def _decay(lam: float, d: float, d_ref: float, e_ref: float) -> float:
    """e^{-λd} from e_ref = e^{-λ d_ref}, given |λ (d - d_ref)| <= 1/4: the steps of a jittered grid
    differ little, so most steps cost a few multiplications instead of an exp."""
    return e_ref * _series(lam * (d_ref - d))


@njit(cache=True, inline="always")
def _transition_e(kind: int, d: float, lam: float, e: float):
    """Φ over a step d as (f00, f01, f10, f11), given e = exp(-λd)."""
    if kind == 0:
        return e, 0.0, 0.0, 0.0
    x = lam * d
    return e * (1.0 + x), e * d, -e * lam * x, e * (1.0 - x)


@njit(cache=True, inline="always")
def _transition(kind: int, d: float, lam: float):
    return _transition_e(kind, d, lam, math.exp(-lam * d))


@njit(cache=True, inline="always")
def _predict_mean(kind: int, f00, f01, f10, f11, m0, m1):
    """Φ m."""
    if kind == 0:
        return f00 * m0, 0.0
    return f00 * m0 + f01 * m1, f10 * m0 + f11 * m1


@njit(cache=True, inline="always")
def _predict_cov(kind: int, f00, f01, f10, f11, p00, p01, p11, q0, q1):
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
def _update_cov(p00, p01, p11, s2, inv):
    """P - K S Kᵀ after observing δ + ε (S = p00 + σ0², inv = 1/S), written so p00 stays positive."""
    return p00 * s2 * inv, p01 * s2 * inv, p11 - p01 * p01 * inv


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


@njit(cache=True)
def _valid(sigma0: float, amplitude: float, length: float) -> bool:
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
    lam = _rate(kind, length)
    q0 = amplitude * amplitude
    q1 = q0 * lam * lam
    m0 = np.zeros(m)
    m1 = np.zeros(m)
    p00, p01, p11 = _initial_cov(kind, gap, lam, q0, q1)
    f00 = f01 = f10 = f11 = 0.0
    logdet = 0.0
    keep = store.shape[0] >= n
    for i in range(n):
        if i > 0:
            f00, f01, f10, f11 = _transition(kind, x[i] - x[i - 1], lam)
            for c in range(m):
                m0[c], m1[c] = _predict_mean(kind, f00, f01, f10, f11, m0[c], m1[c])
            p00, p01, p11 = _predict_cov(kind, f00, f01, f10, f11, p00, p01, p11, q0, q1)
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
        p00, p01, p11 = _update_cov(p00, p01, p11, s2, inv)
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
    lam = _rate(kind, length)
    out = np.empty((n, m))
    l0 = np.zeros(m)
    l1 = np.zeros(m)
    for i in range(n - 1, -1, -1):
        if i < n - 1:         # λ⁺ = Φ_{i+1}ᵀ λ_{i+1}
            f00, f01, f10, f11 = _transition(kind, x[i + 1] - x[i], lam)
            for c in range(m):
                l0[c], l1[c] = _predict_mean(kind, f00, f10, f01, f11, l0[c], l1[c])
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
    lam = _rate(kind, length)
    out = np.empty(n)
    ms0 = out[n - 1] = store[n - 1, 7]
    ms1 = store[n - 1, 8]
    for i in range(n - 2, -1, -1):
        f00, f01, f10, f11 = _transition(kind, x[i + 1] - x[i], lam)
        mf0, mf1 = store[i, 7], store[i, 8]
        mp0, mp1 = _predict_mean(kind, f00, f01, f10, f11, mf0, mf1)
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
    lam = _rate(kind, length)
    q0 = amplitude * amplitude
    q1 = q0 * lam * lam
    m0 = m1 = 0.0
    p00, p01, p11 = _initial_cov(kind, gap, lam, q0, q1)
    u00, u01, u11 = _initial_cov(kind, gap, lam, 1.0, lam * lam)
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
            if abs(d - d_ref) * lam > _REF:
                d_ref = d
                e_ref = math.exp(-lam * d)
            f00, f01, f10, f11 = _transition_e(kind, d, lam, _decay(lam, d, d_ref, e_ref))
            m0, m1 = _predict_mean(kind, f00, f01, f10, f11, m0, m1)
            p00, p01, p11 = _predict_cov(kind, f00, f01, f10, f11, p00, p01, p11, q0, q1)
            for j in range(p):
                mv0[j], mv1[j] = _predict_mean(kind, f00, f01, f10, f11, mv0[j], mv1[j])
                v = V[i - 1, j]
                z0[j], z1[j] = _predict_mean(kind, f00, f01, f10, f11, z0[j] + u00 * v, z1[j] + u01 * v)
            u00, u01, u11 = _predict_cov(kind, f00, f01, f10, f11, u00, u01, u11, 1.0, lam * lam)
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
        p00, p01, p11 = _update_cov(p00, p01, p11, s2, inv)
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
def _combine(quad, logdet, n, D, mu, Mt, s2, q0, A, M, z) -> float:
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
def _loglike(x, r, V, sigma0, amplitude, length, kind, gap) -> float:
    """log N(r | 0, C), or with p = V.shape[1] > 0 columns the orthogonal likelihood
    log N(r | 0, C - K V M⁻¹ Vᵀ K); -inf for invalid hyperparameters. One filter pass, a divide per
    sample, and log det C taken as a product that is logged when it leaves [1e-150, 1e150]."""
    if not _valid(sigma0, amplitude, length):
        return -np.inf
    p = V.shape[1]
    D = np.empty((p, p))
    Mt = np.empty((p, p))
    mu = np.empty(p)
    quad, logdet = _sums(x, r, V, sigma0, amplitude, length, kind, gap, D, mu, Mt)
    return _combine(quad, logdet, x.shape[0], D, mu, Mt, sigma0 * sigma0, amplitude * amplitude,
                    np.empty((p, p)), np.empty((p, p)), np.empty(p))


# ------------------------------------------------------------------ many residuals: SIMD lanes

_LANES = dict(cache=True, fastmath={"contract", "nsz", "arcp"}, error_model="numpy")


@njit(**_LANES)
def _columns_predict(kind, k, V, i, cf, mv0, mv1, z0, z1, u00, u01):
    """The columns' predicted means and M̃'s z over the step to sample i, every lane (``_sums``)."""
    for j in range(V.shape[1]):
        v = V[i - 1, j]
        for w in range(k):
            mv0[j, w], mv1[j, w] = _predict_mean(kind, cf[0, w], cf[1, w], cf[2, w], cf[3, w],
                                                 mv0[j, w], mv1[j, w])
            z0[j, w], z1[j, w] = _predict_mean(kind, cf[0, w], cf[1, w], cf[2, w], cf[3, w],
                                               z0[j, w] + u00[w] * v, z1[j, w] + u01[w] * v)


@njit(**_LANES)
def _columns_observe(k, V, i, cf, mv0, mv1, mp, ev, mu):
    """The columns' innovations and filtered means at sample i, and μ's terms (``_sums``)."""
    for j in range(V.shape[1]):
        vj = V[i, j]
        for w in range(k):
            mp[j, w] = mv0[j, w]
            ev[j, w] = vj - mv0[j, w]
            mv0[j, w] += cf[4, w] * ev[j, w]
            mv1[j, w] += cf[5, w] * ev[j, w]
            mu[j, w] += mv0[j, w] * cf[6, w] + vj * cf[7, w]


@njit(**_LANES)
def _columns_pairs(k, V, i, mv0, mp, ev, z0, D, N, pinned, u00):
    """D's and N's terms at sample i, every lane (``_sums``)."""
    p = V.shape[1]
    for j in range(p):
        vj = V[i, j]
        for q in range(j + 1):
            for w in range(k):
                D[j * p + q, w] += mv0[j, w] * ev[q, w] + vj * mp[q, w]
        for q in range(p):
            for w in range(k):
                N[j * p + q, w] += vj * z0[q, w]
        if pinned:                     # the prior variance varies: Σ p̃ v vᵀ by lane
            for q in range(j + 1):
                h = (0.5 if q == j else 1.0) * vj * V[i, q]
                for w in range(k):
                    N[j * p + q, w] += h * u00[w]


@njit(**_LANES)
def loglike_lanes(x, Rt, lo, hi, sigma0, amplitude, length, kind, gap, V, out):
    """``_loglike`` of the walkers lo..hi-1 side by side, one SIMD lane each.

    Rt (n, k): residuals, one column per walker (time-major, so a step's lanes are contiguous);
    V (n, p): the columns of the orthogonality constraint, the same for every walker (p = 0: the
    plain likelihood). Walkers are independent, so the compiler vectorises the inner loops over
    them and the filter's division latency overlaps: about 6x faster per walker than one filter
    at a time. Writes out[lo:hi]; -inf for invalid hyperparameters. Each lane's arithmetic is the
    same whatever the other lanes hold, so results do not depend on how walkers are grouped.
    log det C accumulates as a product per lane, logged every 64 samples; a lane whose product
    under- or overflows (innovation variances far from 1 for 64 samples, e.g. matern32 far above
    the white noise) is recomputed by ``_loglike``, which rescales as it goes.
    """
    cols = V.shape[1] > 0
    if kind == 0:     # the kernel and the columns as constants: their branches fold out of the loops
        if cols:
            _lanes(0, True, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out)
        else:
            _lanes(0, False, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out)
    elif cols:
        _lanes(1, True, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out)
    else:
        _lanes(1, False, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out)


@njit(inline="always", **_LANES)
def _lanes(kind, cols, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out):
    n = Rt.shape[0]
    k = hi - lo
    p = V.shape[1] if cols else 0
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
    d_ref = np.zeros(k)      # each lane's reference step (0 to start) and its e^{-λ d_ref}
    e_ref = np.ones(k)
    d_lo, d_hi = 0.0, -1.0   # steps that keep every lane's reference (none yet)
    ok = np.empty(k, dtype=np.bool_)
    exact = np.ones(k, dtype=np.bool_)    # False: the lane's product left the normal range
    # the orthogonal sums of ``_sums`` (cols): per sample the lanes' transition, gains, and the
    # residual's predicted mean and innovation; per column its means, innovation and z; the sums
    cf = np.empty((_NCF, k))
    mv0 = np.zeros((p, k))
    mv1 = np.zeros((p, k))
    mp = np.empty((p, k))
    ev = np.empty((p, k))
    z0 = np.zeros((p, k))
    z1 = np.zeros((p, k))
    u00 = np.empty(k)
    u01 = np.empty(k)
    u11 = np.empty(k)
    D = np.zeros((p * p, k))
    N = np.zeros((p * p, k))
    mu = np.zeros((p, k))
    pinned = math.isfinite(gap)
    for w in range(k):
        ok[w] = _valid(sigma0[lo + w], amplitude[lo + w], length[lo + w])
        ln = length[lo + w] if ok[w] else 1.0
        lam[w] = _rate(kind, ln)
        s2[w] = sigma0[lo + w] ** 2 if ok[w] else 1.0
        q0[w] = amplitude[lo + w] ** 2 if ok[w] else 0.0
        q1[w] = q0[w] * lam[w] * lam[w]
        p00[w], p01[w], p11[w] = _initial_cov(kind, gap, lam[w], q0[w], q1[w])
        u00[w], u01[w], u11[w] = _initial_cov(kind, gap, lam[w], 1.0, lam[w] * lam[w])
    for i in range(n):
        if i > 0:
            d = x[i] - x[i - 1]
            # a lane whose step left its reference step's range takes this one (one exp), as
            # ``_sums`` does, so that each lane's values are those of its walker alone, whatever
            # the other lanes hold. [d_lo, d_hi], inside every lane's range with a margin, spares
            # the lanes' test on most steps
            if not d_lo <= d <= d_hi:
                d_lo, d_hi = -np.inf, np.inf
                for w in range(k):
                    if abs(d - d_ref[w]) * lam[w] > _REF:
                        d_ref[w] = d
                        e_ref[w] = math.exp(-lam[w] * d)
                    half = _REF / lam[w] * (1.0 - 1e-9)
                    d_lo = max(d_lo, d_ref[w] - half)
                    d_hi = min(d_hi, d_ref[w] + half)
            for w in range(k):
                a00, a01, a10, a11 = _transition_e(kind, d, lam[w],
                                                   _decay(lam[w], d, d_ref[w], e_ref[w]))
                if kind == 0:      # one state: m1, p01, p11 stay 0
                    m0[w] = _predict_mean(kind, a00, a01, a10, a11, m0[w], 0.0)[0]
                    p00[w] = _predict_cov(kind, a00, a01, a10, a11, p00[w], 0.0, 0.0, q0[w], 0.0)[0]
                else:
                    m0[w], m1[w] = _predict_mean(kind, a00, a01, a10, a11, m0[w], m1[w])
                    p00[w], p01[w], p11[w] = _predict_cov(kind, a00, a01, a10, a11,
                                                          p00[w], p01[w], p11[w], q0[w], q1[w])
                if cols:
                    cf[0, w], cf[1, w], cf[2, w], cf[3, w] = a00, a01, a10, a11
            if cols:
                _columns_predict(kind, k, V, i, cf, mv0, mv1, z0, z1, u00, u01)
            if cols and pinned:
                for w in range(k):
                    u00[w], u01[w], u11[w] = _predict_cov(kind, cf[0, w], cf[1, w], cf[2, w], cf[3, w],
                                                          u00[w], u01[w], u11[w], 1.0, lam[w] * lam[w])
        for w in range(k):
            s = p00[w] + s2[w]
            inv = 1.0 / s
            v = Rt[i, lo + w] - m0[w]
            quad[w] += v * v * inv
            prod[w] *= s
            c = p00[w] * inv
            if cols:
                cf[4, w], cf[5, w], cf[6, w], cf[7, w] = c, p01[w] * inv, v, m0[w]
            m0[w] += c * v
            if kind == 0:
                p00[w] = p00[w] * s2[w] * inv
            else:
                m1[w] += p01[w] * inv * v
                p00[w], p01[w], p11[w] = _update_cov(p00[w], p01[w], p11[w], s2[w], inv)
        if cols:
            _columns_observe(k, V, i, cf, mv0, mv1, mp, ev, mu)
            _columns_pairs(k, V, i, mv0, mp, ev, z0, D, N, pinned, u00)
        if i % 64 == 63:                                 # log det C, without a log per sample
            for w in range(k):
                exact[w] = exact[w] and 1e-290 < prod[w] < 1e290
                logdet[w] += math.log(prod[w])
                prod[w] = 1.0
    Dw = np.empty((p, p))
    Mw = np.empty((p, p))
    A = np.empty((p, p))
    M = np.empty((p, p))
    zw = np.empty(p)
    muw = np.empty(p)
    vv = np.zeros((p, p))      # Σ v vᵀ: the unit prior variance's share of M̃ when stationary
    if not pinned:
        for i in range(n):
            for j in range(p):
                for q in range(j + 1):
                    vv[j, q] += V[i, j] * V[i, q]
    for w in range(k):
        ll = -np.inf
        if ok[w] and exact[w] and 1e-290 < prod[w] < 1e290:
            for j in range(p):
                muw[j] = mu[j, w]
                for q in range(j + 1):
                    Dw[j, q] = Dw[q, j] = D[j * p + q, w]
                    Mw[j, q] = Mw[q, j] = N[j * p + q, w] + N[q * p + j, w] + vv[j, q]
            ll = _combine(quad[w], logdet[w] + math.log(prod[w]), n, Dw, muw, Mw, s2[w], q0[w],
                          A, M, zw)
        elif ok[w]:
            ll = _loglike(x, Rt[:, lo + w], V, sigma0[lo + w], amplitude[lo + w], length[lo + w],
                          kind, gap)
        out[lo + w] = ll if ok[w] and math.isfinite(ll) else -np.inf


@njit(cache=True)
def lane_group(k: int, threads: int) -> int:
    """Walkers per group when k walkers are shared by ``threads`` threads: as many lanes as a
    thread gets, up to LANE_GROUP. The filter's steps are a chain of dependent operations (the
    division of one step waits for the last), so a filter runs about as fast with 16 lanes as
    with 8: one thread takes all of them, two take half each. The values do not depend on it."""
    per_thread = (k + threads - 1) // max(threads, 1)
    return max(1, min(LANE_GROUP, per_thread))


@njit(cache=True, parallel=True)
def loglike_batch(x, Rt, sigma0, amplitude, length, kind, gap, V, out, threads):
    """``loglike_lanes`` over all columns of Rt, in groups (``lane_group``) over ``threads``
    threads (numba's count, passed in: a function that reads it cannot be cached)."""
    k = Rt.shape[1]
    size = lane_group(k, threads)
    groups = (k + size - 1) // size
    for g in prange(groups):
        lo = g * size
        loglike_lanes(x, Rt, lo, min(k, lo + size), sigma0, amplitude, length, kind, gap, V, out)
