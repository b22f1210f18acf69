"""The baseline noise of a test: the stress noise where the specimen is not yet loaded
(``noise.sigma0: {baseline: ...}``), and the check that such a window is flat and unloaded."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.config import Window
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.testdata import TestData
from bayes_dnlr.data.windows import describe_window, window_mask

MIN_BASELINE = 10


def _line_fit(t: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray]:
    """Slope of the least-squares line of y(t) and the residuals."""
    tc = t - t.mean()
    slope = float(np.dot(tc, y - y.mean()) / np.dot(tc, tc))
    return slope, y - y.mean() - slope * tc


def _loading_starts(test: TestData) -> float | None:
    """When the strain starts to rise: the line through the samples between 5 % and 20 % of the
    strain's rise, extended back to the first sample's strain."""
    v = test.virtual_start
    t, e = test.time[v:], test.strain_input[v:]
    top = int(np.argmax(e))
    rise = e[top] - e[0]
    if not rise > 0:
        return None
    a = int(np.argmax(e >= e[0] + 0.05 * rise))
    b = int(np.argmax(e >= e[0] + 0.2 * rise)) + 1
    if b - a < 2:
        return float(t[a])
    slope, _ = _line_fit(t[a:b], e[a:b])
    return float(t[a:b].mean() - (e[a:b].mean() - e[0]) / slope) if slope > 0 else float(t[a])


def check_baseline(test: TestData, mask: np.ndarray, key: str) -> None:
    """Refuse a baseline window over a loaded specimen.

    Unloaded: the strain does not rise across the window by more than its own noise can explain
    (5 sd of a line's rise over the window, or 0.1 % of the test's strain range if larger). Flat and
    unloaded: the stress there stays below 5 % of the test's largest stress, in level and in trend
    across the window. A baseline over the loading ramp measures the curvature of the stress as
    well as its noise (0.087 MPa instead of 0.001 on a test loading from t = 0).
    """
    t, e, s = test.time[mask], test.strain_input[mask], test.stress[mask]
    duration = float(t[-1] - t[0])
    span = f"{key} selects t = {t[0]:g} to {t[-1]:g} s ({t.size} samples)"
    e_all = test.strain_input[test.virtual_start:]
    e_range = float(e_all.max() - e_all.min())
    slope_e, res_e = _line_fit(t, e)
    sd_e = float(np.sqrt(np.dot(res_e, res_e) / max(t.size - 2, 1)))
    rise = abs(slope_e) * duration
    limit = max(5.0 * sd_e * np.sqrt(12.0 / t.size), 1e-3 * e_range)
    if rise > limit:
        start = _loading_starts(test)
        first = float(test.time[test.virtual_start])
        step = float(np.median(np.diff(test.time[test.virtual_start:])))
        where = (f"; the strain starts to rise near t = {start:.4g} s" if start is not None
                 and start > first + 2 * step else "; the test loads from its first sample")
        raise DataError(f"{test.path}: {span}, but the specimen is loaded there: the strain rises by "
                        f"{rise:.3g} across the window (from {e[0]:.4g} to {e[-1]:.4g}){where}. A baseline "
                        f"must be flat and unloaded: choose a window before the loading, or give "
                        f"noise.sigma0 as a number (MPa) or 'residuals'")
    top = float(np.max(np.abs(test.stress[test.virtual_start:])))
    slope_s, _ = _line_fit(t, s)
    trend = abs(slope_s) * duration
    if top > 0 and (trend > 0.05 * top or abs(float(np.median(s))) > 0.05 * top):
        what = (f"sits at {float(np.median(s)):.4g} MPa" if abs(float(np.median(s))) > 0.05 * top else
                f"changes by {trend:.3g} MPa across it")
        raise DataError(f"{test.path}: {span}, but the stress there is not an unloaded baseline: it "
                        f"{what}, more than 5 % of the test's largest stress ({top:.4g} MPa). Choose a "
                        f"window before the loading, or give noise.sigma0 as a number (MPa) or 'residuals'")


def baseline_sd(test: TestData, window: Window) -> float:
    """Noise sd of the stress where the specimen is not yet loaded (noise.sigma0: {baseline: ...}).

    The standard deviation of the observable stress over the window's samples after removing a
    least-squares straight line in time (two degrees of freedom). Needs at least 10 samples, and a
    window that is flat and unloaded (``check_baseline``).
    """
    v = test.virtual_start
    mask = window_mask(test.time[v:], test.strain[v:], window, path=test.path,
                       key="noise.sigma0.baseline", min_points=MIN_BASELINE)
    mask = np.concatenate((np.zeros(v, bool), mask))
    check_baseline(test, mask, "noise.sigma0.baseline " + describe_window(window))
    t, s = test.time[mask], test.stress[mask]
    A = np.column_stack([np.ones_like(t), t - t.mean()])
    coef, *_ = np.linalg.lstsq(A, s, rcond=None)
    r = s - A @ coef
    return float(np.sqrt(np.dot(r, r) / (t.size - 2)))
