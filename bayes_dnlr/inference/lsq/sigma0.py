"""The noise level sigma0 of the stress (paper eq. 30-32: V(ε) = sigma0²).

From the config ``noise.sigma0``:
- a number (MPa)                         -> (value, "config")
- ``residuals``                          -> s = sqrt(SSR/(q - p)) of the fit, "residuals"
- ``{baseline: {time_max: ...}}``        -> sd of the signal where the specimen is not yet loaded,
                                            "baseline"
- a prior (sigma0 sampled in the MCMC)   -> the residual estimate, "residuals (sigma0 sampled in MCMC)"
"""

from __future__ import annotations

import math

import numpy as np

from bayes_dnlr.config import BaselineNoise, Config, SampledNoise
from bayes_dnlr.errors import BayesDnlrError

SOURCE_CONFIG = "config"
SOURCE_RESIDUALS = "residuals"
SOURCE_BASELINE = "baseline"
SOURCE_SAMPLED = "residuals (sigma0 sampled in MCMC)"


def residual_sigma(residuals: np.ndarray, n_free: int) -> float:
    """s = sqrt(SSR / (q - p)), the unbiased estimate of sigma0 from the fit residuals."""
    r = np.asarray(residuals, dtype=float)
    dof = r.size - n_free
    if dof <= 0:
        raise BayesDnlrError(f"cannot estimate sigma0 from the residuals: {r.size} points for "
                             f"{n_free} parameters")
    return math.sqrt(float(r @ r) / dof)


def high_frequency_sd(residuals: np.ndarray) -> float:
    """The sd of the sample-to-sample scatter of residuals in axis order: the robust spread (MAD) of
    their second differences over √6, the sd of a second difference of independent noise. A smooth
    misfit adds almost nothing to second differences, so this measures the measurement noise (from
    above: a rough misfit adds its share). The noise floor of the discrepancy's σ0."""
    d2 = np.diff(np.asarray(residuals, dtype=float), 2)
    if d2.size < 3:
        return 0.0
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return mad / 0.6744897501960817 / math.sqrt(6.0)


def resolve_sigma0(cfg: Config, test, residuals: np.ndarray | None = None) -> tuple[float, str]:
    """sigma0 (MPa) and where it comes from, following ``cfg.noise.sigma0``.

    ``test`` is the ``bayes_dnlr.data.TestData`` (needed for the baseline form); ``residuals`` the fit
    residuals on the window (needed for 'residuals' and for a sampled sigma0).
    """
    spec = cfg.noise.sigma0
    if isinstance(spec, int | float):      # one row's sd; a bin of k rows (data.reduce) has σ0/√k
        return float(spec) / math.sqrt(getattr(test, "rows_per_point", 1)), SOURCE_CONFIG
    if isinstance(spec, BaselineNoise):
        from bayes_dnlr.data import baseline_sd

        value = float(baseline_sd(test, spec.baseline))
        if not (math.isfinite(value) and value > 0):
            raise BayesDnlrError(f"noise.sigma0: the baseline gives sd = {value}: choose a baseline "
                                 "window with unloaded samples, or give sigma0 as a number")
        return value, SOURCE_BASELINE
    if residuals is None:
        raise BayesDnlrError("noise.sigma0 from the residuals needs the fit residuals (run fit first)")
    value = residual_sigma(residuals, len(cfg.free_parameters))
    if isinstance(spec, SampledNoise):
        return value, SOURCE_SAMPLED
    return value, SOURCE_RESIDUALS
