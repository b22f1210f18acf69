"""The log-likelihood of all walkers of an ensemble step in two compiled calls.

For each walker: the model stress by the exponential integrator (``kernel.stress_into``, eq. 18;
no basis is formed), the residual r = y - σ(θ) on the compared samples, then

- white: log L = -½ Σ r² / σ0² - n ln σ0 - (n/2) ln 2π (eq. 27 up to constants), in the same call;
- with the discrepancy: log L = log N(r | 0, k(x, x) + σ0² I), or the orthogonal discrepancy's
  log N(r | 0, C - K V M⁻¹ Vᵀ K), by the Kalman filter of the second call,
  ``lanes.loglike_groups`` (inference/discrepancy/lanes.py), the walkers of a group side by side
  as SIMD lanes. Kept apart, each of the filter's variants (kernel, columns) is compiled only when
  a run uses it, and is not compiled again into the model's call.

Walkers run in groups, one group per numba thread (``prange``): as many as a thread gets, up to
``lanes.LANE_GROUP`` (16) side by side in the filter (``lanes.lane_group``). Nothing is summed
across walkers, and a lane's values are its walker's alone, so the result does not depend on the
number of threads or on the groups: a fixed seed gives the same chain with 1 or 2 threads.

numba's on-disk cache keys a function on the content of its own file only, not on the njit
helpers it calls from other modules. ``numba_cache.depend_on`` adds the content of
model/kernel.py to the cache key of the functions here (and lanes.py adds kalman.py's to its
own), so an edit there recompiles them instead of loading stale machine code.
"""

from __future__ import annotations

import math

import numpy as np
from numba import get_num_threads, njit, prange

from bayes_dnlr.inference.discrepancy import lanes
from bayes_dnlr.model import kernel, reduced_time, threads
from bayes_dnlr.numba_cache import depend_on

_LOG_2PI = math.log(2.0 * math.pi)
_stress_into = kernel.stress_into
_stress_shift_into = reduced_time.stress_shift_into


@njit(cache=True, inline="always")
def _walker(r, ok, stress, sig, y, idx, use_gp, out, rt, bad):
    """Walker r whose model stress is ``stress`` (``ok``: the model was defined): with the
    discrepancy its residuals into rt's column (zeros for a walker whose model fails), white its
    log-likelihood into ``out``; ``bad`` where the log-likelihood is not defined."""
    n = y.shape[0]
    if not ok:
        bad[r] = True
    elif use_gp:
        finite = True
        for i in range(n):
            v = y[i] - stress[idx[i]]
            rt[i, r] = v
            finite = finite and math.isfinite(v)
        bad[r] = not finite
    else:
        s = sig[r]
        if not (s > 0.0 and math.isfinite(s)):
            bad[r] = True
            return
        rss = 0.0
        for i in range(n):
            v = y[i] - stress[idx[i]]
            rss += v * v
        ll = -0.5 * rss / (s * s) - n * (math.log(s) + 0.5 * _LOG_2PI)
        out[r] = ll
        bad[r] = not math.isfinite(ll)
    if bad[r] and use_gp:
        for i in range(n):
            rt[i, r] = 0.0


@njit(cache=True)
def _group(theta, sig, grid, y, idx, use_gp, out, rt, bad, lo, hi):
    """Walkers lo..hi-1 (one group, one thread): the model stress of each, then ``_walker``."""
    q = grid[0].shape[0] + 1
    stress = np.empty(q)
    for r in range(lo, hi):
        ok = _stress_into(theta[r, 0], theta[r, 1], theta[r, 2], theta[r, 3], theta[r, 4],
                          theta[r, 5], grid, stress)
        _walker(r, ok, stress, sig, y, idx, use_gp, out, rt, bad)


@njit(cache=True)
def _group_shift(theta, ln_at, driving, sig, grid, y, idx, use_gp, out, rt, bad, lo, hi):
    """``_group`` for the shifted model (``kernel.stress_shift_into``): theta (k, 7) with sigma_s
    last, ln_at (k, q-1) or (k, 0)."""
    q = grid[0].shape[0] + 1
    stress = np.empty(q)
    for r in range(lo, hi):
        ok = _stress_shift_into(theta[r, 0], theta[r, 1], theta[r, 2], theta[r, 3], theta[r, 4],
                                theta[r, 5], theta[r, 6], driving, ln_at[r], grid, stress)
        _walker(r, ok, stress, sig, y, idx, use_gp, out, rt, bad)


@njit(cache=True, parallel=True)
def model_walkers_shift(theta, ln_at, driving, sig, grid, y, idx, use_gp, out, rt, bad, size):
    """``model_walkers`` for the shifted model (``_group_shift``)."""
    k = theta.shape[0]
    for g in prange((k + size - 1) // size):
        lo = g * size
        _group_shift(theta, ln_at, driving, sig, grid, y, idx, use_gp, out, rt, bad, lo,
                     min(k, lo + size))


@njit(cache=True)
def model_walkers_shift_serial(theta, ln_at, driving, sig, grid, y, idx, use_gp, out, rt, bad,
                               size):
    """``model_walkers_shift`` in the calling thread (``model_walkers_serial``)."""
    k = theta.shape[0]
    for lo in range(0, k, size):
        _group_shift(theta, ln_at, driving, sig, grid, y, idx, use_gp, out, rt, bad, lo,
                     min(k, lo + size))


@njit(cache=True, parallel=True)
def model_walkers(theta, sig, grid, y, idx, use_gp, out, rt, bad, size):
    """``_group`` over every row of theta, groups of ``size`` walkers in parallel (numba threads).

    theta (k, 6): E, G, σ_inf, tau_max, tau_max_R, alpha (model units; tau_max_R is
    ignored without a relaxation phase, but must then be positive anyway; alpha is the
    spectrum exponent, ½ for eq. 12); sig (k,): σ0; grid: ``DNLR.kernel_args``; y (n,): the
    observed values in the order of the axis x; idx (n,): the model sample of each of them;
    rt (n, k): the residuals, written with ``use_gp``; bad (k,): set where not defined.
    """
    k = theta.shape[0]
    for g in prange((k + size - 1) // size):
        lo = g * size
        _group(theta, sig, grid, y, idx, use_gp, out, rt, bad, lo, min(k, lo + size))


@njit(cache=True)
def model_walkers_serial(theta, sig, grid, y, idx, use_gp, out, rt, bad, size):
    """``model_walkers`` in the calling thread (the same values): for one thread, and in a process
    forked from one whose numba threads run on GNU OpenMP, where numba terminates a child that
    starts a parallel region."""
    k = theta.shape[0]
    for lo in range(0, k, size):
        _group(theta, sig, grid, y, idx, use_gp, out, rt, bad, lo, min(k, lo + size))


def evaluate(theta, sig, amp, length, grid, y, idx, x, kind, gap, V, use_gp, out,
             shifted=None) -> None:
    """The log-likelihood of every row of theta into ``out`` (k,); -inf where it is not defined.

    The model of every walker (``model_walkers``), then with the discrepancy the filter of their
    residuals (``lanes.loglike_groups``): amp, length (k,) the discrepancy's amplitude and length
    (unused when ``use_gp`` is False); kind, gap: the kernel code and the pinned start (inf:
    stationary) of inference/discrepancy/kalman.py; V (n, p): the orthogonality columns in the
    order of x (p = 0: the plain discrepancy). ``shifted``: None, or (ln_at, driving) of the
    shifted model (``DNLR.kernel_rows``; theta then has 7 columns). Threads when
    ``model.threads.parallel_allowed``."""
    k = theta.shape[0]
    nthreads = get_num_threads() if threads.parallel_allowed() else 1
    size = lanes.lane_group(k, nthreads)
    rt = np.empty((y.shape[0] if use_gp else 0, k))
    bad = np.zeros(k, dtype=np.bool_)
    if shifted is None:
        walkers = model_walkers if nthreads > 1 else model_walkers_serial    # one of them compiled
        walkers(theta, sig, grid, y, idx, use_gp, out, rt, bad, size)
    else:
        walkers = model_walkers_shift if nthreads > 1 else model_walkers_shift_serial
        walkers(theta, shifted[0], shifted[1], sig, grid, y, idx, use_gp, out, rt, bad, size)
    if use_gp:
        lanes.loglike_groups(x, rt, sig, amp, length, kind, gap, V, out, nthreads)
    out[bad] = -np.inf


for _f in (_walker, _group, model_walkers, model_walkers_serial, _group_shift, model_walkers_shift,
           model_walkers_shift_serial):
    depend_on(_f, kernel, reduced_time)
