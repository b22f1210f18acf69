"""Posterior mass against a prior bound: where the prior's box, not the data, decides a parameter.

A parameter whose 90 % interval reaches within 1 % of the prior's width of a finite bound piles
against it: the data would move it further. The bound is a choice of the user (or a default), so
the check also asks how far E moves when that bound is widened ×10 (runs/checks.py refits with
it). A bound that is a physical limit (a modulus or a time constant cannot be negative) is named but
not widened.
"""

from __future__ import annotations

import math

import numpy as np

NEAR = 0.01            # within this share of the prior's width (log width in log space)
WIDEN = 10.0


def piled_side(draws: np.ndarray, low: float, high: float, log_space: bool) -> str | None:
    """'low' or 'high' when the 90 % interval of the draws reaches that bound, else None."""
    x = np.ravel(np.asarray(draws, dtype=float))
    q05, q95 = np.quantile(x, [0.05, 0.95])
    if log_space:
        if not (low > 0 and math.isfinite(high)):
            return None
        width = math.log(high / low)
        near_high = math.log(high / q95) <= NEAR * width if q95 > 0 else False
        near_low = math.log(q05 / low) <= NEAR * width if q05 > 0 else True
    else:
        if not (math.isfinite(low) and math.isfinite(high)):
            return None
        width = high - low
        near_high, near_low = high - q95 <= NEAR * width, q05 - low <= NEAR * width
    if near_high:
        return "high"
    if near_low:
        return "low"
    return None


def physical_limit(side: str, bound: float) -> bool:
    """A lower bound at 0 is the physics of a modulus or a time constant, not a choice."""
    return side == "low" and bound == 0.0


def widened(low: float, high: float, side: str, log_space: bool) -> tuple[float, float]:
    """The prior's support with the ``side`` bound widened ×10 (a factor 10 in log space)."""
    if log_space:
        return (low, high * WIDEN) if side == "high" else (low / WIDEN, high)
    width = high - low
    return (low, low + WIDEN * width) if side == "high" else (high - WIDEN * width, high)
