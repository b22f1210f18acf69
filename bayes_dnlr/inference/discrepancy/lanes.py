"""The discrepancy's Kalman filter for many residuals at once: one SIMD lane per walker.

The sampler evaluates the likelihood of every walker of an ensemble step in one compiled call
(inference/posterior/fused.py). Walkers are independent, so the filter of inference/discrepancy/
kalman.py runs for a group of them side by side: the compiler vectorises the inner loops over the
lanes and the filter's division latency overlaps. Each lane's arithmetic is its walker's alone,
whatever the other lanes hold, so the values do not depend on how walkers are grouped.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from bayes_dnlr.inference.discrepancy import kalman
from bayes_dnlr.inference.discrepancy.kalman import (
    REFERENCE_RANGE,
    combine,
    decay,
    initial_cov,
    loglike,
    predict_cov,
    predict_mean,
    rate,
    transition_e,
    update_cov,
    valid,
)
from bayes_dnlr.numba_cache import depend_on

LANE_GROUP = 16      # the most walkers side by side in one filter (one thread)
_NCF = 8             # per-sample lane coefficients of the orthogonal sums
# no fast-math: with it, LLVM contracted or reordered the filter's arithmetic differently in the
# parallel function and in the one-thread one (a forked child's), and their values differed in the
# last bit; strict IEEE arithmetic gives the same value on every path
_LANES = dict(cache=True, error_model="numpy")


@njit(**_LANES)
def _columns_predict(kind, k, V, i, cf, mv0, mv1, z0, z1, u00, u01):
    """The columns' predicted means and M̃'s z over the step to sample i, every lane (``kalman._sums``)."""
    for j in range(V.shape[1]):
        v = V[i - 1, j]
        for w in range(k):
            mv0[j, w], mv1[j, w] = predict_mean(kind, cf[0, w], cf[1, w], cf[2, w], cf[3, w],
                                                 mv0[j, w], mv1[j, w])
            z0[j, w], z1[j, w] = predict_mean(kind, cf[0, w], cf[1, w], cf[2, w], cf[3, w],
                                               z0[j, w] + u00[w] * v, z1[j, w] + u01[w] * v)


@njit(**_LANES)
def _columns_observe(k, V, i, cf, mv0, mv1, mp, ev, mu):
    """The columns' innovations and filtered means at sample i, and μ's terms (``kalman._sums``)."""
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
    """D's and N's terms at sample i, every lane (``kalman._sums``)."""
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


# One compiled function per kernel, with or without the orthogonality columns: the kernel and the
# columns are constants in each, so their branches fold out of the loops, and each is compiled
# the first time it is used (a run needs one of the four: compiling all took 18-23 s).

@njit(**_LANES)
def _lanes_exp(x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out):
    _lanes(0, False, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out)


@njit(**_LANES)
def _lanes_matern32(x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out):
    _lanes(1, False, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out)


@njit(**_LANES)
def _lanes_exp_columns(x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out):
    _lanes(0, True, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out)


@njit(**_LANES)
def _lanes_matern32_columns(x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out):
    _lanes(1, True, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out)


@njit(inline="always", **_LANES)
def _lanes(kind, cols, x, Rt, lo, hi, sigma0, amplitude, length, gap, V, out):
    """``loglike`` of the walkers lo..hi-1 side by side, one SIMD lane each.

    Rt (n, k): residuals, one column per walker (time-major, so a step's lanes are contiguous);
    V (n, p): the columns of the orthogonality constraint, the same for every walker (p = 0: the
    plain likelihood). Walkers are independent, so the compiler vectorises the inner loops over
    them and the filter's division latency overlaps: about 6x faster per walker than one filter
    at a time. Writes out[lo:hi]; -inf for invalid hyperparameters. Each lane's arithmetic is the
    same whatever the other lanes hold, so results do not depend on how walkers are grouped.
    log det C accumulates as a product per lane, logged every 64 samples; a lane whose product
    under- or overflows (innovation variances far from 1 for 64 samples, e.g. matern32 far above
    the white noise) is recomputed by ``loglike``, which rescales as it goes.
    """
    n = Rt.shape[0]
    # the kernel code as a plain integer for the compiled functions called here: as the constant
    # ``kind`` it would be a type of its own, and they would be compiled once more for it
    code = np.int64(kind)
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
    # the orthogonal sums of ``kalman._sums`` (cols): per sample the lanes' transition, gains, and the
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
        ok[w] = valid(sigma0[lo + w], amplitude[lo + w], length[lo + w])
        ln = length[lo + w] if ok[w] else 1.0
        lam[w] = rate(code, ln)
        s2[w] = sigma0[lo + w] ** 2 if ok[w] else 1.0
        q0[w] = amplitude[lo + w] ** 2 if ok[w] else 0.0
        q1[w] = q0[w] * lam[w] * lam[w]
        p00[w], p01[w], p11[w] = initial_cov(code, gap, lam[w], q0[w], q1[w])
        u00[w], u01[w], u11[w] = initial_cov(code, gap, lam[w], 1.0, lam[w] * lam[w])
    for i in range(n):
        if i > 0:
            d = x[i] - x[i - 1]
            # a lane whose step left its reference step's range takes this one (one exp), as
            # ``kalman._sums`` does, so that each lane's values are those of its walker alone, whatever
            # the other lanes hold. [d_lo, d_hi], inside every lane's range with a margin, spares
            # the lanes' test on most steps
            if not d_lo <= d <= d_hi:
                d_lo, d_hi = -np.inf, np.inf
                for w in range(k):
                    if abs(d - d_ref[w]) * lam[w] > REFERENCE_RANGE:
                        d_ref[w] = d
                        e_ref[w] = math.exp(-lam[w] * d)
                    half = REFERENCE_RANGE / lam[w] * (1.0 - 1e-9)
                    d_lo = max(d_lo, d_ref[w] - half)
                    d_hi = min(d_hi, d_ref[w] + half)
            for w in range(k):
                a00, a01, a10, a11 = transition_e(kind, d, lam[w],
                                                   decay(lam[w], d, d_ref[w], e_ref[w]))
                if kind == 0:      # one state: m1, p01, p11 stay 0
                    m0[w] = predict_mean(kind, a00, a01, a10, a11, m0[w], 0.0)[0]
                    p00[w] = predict_cov(kind, a00, a01, a10, a11, p00[w], 0.0, 0.0, q0[w], 0.0)[0]
                else:
                    m0[w], m1[w] = predict_mean(kind, a00, a01, a10, a11, m0[w], m1[w])
                    p00[w], p01[w], p11[w] = predict_cov(kind, a00, a01, a10, a11,
                                                          p00[w], p01[w], p11[w], q0[w], q1[w])
                if cols:
                    cf[0, w], cf[1, w], cf[2, w], cf[3, w] = a00, a01, a10, a11
            if cols:
                _columns_predict(kind, k, V, i, cf, mv0, mv1, z0, z1, u00, u01)
            if cols and pinned:
                for w in range(k):
                    u00[w], u01[w], u11[w] = predict_cov(kind, cf[0, w], cf[1, w], cf[2, w], cf[3, w],
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
                p00[w], p01[w], p11[w] = update_cov(p00[w], p01[w], p11[w], s2[w], inv)
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
            ll = combine(quad[w], logdet[w] + math.log(prod[w]), n, Dw, muw, Mw, s2[w], q0[w],
                          A, M, zw)
        elif ok[w]:
            # a contiguous copy: the residual's type is then the one gp.log_likelihood compiles
            ll = loglike(x, np.ascontiguousarray(Rt[:, lo + w]), V, sigma0[lo + w],
                         amplitude[lo + w], length[lo + w], code, gap)
        out[lo + w] = ll if ok[w] and math.isfinite(ll) else -np.inf


def lane_group(k: int, threads: int) -> int:
    """Walkers per group when k walkers are shared by ``threads`` threads: as many lanes as a
    thread gets, up to LANE_GROUP. The filter's steps are a chain of dependent operations (the
    division of one step waits for the last), so a filter runs about as fast with 16 lanes as
    with 8: one thread takes all of them, two take half each. The values do not depend on it."""
    per_thread = (k + threads - 1) // max(threads, 1)
    return max(1, min(LANE_GROUP, per_thread))


@njit(cache=True, parallel=True)
def _groups_exp(x, Rt, sigma0, amplitude, length, gap, V, out, size):
    for g in prange((Rt.shape[1] + size - 1) // size):
        lo = g * size
        _lanes_exp(x, Rt, lo, min(Rt.shape[1], lo + size), sigma0, amplitude, length, gap, V, out)


@njit(cache=True, parallel=True)
def _groups_matern32(x, Rt, sigma0, amplitude, length, gap, V, out, size):
    for g in prange((Rt.shape[1] + size - 1) // size):
        lo = g * size
        _lanes_matern32(x, Rt, lo, min(Rt.shape[1], lo + size), sigma0, amplitude, length, gap, V,
                        out)


@njit(cache=True, parallel=True)
def _groups_exp_columns(x, Rt, sigma0, amplitude, length, gap, V, out, size):
    for g in prange((Rt.shape[1] + size - 1) // size):
        lo = g * size
        _lanes_exp_columns(x, Rt, lo, min(Rt.shape[1], lo + size), sigma0, amplitude, length, gap,
                           V, out)


@njit(cache=True, parallel=True)
def _groups_matern32_columns(x, Rt, sigma0, amplitude, length, gap, V, out, size):
    for g in prange((Rt.shape[1] + size - 1) // size):
        lo = g * size
        _lanes_matern32_columns(x, Rt, lo, min(Rt.shape[1], lo + size), sigma0, amplitude, length,
                                gap, V, out)


# (kernel code, with columns) -> (one group in this thread, groups over numba's threads)
_VARIANTS = {(0, False): (_lanes_exp, _groups_exp), (1, False): (_lanes_matern32, _groups_matern32),
             (0, True): (_lanes_exp_columns, _groups_exp_columns),
             (1, True): (_lanes_matern32_columns, _groups_matern32_columns)}


def loglike_groups(x, Rt, sigma0, amplitude, length, kind, gap, V, out, threads: int) -> None:
    """``kalman.loglike`` of every column of Rt (n, k), with each walker's σ0, amplitude and length
    (k,), into ``out`` (k,): groups of ``lane_group(k, threads)`` walkers side by side, over numba's
    threads when ``threads`` > 1 (the caller says whether threads may run here:
    ``model.threads.parallel_allowed``). -inf for invalid hyperparameters."""
    one, groups = _VARIANTS[(int(kind), V.shape[1] > 0)]
    k = Rt.shape[1]
    size = lane_group(k, threads)
    if threads > 1:         # also for one group: the other function need not be compiled
        groups(x, Rt, sigma0, amplitude, length, gap, V, out, size)
        return
    for lo in range(0, k, size):
        one(x, Rt, lo, min(k, lo + size), sigma0, amplitude, length, gap, V, out)


for _f in (_columns_predict, _columns_observe, _columns_pairs, *(f for pair in _VARIANTS.values()
                                                                 for f in pair)):
    depend_on(_f, kalman)
