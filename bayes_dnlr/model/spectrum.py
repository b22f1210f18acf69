"""The relaxation spectrum of the DNLR model (paper eq. 12-14).

Cunat's universal spectrum weights mode j by p_j ∝ tau_j^½ (eq. 12). The package also takes the
exponent as a parameter, p_j ∝ tau_j^alpha (alpha = ½ is eq. 12; alpha = 0 puts equal weight on
every decade, larger alpha moves weight to the slow modes): the one-parameter family the
posterior can marginalise when the spectrum's shape is an assumption rather than a measurement.
"""

from __future__ import annotations

import numpy as np

from bayes_dnlr.vocabulary import UNIVERSAL_EXPONENT  # eq. 12: ½


def relaxation_times(tau_max: float, modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """tau_j = tau_max * 10**(-(N - j)/(N - 1) * d), j = 1..N, so tau_N = tau_max (eq. 13-14)."""
    if modes == 1:
        return np.array([float(tau_max)])
    j = np.arange(1, modes + 1)
    return tau_max * 10.0 ** (-(modes - j) / (modes - 1) * decades)


def weights(modes: int = 50, decades: float = 6.0, alpha: float = UNIVERSAL_EXPONENT) -> np.ndarray:
    """p_j = tau_j^alpha / sum_k tau_k^alpha; alpha = ½ is eq. 12. They sum to 1 (eq. 11).

    They do not depend on tau_max: the spectrum keeps its shape when it is shifted.
    """
    s = relaxation_times(1.0, modes, decades)
    if alpha == UNIVERSAL_EXPONENT:
        w = np.sqrt(s)
    else:
        # tau_j/tau_max <= 1: scale by the largest term so that no alpha overflows
        e = float(alpha) * np.log(s)
        w = np.exp(e - e.max())
    return w / w.sum()


def tau_scale(modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """tau_j / tau_max, the fixed shape of the spectrum."""
    return relaxation_times(1.0, modes, decades)
