"""The strain that drives the model: a cubic smoothing spline of the measured strain, per segment,
with the smoothing parameter chosen by generalised cross-validation (GCV, Wahba 1990).

The spline is computed in its state-space form: the cubic smoothing spline with penalty
λ∫f''² is the posterior mean of an integrated Wiener process observed in white noise (Wahba 1978;
Kohn & Ansley 1987), which a Kalman filter and a Rauch-Tung-Striebel smoother give in O(n) time
and memory, together with the diagonal of the hat matrix that GCV needs. Unlike the banded
normal equations (scipy's ``make_smoothing_spline``), this stays exact for any λ, up to the
straight line (λ → ∞), and for any record length: a 10⁶-sample ramp is smoothed in seconds.

Time is measured in each segment's median sampling step, so λ means the same for a 1 kHz and a
0.01 Hz record. Segments are split at the start of a hold (the kink is kept) and where the
sampling interval changes (0.2 s, then 180 s): a sparse stretch gets its own λ instead of the
dense stretch's, which would let the spline follow the noise between sparse samples.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayes_dnlr.data.brent import fminbound
from bayes_dnlr.diskio import keep_cache_arrays
from bayes_dnlr.readback import read_npz

SMOOTH_MIN_POINTS = 5       # fewer samples: a least-squares line (2: the samples themselves)
LOG_LAMBDA = (-3.0, 14.0)   # GCV search range of log10 λ, λ in (median step)³
RATE_CHANGE = 3.0           # a sampling interval that changes by this factor starts a new segment
RATE_WINDOW = 5             # samples on each side whose median interval is compared
PRIOR_VAR = 1e8             # the (nearly) diffuse prior of the start value and slope, in data sd units

_KERNEL = None


def _kalman_spline_py(u: np.ndarray, y: np.ndarray, q: float, prior: float,
                      fit: np.ndarray) -> float:
    """Posterior mean of an integrated Wiener process (spectral density q) observed with unit noise
    at the points u: the cubic smoothing spline with λ = 1/q. Writes the fit, returns tr(H)."""
    n = u.size
    mf = np.empty((n, 2))
    pf = np.empty((n, 3))           # p00, p01, p11 of the filtered covariance
    m0, m1 = 0.0, 0.0
    p00, p01, p11 = prior, 0.0, prior
    for i in range(n):
        if i > 0:
            d = u[i] - u[i - 1]
            m0 = m0 + d * m1
            a00 = p00 + 2.0 * d * p01 + d * d * p11 + q * d * d * d / 3.0
            a01 = p01 + d * p11 + q * d * d / 2.0
            a11 = p11 + q * d
            p00, p01, p11 = a00, a01, a11
        s = p00 + 1.0
        k0, k1 = p00 / s, p01 / s
        r = y[i] - m0
        m0, m1 = m0 + k0 * r, m1 + k1 * r
        p00, p01, p11 = p00 - k0 * p00, p01 - k0 * p01, p11 - k1 * p01
        mf[i, 0], mf[i, 1] = m0, m1
        pf[i, 0], pf[i, 1], pf[i, 2] = p00, p01, p11
    # Rauch-Tung-Striebel smoother
    s0, s1 = mf[n - 1, 0], mf[n - 1, 1]
    c00, c01, c11 = pf[n - 1, 0], pf[n - 1, 1], pf[n - 1, 2]
    fit[n - 1] = s0
    trace = c00
    for i in range(n - 2, -1, -1):
        d = u[i + 1] - u[i]
        f00, f01, f11 = pf[i, 0], pf[i, 1], pf[i, 2]
        a00 = f00 + 2.0 * d * f01 + d * d * f11 + q * d * d * d / 3.0
        a01 = f01 + d * f11 + q * d * d / 2.0
        a11 = f11 + q * d
        det = a00 * a11 - a01 * a01
        # gain G = P_f Fᵀ A⁻¹, with P_f Fᵀ = [[f00 + d f01, f01], [f01 + d f11, f11]]
        b00, b01 = f00 + d * f01, f01
        b10, b11 = f01 + d * f11, f11
        g00 = (b00 * a11 - b01 * a01) / det
        g01 = (b01 * a00 - b00 * a01) / det
        g10 = (b10 * a11 - b11 * a01) / det
        g11 = (b11 * a00 - b10 * a01) / det
        pm0 = mf[i, 0] + d * mf[i, 1]
        pm1 = mf[i, 1]
        e0, e1 = s0 - pm0, s1 - pm1
        s0 = mf[i, 0] + g00 * e0 + g01 * e1
        s1 = mf[i, 1] + g10 * e0 + g11 * e1
        # C = P_f + G (C_next - A) Gᵀ
        h00, h01, h11 = c00 - a00, c01 - a01, c11 - a11
        t00 = g00 * h00 + g01 * h01
        t01 = g00 * h01 + g01 * h11
        t10 = g10 * h00 + g11 * h01
        t11 = g10 * h01 + g11 * h11
        c00 = f00 + t00 * g00 + t01 * g01
        c01 = f01 + t00 * g10 + t01 * g11
        c11 = f11 + t10 * g10 + t11 * g11
        fit[i] = s0
        trace += c00
    return trace


def _kernel():
    global _KERNEL
    if _KERNEL is None:
        try:
            from numba import njit
        except ImportError:  # pragma: no cover - numba is a dependency; plain Python is just slower
            _KERNEL = _kalman_spline_py
        else:
            _KERNEL = njit(cache=True, nogil=True)(_kalman_spline_py)
    return _KERNEL


def _scaled(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """u = (x - x0)/h (h the median step) and y standardised: (u, z, h, centre, scale)."""
    h = float(np.median(np.diff(x)))
    u = (x - x[0]) / h
    centre = float(y[0])
    scale = float(np.std(y - np.polyval(np.polyfit(u, y, 1), u))) or float(np.std(y)) or 1.0
    return u, (y - centre) / scale, h, centre, scale


def _gcv(u: np.ndarray, z: np.ndarray, log_lam: float, fit: np.ndarray) -> float:
    n = u.size
    tr = _kernel()(u, z, 10.0 ** -log_lam, PRIOR_VAR, fit)
    r = z - fit
    return float(n * np.dot(r, r) / max(n - tr, 1e-300) ** 2)


def _search(u: np.ndarray, z: np.ndarray) -> float:
    """log10 λ (λ in step³) minimising GCV: a grid of decades, then a bounded Brent refinement
    (scipy's algorithm, data/brent.py)."""
    fit = np.empty_like(z)
    lo, hi = LOG_LAMBDA
    grid = np.arange(lo, hi + 0.5, 1.0)
    scores = np.array([_gcv(u, z, g, fit) for g in grid])
    k = int(np.argmin(scores))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    x, fun = fminbound(lambda g: _gcv(u, z, g, fit), float(a), float(b), xatol=1e-3)
    return float(x) if fun <= scores[k] else float(grid[k])


def gcv_lambda(x: np.ndarray, y: np.ndarray) -> float:
    """The GCV smoothing parameter λ of the cubic smoothing spline of y(x), in x's units
    (the ``lam`` of ``scipy.interpolate.make_smoothing_spline``); the search spans λ from 1e-3 to
    1e14 median steps cubed, where the spline is a straight line to within rounding."""
    u, z, h, _, _ = _scaled(np.asarray(x, float), np.asarray(y, float))
    return 10.0 ** _search(u, z) * h**3


def smooth_segment(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """GCV cubic smoothing spline of y(x) at the points x, and λ in x's units."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    u, z, h, centre, scale = _scaled(x, y)
    log_lam = _search(u, z)
    fit = np.empty_like(z)
    _kernel()(u, z, 10.0 ** -log_lam, PRIOR_VAR, fit)
    lam = 10.0 ** log_lam * h**3
    if log_lam >= LOG_LAMBDA[1] - 0.01:
        lam = math.inf
    return centre + scale * fit, lam


def segment_edges(n: int, breaks: Sequence[int]) -> list[int]:
    """First and last sample of each segment (neighbours share their break sample)."""
    return [0, *sorted({int(b) for b in breaks if 0 < b < n - 1}), n - 1]


def sampling_breaks(time: np.ndarray, breaks: Sequence[int] = ()) -> list[int]:
    """Samples where the sampling interval changes for good (by RATE_CHANGE or more): the median
    interval of the RATE_WINDOW steps after differs from that of the steps before. One jittered or
    missing step does not count. Breaks closer than RATE_WINDOW samples to another are merged."""
    dt = np.diff(np.asarray(time, float))
    k = RATE_WINDOW
    if dt.size < 2 * k:
        return []
    from numpy.lib.stride_tricks import sliding_window_view

    med = np.median(sliding_window_view(dt, k), axis=1)     # med[j] = median(dt[j:j+k])
    before, after = med[:-k], med[k:]                         # around sample i = j + k
    ratio = np.abs(np.log(after / before))
    cand = np.flatnonzero(ratio > math.log(RATE_CHANGE)) + k
    out: list[int] = []
    existing = sorted(int(b) for b in breaks)
    for i in cand:
        if out and i - out[-1] < k:
            if ratio[i - k] > ratio[out[-1] - k]:
                out[-1] = int(i)
            continue
        out.append(int(i))
    # the break is the sample where the interval changes: the largest jump of log dt near i
    final = []
    for i in out:
        lo, hi = max(i - k, 1), min(i + k, dt.size)
        j = lo + int(np.argmax(np.abs(np.diff(np.log(dt[lo - 1:hi])))))
        if all(abs(j - b) >= k for b in existing + final):
            final.append(j)
    return sorted(final)


def _line(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    xc = x - x.mean()
    return y.mean() + xc * (np.dot(xc, y - y.mean()) / np.dot(xc, xc))


def _cache_file(cache: Path, time: np.ndarray, strain: np.ndarray, breaks: Sequence[int]) -> Path:
    """The file of a smoothing in ``cache``: named by the digest of everything the result depends
    on (the samples, the breaks, the search's constants)."""
    h = hashlib.sha256()
    for a in (np.ascontiguousarray(time, dtype=float), np.ascontiguousarray(strain, dtype=float)):
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    h.update(repr((list(map(int, breaks)), SMOOTH_MIN_POINTS, LOG_LAMBDA, PRIOR_VAR)).encode())
    return Path(cache) / f"strain-{h.hexdigest()[:32]}.npz"


@dataclass(frozen=True)
class UnkeptSmoothing:
    """A smoothing computed before its cache folder's parent (the run folder) existed: ``keep``
    writes it once the folder is there, so that the next command does not search λ again."""

    path: Path
    strain: np.ndarray
    lams: tuple[float, ...]

    def keep(self) -> bool:
        """Write it to the cache when the run folder exists now; False when it is not written."""
        return self.path.parent.parent.is_dir() and _store(self.path, self.strain, list(self.lams))


def unkept_smoothing(cache: Path | None, time: np.ndarray, strain: np.ndarray, breaks: Sequence[int],
                     result: tuple[np.ndarray, list[float]]) -> UnkeptSmoothing | None:
    """``smooth_strain``'s ``result`` to keep later, when its ``cache`` could not be written yet (the
    run folder is made once a command has something to write: ``fit`` and ``sample`` from an empty
    folder); None when there is nothing to keep later."""
    if cache is None or Path(cache).parent.is_dir():
        return None
    return UnkeptSmoothing(_cache_file(Path(cache), time, strain, breaks), result[0], tuple(result[1]))


def _cached(path: Path) -> tuple[np.ndarray, list[float]] | None:
    z = read_npz(path)
    try:
        return z["strain"], [float(v) for v in z["lams"]]
    except (TypeError, ValueError, KeyError):
        return None


def _store(path: Path, fit: np.ndarray, lams: list[float]) -> bool:
    """Keep a smoothing for the next command (replaced in one step; a cache that cannot be written
    is no error: the next command smooths again). False when it is not written."""
    return keep_cache_arrays(path, strain=fit, lams=np.asarray(lams, dtype=float))


def smooth_strain(time: np.ndarray, strain: np.ndarray, breaks: Sequence[int] = (),
                  cache: Path | None = None) -> tuple[np.ndarray, list[float]]:
    """The strain that drives the model: a GCV smoothing spline per segment, split at ``breaks``.

    Segments share their break sample (the kink at the start of a hold), where the two fits are
    averaged, so a kink in the strain history is kept rather than rounded off. Segments of 3 or 4
    samples get a least-squares line, of 2 samples the samples themselves. Returns the smoothed
    strain and the λ of each segment (in s³; inf for a straight line, NaN when not smoothed).

    ``cache``: a folder (created when its parent exists) that keeps the result by the digest of its
    inputs, so that the commands after the first (sample, report) do not search λ again.
    """
    path = None
    if cache is not None and Path(cache).parent.is_dir():
        path = _cache_file(Path(cache), time, strain, breaks)
        hit = _cached(path)
        if hit is not None and hit[0].shape == np.shape(strain):
            return hit
    out = _smooth(time, strain, breaks)
    if path is not None:
        _store(path, *out)
    return out


def _smooth(time: np.ndarray, strain: np.ndarray, breaks: Sequence[int]) -> tuple[np.ndarray, list[float]]:
    edges = segment_edges(time.size, breaks)
    weight = np.zeros(time.size)
    acc = np.zeros(time.size)
    lams = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        sl = slice(a, b + 1)
        m = b + 1 - a
        if m < 3:
            fit, lam = strain[sl], float("nan")
        elif m < SMOOTH_MIN_POINTS:
            fit, lam = _line(time[sl], strain[sl]), math.inf
        else:
            fit, lam = smooth_segment(time[sl], strain[sl])
        acc[sl] += fit
        weight[sl] += 1.0
        lams.append(lam)
    return acc / weight, lams
