"""The ``truth:`` section of a synthetic test on the paper's ramp (workflows/simulate.py)."""

from __future__ import annotations

TENSILE = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}      # paper Table 3, interval II, 5e-3 1/s


def truth(**kw):
    """A truth section: the paper's 5e-3 1/s ramp to 1.9 on 2000 points, ``kw`` on top."""
    base = {"params": TENSILE, "strain_rate": 5e-3, "strain_max": 1.9, "n_points": 2000, "seed": 1}
    return {**base, **kw}
