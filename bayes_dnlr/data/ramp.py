"""The loading history: the ramp's strain rate and the start of a relaxation hold."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayes_dnlr.data.checks import noise_sd
from bayes_dnlr.data.cycles import Turns, turning_points


def ramp_strain_rate(time: np.ndarray, strain: np.ndarray, relaxation_start: float | None) -> float:
    """Mean Hencky strain rate of the loading ramp: least-squares slope of ε(t) up to relaxation_start."""
    ramp = np.ones(time.size, bool) if relaxation_start is None else time <= relaxation_start
    t, e = time[ramp], strain[ramp]
    if t.size < 2:
        return float("nan")
    tc = t - t.mean()
    return float(np.dot(tc, e - e.mean()) / np.dot(tc, tc))


def _prefix(x: np.ndarray) -> np.ndarray:
    return np.concatenate(([0.0], np.cumsum(x)))


def detect_relaxation_start(time: np.ndarray, strain: np.ndarray, min_points: int = 5) -> int:
    """Index of the sample where the hold starts (the strain stops increasing).

    Every split k is scored by the residual sum of squares of a straight line fitted to the ramp
    (samples < k) plus a constant fitted to the hold (samples >= k), both from prefix sums (O(n)).
    The start is the sample nearest to the intersection of the best line and constant, which is
    robust to strain noise (the paper's sd 1e-4). Raises ValueError when there is no hold.
    """
    n = time.size
    if n < 2 * min_points:
        raise ValueError(f"only {n} samples: too few to find a ramp and a hold")
    t = time - time.mean()
    e = strain - strain.mean()
    c1, ct, ctt, ce, cte, cee = (_prefix(v) for v in (np.ones(n), t, t * t, e, t * e, e * e))
    k = np.arange(min_points, n - min_points + 1)
    sxx = ctt[k] - ct[k] ** 2 / k
    sxy = cte[k] - ct[k] * ce[k] / k
    syy = cee[k] - ce[k] ** 2 / k
    line = syy - np.divide(sxy**2, sxx, out=np.zeros_like(sxx), where=sxx > 0)
    m = n - k
    hold_e = ce[n] - ce[k]
    const = (cee[n] - cee[k]) - hold_e**2 / m
    best = int(k[np.argmin(line + const)])
    slope = float(sxy[best - min_points] / sxx[best - min_points])
    intercept = ce[best] / best - slope * ct[best] / best
    level = hold_e[best - min_points] / (n - best)
    hold_slope = ramp_strain_rate(t[best:], e[best:], None)
    if not slope > 0 or abs(hold_slope) > 0.1 * slope:
        raise ValueError(f"no hold found: the strain rate is {slope:.3g} 1/s on the ramp and "
                         f"{hold_slope:.3g} 1/s after the best split at t = {time[best]:g} s")
    # the end of the ramp from its last tenth: a crosshead at constant speed drives the nominal
    # strain, so the Hencky strain bends and a line through the whole ramp meets the hold early
    w = max(min_points, best // 10)
    near = slice(best - w, best)
    local = _slope(t[near], e[near])
    if local > 0:
        slope = local
        intercept = float(np.mean(e[near]) - local * np.mean(t[near]))
    t_cross = (level - intercept) / slope
    return int(np.argmin(np.abs(t - t_cross)))


def _slope(t: np.ndarray, e: np.ndarray) -> float:
    if t.size < 2:
        return float("nan")
    tc = t - t.mean()
    den = np.dot(tc, tc)
    return float(np.dot(tc, e - e.mean()) / den) if den > 0 else float("nan")


def window_strain_rate(time: np.ndarray, strain: np.ndarray, window: np.ndarray,
                       relaxation_start: float | None, first: int = 0,
                       peak: int | None = None) -> tuple[float, str]:
    """The strain rate of the loading the fit sees, and how it was found.

    The least-squares slope of ε(t) over the window's loading: its samples of the ramp (up to
    relaxation_start, and up to ``peak``, the first peak of cycles the window runs past,
    data/cycles.py) from the first one until the strain has made 98 % of its rise there (so a
    hold or an unloading inside the window does not count, nor the creep of cycles to a force,
    whose largest strain comes at the last peak). When that leaves fewer than 3
    samples, or no rise (a window in a hold), the slope of the loading before: from the first model
    sample (``first``) to the largest strain up to the window's end, within the ramp. NaN when the
    strain never rises.
    """
    ramp = np.ones(time.size, bool) if relaxation_start is None else time <= relaxation_start
    ramp[:first] = False
    if peak is not None:
        ramp[peak + 1:] = False
    sel = np.flatnonzero(window & ramp)
    if sel.size >= 3:
        e = strain[sel]
        rise = float(e.max() - e[0])
        if rise > 0:
            stop = int(np.argmax(e >= e[0] + 0.98 * rise))
            load = sel[:max(stop, 1) + 1]
            rate = _slope(time[load], strain[load])
            if load.size >= 3 and rate > 0:
                return rate, (f"over the window's loading, t = {time[load[0]]:g} to {time[load[-1]]:g} s")
    end = int(np.flatnonzero(window)[-1]) + 1
    top = first + int(np.argmax(np.where(ramp[first:end], strain[first:end], -np.inf)))
    load = np.zeros(time.size, bool)
    load[first:top + 1] = True
    load &= ramp
    rate = _slope(time[load], strain[load])
    if rate > 0:
        return rate, (f"over the loading before the window's hold, t = {time[load][0]:g} to "
                      f"{time[load][-1]:g} s")
    return float("nan"), "the strain does not rise before or in the window"


HOLD_FLAT = 0.01        # the strain of a hold stays within this share of its range
HOLD_SHARE = 0.1        # ... for at least this share of the test's duration, at its end
HOLD_FALL = 0.02        # ... while the stress falls by at least this share of its largest value
HOLD_OUTLIERS = 0.02    # ... a share of the hold's samples may leave that band (a DIC glitch)
HOLD_NOISE = 5.0        # ... or within this many noise sd of its level, when the noise is larger


@dataclass(frozen=True)
class Hold:
    """A relaxation hold at the end of a test: the strain stops rising at ``start`` (an index) and
    stays, while the stress falls from ``stress_from`` to ``stress_to``."""

    start: int
    time: float
    end_time: float
    strain: float
    stress_from: float
    stress_to: float
    band: float = 0.0         # the strain stays within ± band of its level

    def describe(self, strain_what: str = "the strain", load_what: str = "the stress") -> str:
        return (f"{strain_what} stays at {self.strain:.4g} (within ±{self.band:.2g}) "
                f"from t = {self.time:.4g} s to the end ({self.end_time:.4g} s) while {load_what} falls "
                f"from {self.stress_from:.4g} to {self.stress_to:.4g}")


def find_hold(time: np.ndarray, strain: np.ndarray, stress: np.ndarray,
              turns: Turns | None = None) -> Hold | None:
    """A relaxation hold: the strain stays within HOLD_FLAT of its range (or within HOLD_NOISE sd of
    its scatter in the test's last tenth, for a noisy strain such as DIC's) of its level at the end,
    but for HOLD_OUTLIERS of its samples, from some sample to the end, for at least HOLD_SHARE of the
    test, near its largest value, while the stress falls by HOLD_FALL of
    its largest value or more, and the test does not unload (``turns``: the test's turning points
    when known, data/cycles.py). None for a tensile test (or a machine that only stopped). NaN rows
    (padding) are left out."""
    ok = np.isfinite(time) & np.isfinite(strain) & np.isfinite(stress)
    t, e, s = time[ok], strain[ok], stress[ok]
    if t.size < 20 or np.ptp(e) == 0:
        return None
    tail = slice(e.size - max(10, e.size // 10), e.size)
    level = float(np.median(e[tail]))
    sd = max(noise_sd(e), _scatter(t[tail], e[tail]))
    band = max(HOLD_FLAT * float(np.ptp(e)), HOLD_NOISE * sd)
    flat = np.abs(e - level) <= band
    if flat.all():
        return None
    # the first flat sample after which at most HOLD_OUTLIERS of the samples leave the band
    outside = np.concatenate((np.cumsum((~flat)[::-1])[::-1], [0]))[:-1]
    stays = flat & (outside <= HOLD_OUTLIERS * (e.size - np.arange(e.size)))
    start = int(np.argmax(stays)) if stays.any() else e.size
    if start == 0 or start >= e.size or level < 0.9 * e.max() or \
            t[-1] - t[start] < HOLD_SHARE * (t[-1] - t[0]):
        return None
    top = float(np.max(np.abs(s)))
    fall = float(s[start] - s[-1])
    if turns is None:
        turns = turning_points(e, s)
    if not top > 0 or fall < HOLD_FALL * top or turns.peaks:
        return None                     # no fall, or an unloading: the strain went back with the stress
    return Hold(int(np.flatnonzero(ok)[start]), float(t[start]), float(t[-1]), level,
                float(s[start]), float(s[-1]), band)


def _scatter(t: np.ndarray, e: np.ndarray) -> float:
    """Robust sd of e about a straight line of t: the noise of a hold's strain, slow wander
    included (DIC), which second differences do not see."""
    line = np.polyval(np.polyfit(t - t.mean(), e, 1), t - t.mean())
    r = e - line
    return float(1.4826 * np.median(np.abs(r - np.median(r))))
