"""Identification windows (paper section 4.1): which samples a window selects."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bayes_dnlr.config import Window
from bayes_dnlr.data.errors import DataError

MIN_ROWS = 3


def describe_window(window: Window) -> str:
    """The window's bounds as the config writes them: ``{strain_max: 0.1}``."""
    items = [f"{k}: {getattr(window, k):g}" for k in ("strain_min", "strain_max", "time_min", "time_max")
             if getattr(window, k) is not None]
    return "{" + ", ".join(items) + "}"


def window_mask(time: np.ndarray, strain: np.ndarray, window: Window, *, path: Path | str = "data",
                key: str = "data.window", min_points: int = MIN_ROWS) -> np.ndarray:
    """Contiguous samples of a window (paper section 4.1: interval I is strain_max 0.13).

    From the first sample meeting every lower bound (strain_min on ``strain``, time_min) up to
    the last sample before the first one that breaks an upper bound (strain_max, time_max).
    A bound beyond the data (a lower bound above the largest value, an upper bound below the
    smallest or more than 1 % of the range above the largest) is an error, as is a window with
    fewer than ``min_points`` samples.
    """
    ranges = {"strain": (float(strain.min()), float(strain.max())),
              "time": (float(time.min()), float(time.max()))}
    span = (f"the input strain spans {ranges['strain'][0]:.4g} to {ranges['strain'][1]:.4g} and time "
            f"{ranges['time'][0]:.6g} to {ranges['time'][1]:.6g} s")
    for q in ("strain", "time"):
        lo, hi = ranges[q]
        slack = 0.01 * (hi - lo)
        vmin, vmax = getattr(window, f"{q}_min"), getattr(window, f"{q}_max")
        if (vmin is not None and vmin > hi) or (vmax is not None and (vmax < lo or vmax > hi + slack)):
            bad = f"{q}_min: {vmin:g}" if vmin is not None and vmin > hi else f"{q}_max: {vmax:g}"
            raise DataError(f"{path}: {key} {bad} lies outside the data: {span}")
    low = np.ones(time.size, bool)
    high = np.zeros(time.size, bool)
    if window.strain_min is not None:
        low &= strain >= window.strain_min
    if window.time_min is not None:
        low &= time >= window.time_min
    if window.strain_max is not None:
        high |= strain > window.strain_max
    if window.time_max is not None:
        high |= time > window.time_max
    mask = np.zeros(time.size, bool)
    start = np.flatnonzero(low)
    if start.size:
        s = int(start[0])
        stop = np.flatnonzero(high[s:])
        e = s + int(stop[0]) if stop.size else time.size
        mask[s:e] = True
    count = int(mask.sum())
    if count < min_points:
        raise DataError(f"{path}: {key} {describe_window(window)} selects {count} sample(s), at least "
                        f"{min_points} are needed: {span}")
    return mask
