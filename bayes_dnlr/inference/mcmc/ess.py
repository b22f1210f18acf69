"""Effective sample size, R-hat and HDI of MCMC draws in plain numpy (no ArviZ import).

The same estimators as ArviZ 1.x (arviz_stats), which cost seconds to import with scipy.stats and
matplotlib while ``sample`` needs only these few functions (Vehtari, Gelman, Simpson, Carpenter &
Bürkner 2021, "Rank-normalization, folding, and localization: an improved R-hat"):

- ``ess_bulk``: ESS of the rank-normalised split chains (Blom ranks, c = 3/8);
- ``ess_tail``: the smaller ESS of the indicators I(x <= q) at the 5 % and 95 % quantiles;
- ``rhat``: the larger of the split R-hat of the rank-normalised draws and of the rank-normalised
  folded draws |x - median|;
- ``hdi``: the narrowest interval holding ``prob`` of the sorted draws ("nearest" method);
- ``diagnostics``: ess_bulk, ess_tail and R-hat of one parameter's emcee draws (steps, walkers),
  every walker a chain for the ESS, 4 groups of walkers for R-hat (``walker_groups``).

Arrays are (chain, draw). tests/inference/mcmc/test_ess.py checks every function against ArviZ.
"""

from __future__ import annotations

import math

import numpy as np

# Wichura (1988), algorithm AS241 (PPND16): the normal quantile to about 1e-16 relative, the
# algorithm of Python's statistics.NormalDist.inv_cdf; coefficients highest degree first
_A = (2.5090809287301226727e3, 3.3430575583588128105e4, 6.7265770927008700853e4,
      4.5921953931549871457e4, 1.3731693765509461125e4, 1.9715909503065514427e3,
      1.3314166789178437745e2, 3.3871328727963666080e0)
_B = (5.2264952788528545610e3, 2.8729085735721942674e4, 3.9307895800092710610e4,
      2.1213794301586595867e4, 5.3941960214247511077e3, 6.8718700749205790830e2,
      4.2313330701600911252e1, 1.0)
_C = (7.7454501427834140764e-4, 2.2723844989269184583e-2, 2.4178072517745061177e-1,
      1.2704582524523683826e0, 3.6478483247632046050e0, 5.7694972214606914055e0,
      4.6303378461565452959e0, 1.4234371107496835773e0)
_D = (1.0507500716444168432e-9, 5.4759380849953445460e-4, 1.5198666563616457197e-2,
      1.4810397642748007459e-1, 6.8976733498510000455e-1, 1.6763848301838038494e0,
      2.0531916266377588219e0, 1.0)
_E = (2.0103343992922881327e-7, 2.7115555687434875782e-5, 1.2426609473880784386e-3,
      2.6532189526576123093e-2, 2.9656057182850489123e-1, 1.7848265399172913358e0,
      5.4637849111641143699e0, 6.6579046435011037772e0)
_F = (2.0442631033899397856e-15, 1.4215117583164458887e-7, 1.8463183175100546818e-5,
      7.8686913114561325910e-4, 1.4875361290850614853e-2, 1.3692988092273580531e-1,
      5.9983220655588793769e-1, 1.0)


def _poly(c: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    out = np.full_like(x, c[0])
    for v in c[1:]:
        out = out * x + v
    return out


def ndtri(p: np.ndarray) -> np.ndarray:
    """The standard normal quantile Φ⁻¹(p) for 0 < p < 1 (AS241): scipy.special.ndtri without
    importing scipy (0.2-0.4 s of a ``sample``)."""
    p = np.asarray(p, dtype=float)
    q = p - 0.5
    out = np.empty_like(p)
    central = np.abs(q) <= 0.425
    qc = q[central]
    r = 0.180625 - qc * qc
    out[central] = qc * _poly(_A, r) / _poly(_B, r)
    tail = ~central
    qt = q[tail]
    r = np.sqrt(-np.log(np.where(qt <= 0.0, p[tail], 1.0 - p[tail])))
    near = r <= 5.0
    x = np.where(near, _poly(_C, r - 1.6) / _poly(_D, r - 1.6),
                 _poly(_E, r - 5.0) / _poly(_F, r - 5.0))
    out[tail] = np.where(qt < 0.0, -x, x)
    return out


def _rankdata(x: np.ndarray) -> np.ndarray:
    """Average ranks (1-based, ties share their mean rank) of the flattened array, its shape kept."""
    a = x.ravel()
    sorter = np.argsort(a, kind="mergesort")
    inv = np.empty(a.size, dtype=np.intp)
    inv[sorter] = np.arange(a.size, dtype=np.intp)
    s = a[sorter]
    first = np.concatenate(([True], s[1:] != s[:-1]))
    dense = np.cumsum(first)[inv]
    count = np.concatenate((np.flatnonzero(first), [a.size]))
    return (0.5 * (count[dense] + count[dense - 1] + 1)).reshape(x.shape)


def _z_scale(x: np.ndarray) -> np.ndarray:
    """Normal scores of the average ranks (Blom's c = 3/8)."""
    r = _rankdata(x)
    return ndtri((r - 0.375) / (x.size - 0.75 + 1.0))


def _split(x: np.ndarray) -> np.ndarray:
    """Each chain split in halves (the middle draw of an odd chain dropped): (2 chains, draw/2)."""
    half = x.shape[1] // 2
    return np.vstack((x[:, :half], x[:, x.shape[1] - half:]))


def next_fast_len(n: int) -> int:
    """The smallest 2^a 3^b 5^c >= n (a fast FFT length)."""
    best = 1 << max(n - 1, 0).bit_length()
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            v = p35
            while v < n:
                v *= 2
            best = min(best, v)
            p35 *= 3
        p5 *= 5
    return best


def _autocov(x: np.ndarray) -> np.ndarray:
    """Autocovariance of each row at every lag (FFT), divided by the row length."""
    n = x.shape[1]
    m = next_fast_len(2 * n)
    d = x - x.mean(axis=1, keepdims=True)
    f = np.fft.rfft(d, n=m, axis=1)
    f *= np.conjugate(f)
    return np.fft.irfft(f, n=m, axis=1)[:, :n] / n


def _ess(x: np.ndarray) -> float:
    """ESS of (chain, draw) draws by Geyer's initial monotone sequence (as ArviZ ``_ess``)."""
    x = np.asarray(x, dtype=float)
    if np.max(x) - np.min(x) < np.finfo(float).resolution:
        return float(x.size)
    n_chain, n_draw = x.shape
    acov = _autocov(x)
    mean_var = np.mean(acov[:, 0]) * n_draw / (n_draw - 1.0)
    var_plus = mean_var * (n_draw - 1.0) / n_draw
    if n_chain > 1:
        var_plus += np.var(x.mean(axis=1), ddof=1)
    mean_acov = acov.mean(axis=0)
    rho = np.zeros(n_draw)
    even = 1.0
    rho[0] = even
    odd = 1.0 - (mean_var - mean_acov[1]) / var_plus
    rho[1] = odd
    t = 1
    while t < n_draw - 3 and even + odd > 0.0:
        even = 1.0 - (mean_var - mean_acov[t + 1]) / var_plus
        odd = 1.0 - (mean_var - mean_acov[t + 2]) / var_plus
        if even + odd >= 0:
            rho[t + 1] = even
            rho[t + 2] = odd
        t += 2
    max_t = t - 2
    if even > 0:
        rho[max_t + 1] = even
    t = 1
    while t <= max_t - 2:
        if rho[t + 1] + rho[t + 2] > rho[t - 1] + rho[t]:
            rho[t + 1] = (rho[t - 1] + rho[t]) / 2.0
            rho[t + 2] = rho[t + 1]
        t += 2
    ess = n_chain * n_draw
    tau = -1.0 + 2.0 * np.sum(rho[: max_t + 1]) + np.sum(rho[max_t + 1: max_t + 2])
    tau = max(tau, 1.0 / math.log10(ess))
    return float("nan") if np.isnan(rho).any() else float(ess / tau)


def _invalid(x: np.ndarray, min_chains: int) -> bool:
    return bool(np.isnan(x).any() or x.shape[1] < 4 or x.shape[0] < min_chains)


def ess_bulk(x: np.ndarray) -> float:
    """Bulk ESS of (chain, draw) draws: rank-normalised split chains."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    if _invalid(x, 1):
        return float("nan")
    return _ess(_z_scale(_split(x)))


def ess_quantile(x: np.ndarray, prob: float) -> float:
    """ESS of the indicator I(x <= the ``prob`` quantile) over the split chains."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    if _invalid(x, 1):
        return float("nan")
    q = np.quantile(x, prob)
    return _ess(_split(x <= q))


def ess_tail(x: np.ndarray, prob: float = 0.05) -> float:
    """Tail ESS: the smaller quantile ESS at ``prob`` and 1 - ``prob``."""
    lo, hi = sorted((prob, 1.0 - prob))
    return min(ess_quantile(x, lo), ess_quantile(x, hi))


def _rhat_plain(x: np.ndarray) -> float:
    n = x.shape[1]
    between = n * np.var(x.mean(axis=1), ddof=1)
    within = np.mean(np.var(x, axis=1, ddof=1))
    return float(np.sqrt((between / within + n - 1) / n))


def rhat(x: np.ndarray) -> float:
    """Rank-normalised split R-hat of (chain, draw) draws: max of the bulk and folded versions."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    if _invalid(x, 2):
        return float("nan")
    s = _split(x)
    bulk = _rhat_plain(_z_scale(s))
    tail = _rhat_plain(_z_scale(np.abs(s - np.median(s))))
    return max(bulk, tail)


def hdi(x: np.ndarray, prob: float) -> tuple[float, float]:
    """The narrowest interval between two draws that holds ``prob`` of the (flattened) draws."""
    a = np.sort(np.asarray(x, dtype=float).ravel())
    n = a.size
    inc = min(int(np.floor(prob * n)), n - 1)
    width = a[inc:] - a[: n - inc]
    if width.size == 0:
        raise ValueError("too few draws for an interval")
    k = int(np.argmin(width))
    return float(a[k]), float(a[k + inc])


RHAT_GROUPS = 4     # R-hat compares 4 groups of walkers


def walker_groups(x: np.ndarray, groups: int = RHAT_GROUPS) -> np.ndarray:
    """(steps, walkers) -> (groups, steps * walkers_per_group), draws ordered step by step.

    Walkers beyond a multiple of ``groups`` are left out of this statistic.
    """
    n, w = x.shape
    g = min(groups, w)
    m = w // g
    return x[:, : g * m].reshape(n, g, m).transpose(1, 0, 2).reshape(g, n * m)


def diagnostics(draws: np.ndarray) -> dict[str, float]:
    """ArviZ ess_bulk, ess_tail (every walker a chain) and R-hat (4 walker groups) of one
    parameter's draws (steps, walkers)."""
    by_walker = np.ascontiguousarray(draws.T)     # (chain = walker, draw = step)
    return {
        "ess_bulk": ess_bulk(by_walker),
        "ess_tail": ess_tail(by_walker, 0.05),
        "r_hat": rhat(walker_groups(draws)),
    }
