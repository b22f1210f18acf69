"""Reading tensile tests; conversions of the paper (eq. 1-8); windows; input checks.

This module is being written: ``TestData`` below is the contract the rest of the package uses.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayes_dnlr.errors import BayesDnlrError


class DataError(BayesDnlrError, ValueError):
    """Bad test data; the message names the file, the row (line number) and the column."""


@dataclass(frozen=True)
class TestData:
    """One tensile (then relaxation) test, ready for the model.

    All arrays hold every row of the file, in file order (nothing dropped or reordered).
    The model runs from the first sample (history matters) to ``model_end``; the comparison
    with data uses the samples where ``window`` is True.
    """

    path: Path
    sha256: str
    time: np.ndarray              # s
    strain: np.ndarray            # measured axial Hencky strain ε11 (eq. 1)
    strain_input: np.ndarray      # the strain that drives the model (smoothed or measured)
    stress: np.ndarray            # the observable, MPa: σ* (eq. 6), σ (eq. 2) or a stress column
    nominal_strain: np.ndarray    # e = exp(ε) - 1
    nominal_stress: np.ndarray | None  # F/S0, MPa (None when it cannot be derived)
    window: np.ndarray            # bool, the identification interval
    relaxation_start: float | None  # s (resolved: 'auto' -> the detected time)
    strain_rate: float            # mean Hencky strain rate of the loading ramp, 1/s
    observable: str               # sigma_star | sigma | stress

    @property
    def model_end(self) -> int:
        """One past the last sample the model must reach (the last window sample)."""
        return int(np.flatnonzero(self.window)[-1]) + 1

    @property
    def n_points(self) -> int:
        """Number of samples compared with the model (q in the paper)."""
        return int(self.window.sum())
