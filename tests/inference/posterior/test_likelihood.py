"""The vectorised log-posterior: equals the brute-force Gaussian density, -inf (never NaN) outside."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import stats
from support.likelihood import discrepancy_config, discrepancy_priors, white_config, wobbly
from support.sampling import TRUTH, TRUTH_RELAX, make_test

from bayes_dnlr.config import parse_config
from bayes_dnlr.inference.posterior.density import build_log_posterior
from bayes_dnlr.inference.posterior.priors import build_priors
from bayes_dnlr.model import simulate


def test_matches_brute_force_gaussian_density() -> None:
    test = make_test()
    cfg = white_config()
    post = build_log_posterior(cfg, test, sigma0=0.3)
    assert post.names == ["E", "G", "tau_max"]
    thetas = np.array([[2854.0, 2.32, 5.79], [2800.0, 2.5, 6.5], [3000.0, 2.0, 4.0]])
    z = post.priors.from_physical(thetas)
    lp = post(z)
    for k, th in enumerate(thetas):
        mu = simulate(test.time, test.strain, dict(zip(post.names, th, strict=True)))
        ll = stats.norm(mu, 0.3).logpdf(test.stress).sum()
        lprior = -math.log(19900.0) - math.log(50.0) - math.log(math.log(1.0e6))
        # tau_max is sampled as ln(tau_max): the log-uniform density there is flat
        assert lp[k] == pytest.approx(ll + lprior, rel=1e-11, abs=1e-8)
    # vectorised over walkers == one by one
    np.testing.assert_array_equal(lp, np.concatenate([post(zi[None]) for zi in z]))
    assert post.n_evals == 6


def test_fixed_parameter_and_sampled_sigma0() -> None:
    test = make_test(sigma=0.5, seed=2)
    cfg = white_config(sigma0={"prior": "half-normal", "scale": 5.0},
               parameters={"G": {"value": 2.32}})
    post = build_log_posterior(cfg, test, sigma0=None)
    assert post.names == ["E", "tau_max", "sigma0"]
    th = np.array([[2854.0, 5.79, 0.5], [2854.0, 5.79, 0.7]])
    lp = post(post.priors.from_physical(th))
    for k in range(2):
        mu = simulate(test.time, test.strain, {"E": th[k, 0], "G": 2.32, "tau_max": th[k, 1]})
        ll = stats.norm(mu, th[k, 2]).logpdf(test.stress).sum()
        lprior = (-math.log(19900.0) - math.log(math.log(1.0e6))
                  + stats.halfnorm(scale=5.0).logpdf(th[k, 2]))
        assert lp[k] == pytest.approx(ll + lprior, rel=1e-11)
    assert lp[0] > lp[1]  # the true noise level is more likely


def test_relaxation_model_with_window_gap() -> None:
    window = np.ones(700, bool)
    window[100:150] = False
    test = make_test(relaxation=True, window=window)
    cfg = white_config(relaxation=True)
    post = build_log_posterior(cfg, test, sigma0=0.3)
    assert post.names == ["E", "G", "tau_max", "sigma_inf", "tau_max_R"]
    th = np.array([[TRUTH_RELAX[k] for k in post.names]])
    mu = simulate(test.time, test.strain, TRUTH_RELAX, relaxation_start=test.relaxation_start)
    ll = stats.norm(mu[window], 0.3).logpdf(test.stress[window]).sum()
    lprior = build_priors(cfg).log_prior(post.priors.from_physical(th))[0]
    assert post(post.priors.from_physical(th))[0] == pytest.approx(ll + lprior, rel=1e-11)


def test_outside_support_and_garbage_give_minus_inf_without_running_the_model() -> None:
    test = make_test()
    cfg = white_config(parameters={"tau_max": {"prior": "uniform", "low": 0.0, "high": 100.0}})
    post = build_log_posterior(cfg, test, sigma0=0.3)
    z = np.array([[2854.0, 2.32, 5.79],
                  [2854.0, 2.32, 0.0],        # on the support's edge: the model refuses tau = 0
                  [2854.0, 2.32, -1.0],       # outside
                  [50.0, 2.32, 5.79],         # E below its prior
                  [np.nan, 2.32, 5.79],
                  [np.inf, 2.32, 5.79],
                  [2854.0, 2.32, np.inf]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lp = post(z)
    assert np.isfinite(lp[0])
    assert np.all(lp[1:] == -np.inf)
    assert post.n_evals == 2   # only the two points inside the support reached the model


def test_true_parameters_are_near_the_maximum() -> None:
    test = make_test(seed=5)
    post = build_log_posterior(white_config(), test, sigma0=0.3)
    z0 = post.priors.from_physical(np.array([[TRUTH[k] for k in post.names]]))
    far = z0 + np.array([[60.0, 0.0, 0.0]])   # 60 MPa off in E: many sd away for 2000 points
    assert post(z0)[0] > post(far)[0] + 10.0


def test_overflowing_parameters_give_minus_inf_silently() -> None:
    test = make_test()
    cfg = white_config(parameters={"E": {"prior": "normal", "mean": 3000.0, "sd": 1000.0}})
    post = build_log_posterior(cfg, test, sigma0=0.3)
    z = post.priors.from_physical(np.array([[1.0e200, 2.32, 5.79], [-1.0e300, 2.32, 5.79]]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lp = post(z)
    assert np.all(lp == -np.inf)


# ------------------------------------------------------------------ the model-discrepancy likelihood

@pytest.mark.parametrize("kernel", ["exp", "matern32"])
@pytest.mark.parametrize("axis", ["time", "strain"])
def test_discrepancy_likelihood_matches_dense_normal(kernel, axis) -> None:
    from bayes_dnlr.inference.discrepancy import gp

    test = wobbly(make_test(n=400))
    cfg = discrepancy_config(kernel, axis)
    post = build_log_posterior(cfg, test, sigma0=0.3,
                               discrepancy_priors=discrepancy_priors(1e3 if axis == "time" else 1.0))
    assert post.names == ["E", "G", "tau_max", "disc_amplitude", "disc_length"]
    length = 12.0 if axis == "time" else 0.02
    thetas = np.array([[2854.0, 2.32, 5.79, 0.8, length], [2700.0, 2.4, 6.5, 0.2, 3 * length]])
    ll = post.log_likelihood(thetas)
    x = test.time if axis == "time" else test.strain_input
    for k, th in enumerate(thetas):
        mu = simulate(test.time, test.strain_input, dict(zip(post.names[:3], th[:3], strict=True)))
        K = gp.covariance(x, th[3], th[4], kernel, 0.3)          # in the file's order
        ref = stats.multivariate_normal(mu, K).logpdf(test.stress)
        assert ll[k] == pytest.approx(ref, abs=1e-9 * test.time.size)
    # the posterior adds the log prior in sampling coordinates
    lp = post(post.priors.from_physical(thetas))
    np.testing.assert_allclose(lp, ll + post.priors.log_prior(post.priors.from_physical(thetas)))


def test_discrepancy_likelihood_on_a_relaxation_test_with_a_window_gap() -> None:
    from bayes_dnlr.inference.discrepancy import gp

    window = np.ones(700, bool)
    window[100:150] = False
    test = make_test(relaxation=True, window=window)
    cfg = discrepancy_config("exp", "time", relaxation=True)
    post = build_log_posterior(cfg, test, sigma0=0.3, discrepancy_priors=discrepancy_priors(1e3))
    th = np.array([[*TRUTH_RELAX.values(), 0.5, 30.0]])
    mu = simulate(test.time, test.strain, TRUTH_RELAX, relaxation_start=test.relaxation_start)[window]
    K = gp.covariance(test.time[window], 0.5, 30.0, "exp", 0.3)
    ref = stats.multivariate_normal(mu, K).logpdf(test.stress[window])
    assert post.log_likelihood(th)[0] == pytest.approx(ref, abs=1e-9 * window.sum())


def test_discrepancy_with_fixed_hyperparameters_and_bad_points() -> None:
    from bayes_dnlr.config import ParameterSpec

    test = make_test(n=300)
    raw = discrepancy_config("matern32", "time").model_dump(mode="json", exclude_none=True)
    raw["noise"]["discrepancy"]["length"] = {"value": 20.0}
    cfg = parse_config(raw)
    priors = {"disc_amplitude": ParameterSpec(prior="half-normal", scale=1.0),
              "disc_length": ParameterSpec(value=20.0)}
    post = build_log_posterior(cfg, test, sigma0=0.3, discrepancy_priors=priors)
    assert post.names == ["E", "G", "tau_max", "disc_amplitude"]
    z = post.priors.from_physical(np.array([[2854.0, 2.32, 5.79, 0.5], [2854.0, 2.32, 5.79, 0.5]]))
    z[1, 3] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lp = post(z)
    assert np.isfinite(lp[0]) and lp[1] == -np.inf
    with pytest.raises(ValueError, match="needs its resolved priors"):
        build_log_posterior(cfg, test, sigma0=0.3)
