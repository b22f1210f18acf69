"""The log-likelihood of all walkers of an ensemble step in one compiled call.

For each walker: the model stress by the exponential integrator (``kernel.stress_into``, eq. 18;
no basis is formed), the residual r = y - σ(θ) on the compared samples, then

- white: log L = -½ Σ r² / σ0² - n ln σ0 - (n/2) ln 2π (eq. 27 up to constants);
- with the discrepancy: log L = log N(r | 0, k(x, x) + σ0² I), or the orthogonal discrepancy's
  log N(r | 0, C - K V M⁻¹ Vᵀ K), by the Kalman filter of ``lanes.loglike_lanes``
  (inference/discrepancy/lanes.py), the walkers of a group side by side as SIMD lanes.

Walkers run in groups, one group per numba thread (``prange``): as many as a thread gets, up to
``lanes.LANE_GROUP`` (16) side by side in the filter (``lanes.lane_group``). Nothing is summed
across walkers, and a lane's values are its walker's alone, so the result does not depend on the
number of threads or on the groups: a fixed seed gives the same chain with 1 or 2 threads.

numba's on-disk cache keys a function on the content of its own file only, not on the njit
helpers it calls from other modules. ``numba_cache.depend_on`` adds the content of
model/kernel.py and inference/discrepancy/kalman.py and lanes.py to the cache key of
``loglike_walkers``, so an edit there recompiles it instead of loading stale machine code.
"""

from __future__ import annotations

import math

import numpy as np
from numba import get_num_threads, njit, prange

from bayes_dnlr.inference.discrepancy import kalman, lanes
from bayes_dnlr.model import kernel, threads
from bayes_dnlr.numba_cache import depend_on

_LOG_2PI = math.log(2.0 * math.pi)
_lane_group = lanes.lane_group
_stress_into = kernel.stress_into
_lanes = lanes.loglike_lanes


@njit(cache=True)
def _group(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out, lo, hi):
    """Walkers lo..hi-1 of ``loglike_walkers`` (one group, one thread)."""
    n = y.shape[0]
    q = grid[0].shape[0] + 1
    m = hi - lo
    stress = np.empty(q)
    rt = np.empty((n if use_gp else 0, m))
    bad = np.zeros(m, dtype=np.bool_)
    for w in range(m):
        r = lo + w
        ok = _stress_into(theta[r, 0], theta[r, 1], theta[r, 2], theta[r, 3], theta[r, 4],
                          theta[r, 5], grid, stress)
        if not ok:
            bad[w] = True
            continue
        if use_gp:
            finite = True
            for i in range(n):
                v = y[i] - stress[idx[i]]
                rt[i, w] = v
                finite = finite and math.isfinite(v)
            if not finite:
                bad[w] = True
            continue
        s = sig[r]
        if not (s > 0.0 and math.isfinite(s)):
            bad[w] = True
            continue
        rss = 0.0
        for i in range(n):
            v = y[i] - stress[idx[i]]
            rss += v * v
        ll = -0.5 * rss / (s * s) - n * (math.log(s) + 0.5 * _LOG_2PI)
        if math.isfinite(ll):
            out[r] = ll
        else:
            bad[w] = True
    if use_gp:
        for w in range(m):
            if bad[w]:
                for i in range(n):
                    rt[i, w] = 0.0
        _lanes(x, rt, 0, m, sig[lo:hi], amp[lo:hi], length[lo:hi], kind, gap, V, out[lo:hi])
    for w in range(m):
        if bad[w]:
            out[lo + w] = -np.inf


@njit(cache=True, parallel=True)
def loglike_walkers(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out, threads):
    """log-likelihood of every row of theta into ``out`` (k,); -inf where it is not defined.
    Groups of walkers in parallel (numba threads; ``lanes.lane_group``).

    theta (k, 6): E, G, σ_inf, tau_max, tau_max_R, alpha (model units; tau_max_R is
    ignored without a relaxation phase, but must then be positive anyway; alpha is the
    spectrum exponent, ½ for eq. 12); sig, amp, length (k,): σ0 and the
    discrepancy's amplitude and length (amp, length unused when ``use_gp`` is False);
    grid: ``DNLR.kernel_args``; y (n,): the observed values in the order of the axis x;
    idx (n,): the model sample of each of them; kind, gap: the kernel code and the pinned start
    (inf: stationary) of inference/discrepancy/kalman.py; V (n, p): the orthogonality columns in the
    order of x (p = 0: the plain discrepancy); threads: numba's thread count (passed in: a
    function that reads it cannot be cached).
    """
    k = theta.shape[0]
    size = _lane_group(k, threads)
    groups = (k + size - 1) // size
    for g in prange(groups):
        lo = g * size
        _group(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out, lo,
               min(k, lo + size))


@njit(cache=True)
def loglike_walkers_serial(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out):
    """``loglike_walkers`` in the calling thread, the walkers in groups of up to LANE_GROUP (the same
    values): for one thread, and in a process forked from one whose numba threads run on GNU
    OpenMP, where numba terminates a child that starts a parallel region."""
    k = theta.shape[0]
    size = _lane_group(k, 1)
    for lo in range(0, k, size):
        _group(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out, lo,
               min(k, lo + size))


def evaluate(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out) -> None:
    """``loglike_walkers`` when threads may run, else ``loglike_walkers_serial``
    (``model.threads.parallel_allowed``)."""
    if threads.parallel_allowed():
        loglike_walkers(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out,
                        get_num_threads())
    else:
        loglike_walkers_serial(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out)


for _f in (_group, loglike_walkers, loglike_walkers_serial):
    depend_on(_f, kernel, kalman, lanes)
