"""The universal relaxation spectrum of the DNLR model (paper eq. 12-14)."""

from __future__ import annotations

import numpy as np


def relaxation_times(tau_max: float, modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """tau_j = tau_max * 10**(-(N - j)/(N - 1) * d), j = 1..N, so tau_N = tau_max (eq. 13-14)."""
    if modes == 1:
        return np.array([float(tau_max)])
    j = np.arange(1, modes + 1)
    return tau_max * 10.0 ** (-(modes - j) / (modes - 1) * decades)


def weights(modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """p_j = sqrt(tau_j) / sum_k sqrt(tau_k) (eq. 12); they sum to 1 (eq. 11).

    They do not depend on tau_max: the spectrum keeps its shape when it is shifted.
    """
    s = np.sqrt(relaxation_times(1.0, modes, decades))
    return s / s.sum()


def tau_scale(modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """tau_j / tau_max, the fixed shape of the spectrum."""
    return relaxation_times(1.0, modes, decades)
