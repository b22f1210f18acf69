"""The discrepancy's hyperparameter search: the quasi-Newton search reaches the Nelder-Mead optimum
it replaced, and the REML likelihood laid out once equals the one-shot function."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.config import DiscrepancyConfig
from bayes_dnlr.inference.discrepancy import gp
from bayes_dnlr.inference.discrepancy.axis import make_axis
from bayes_dnlr.inference.discrepancy.hyper import (
    Hyper,
    amplitude_prior,
    hyper_fit,
    restricted_likelihood,
    restricted_log_likelihood,
    search_priors,
)


def _case(seed: int, amplitude: float, n: int = 400):
    """Residuals of a linear model: noise 0.3 plus (amplitude > 0) a matern32 discrepancy."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 200.0, n)
    r = rng.normal(0.0, 0.3, n)
    if amplitude > 0:
        K = gp.covariance(x, amplitude, 25.0, "matern32")
        r += rng.multivariate_normal(np.zeros(n), K + 1e-10 * np.eye(n))
    X = np.column_stack([np.ones(n), x / 200.0, np.exp(-x / 30.0)])
    return x, r, X


def test_the_prepared_likelihood_equals_the_one_shot_function() -> None:
    x, r, X = _case(1, 1.0)
    for kind in ("exp", "matern32"):
        f = restricted_likelihood(x, r, X, kind, 0.0)
        for h in (Hyper(0.3, 1.0, 25.0), Hyper(0.5, 1e-3, 2.0), Hyper(0.2, 3.0, 150.0)):
            assert f(h) == restricted_log_likelihood(x, r, X, h, kind, 0.0)
        assert f(Hyper(0.3, -1.0, 25.0)) == -np.inf


@pytest.mark.parametrize("amplitude", [0.0, 1.0])
@pytest.mark.parametrize("sigma0", [None, 0.3])
@pytest.mark.parametrize("kind", ["exp", "matern32"])
def test_the_gradient_search_reaches_the_nelder_mead_optimum(kind, sigma0, amplitude) -> None:
    x, r, X = _case(7, amplitude)
    axis = make_axis("time", x, x)
    rms = float(np.sqrt(np.mean(r**2)))
    priors = search_priors(DiscrepancyConfig(), rms, axis)
    priors["disc_amplitude"] = amplitude_prior(DiscrepancyConfig(), rms)
    loglik = restricted_likelihood(x, r, X, kind)
    floor = 0.05
    slow = hyper_fit(kind, loglik, axis, r, priors, sigma0, floor, search="nelder-mead")
    fast = hyper_fit(kind, loglik, axis, r, priors, sigma0, floor)
    # the same maximum (never a worse one by more than the optimizers' tolerance) ...
    assert fast.log_posterior >= slow.log_posterior - 1e-4
    # ... with far fewer likelihood evaluations where there is model error to describe (without,
    # Nelder-Mead's simplex collapses onto the amplitude's floor in about as few)
    if amplitude > 0:
        assert fast.evaluations < slow.evaluations / 2
    if slow.hyper.amplitude < 1e-5:    # no model error: both end on the amplitude's floor
        assert fast.hyper.amplitude == pytest.approx(slow.hyper.amplitude, rel=1e-6)
    else:                              # an identified optimum: the same hyperparameters
        for field in ("sigma0", "amplitude", "length"):
            assert getattr(fast.hyper, field) == pytest.approx(getattr(slow.hyper, field), rel=2e-2)
