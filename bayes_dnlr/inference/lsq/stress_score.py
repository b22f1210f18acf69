"""Does a stress-blind fit need a stress shift? The score test of the Eyring shift held off.

The stress shift a_σ = x/sinh x, x = |σ|/sigma_s (docs/theory.md, "The shift factor") is off when
sigma_s = ∞; in η = 1/sigma_s², ln a_σ = −η σ²/6 + O(η²), so the model is smooth in η at η = 0 and
the stress-blind model is the boundary η = 0. The score test asks how far the data pull η from it
(``sensitivity.score_test``: one Gauss-Newton step from the stress-blind optimum, the other
parameters re-optimised with it). A step above its sd (one-sided: η cannot be negative) says that
the curve bends where the stress is high more than linear relaxation explains: the stress-blind
spectrum then reads the material's nonlinearity as relaxation, and its E(t) beyond the linear
range is not the material's. 1/sqrt(step) is the sigma_s the data point to, and so where that range
ends (inference/modulus_window.py ``linear_range``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.lsq.sensitivity import score_test

STRESS_Z = 2.326        # one-sided 1 %: the data pull η = 1/sigma_s² above 0
PROBE = 100.0           # the finite difference's sigma_s, in units of the test's largest |stress|


def stress_column(cfg: Config, test, params: Mapping[str, float], rows: np.ndarray) -> np.ndarray | None:
    """∂σ/∂η at η = 0 on the compared samples (``rows``: their mask over the samples up to the
    model's end; η = 1/sigma_s²): a forward difference
    through the shifted model at sigma_s = PROBE × max|σ| (a_σ within 2e-5 of 1, smooth in η, so
    the difference's error is of that order). None for a test without stress."""
    from bayes_dnlr.inference.test_model import model_of

    rows = np.asarray(rows, dtype=bool)
    seen = np.asarray(test.stress, dtype=float)[: rows.size][rows]
    top = float(np.max(np.abs(seen))) if seen.size else 0.0
    if not top > 0:
        return None
    sigma_s = PROBE * top
    shifted = cfg.with_shift(stress="eyring")
    blind = {k: float(v) for k, v in params.items()}
    model = model_of(cfg, test)
    base = model.stress(blind)
    bent = model_of(shifted, test).stress({**blind, "sigma_s": sigma_s})
    return ((bent - base) * sigma_s**2)[rows]


def stress_score(cfg: Config, test, params: Mapping[str, float], X: np.ndarray,
                 residuals: np.ndarray, sigma0: float, rows: np.ndarray,
                 whiten=None) -> dict[str, Any] | None:
    """The score test of the stress shift held off, on the compared samples: {step, sd, z, ok,
    sigma_s (the value the step points to, to first order in η; None when the step is not
    positive)}.
    ``whiten``: the discrepancy's whitening operator, under model error (then σ0 = 1). None when
    the model has a stress shift already or the test has no stress."""
    if cfg.model.shift.stress != "none":
        return None
    x = stress_column(cfg, test, params, rows)
    if x is None:
        return None
    if whiten is not None:
        X, x, residuals, sigma0 = whiten(X), whiten(x), whiten(residuals), 1.0
    s = score_test(X, x, residuals, sigma0)
    step = s["step"]
    return {**s, "ok": not s["z"] > STRESS_Z,
            "sigma_s": 1.0 / math.sqrt(step) if math.isfinite(step) and step > 0 else None}
