"""Priors: densities equal scipy's, are normalised, carry the log-space Jacobian, never NaN."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import integrate, stats

from bayes_dnlr.config import ParameterSpec, SampledNoise, parse_config
from bayes_dnlr.inference.posterior.priors import Prior, build_priors, sampled_names

CASES = [
    ({"prior": "uniform", "low": 100.0, "high": 20000.0}, stats.uniform(100.0, 19900.0)),
    ({"prior": "log-uniform", "low": 0.01, "high": 1.0e4}, stats.loguniform(0.01, 1.0e4)),
    ({"prior": "normal", "mean": 3.0, "sd": 2.0}, stats.norm(3.0, 2.0)),
    ({"prior": "normal", "mean": 3.0, "sd": 2.0, "low": 0.0, "high": 4.0},
     stats.truncnorm(-1.5, 0.5, loc=3.0, scale=2.0)),
    ({"prior": "log-normal", "median": 5.0, "sd_log": 0.7}, stats.lognorm(0.7, scale=5.0)),
    ({"prior": "half-normal", "scale": 5.0}, stats.halfnorm(scale=5.0)),
]


def _prior(spec: dict, name: str = "x") -> Prior:
    return Prior.from_spec(name, ParameterSpec(**spec))


@pytest.mark.parametrize(("spec", "ref"), CASES)
def test_logpdf_matches_scipy(spec: dict, ref) -> None:
    p = _prior(spec)
    x = np.asarray(ref.ppf(np.linspace(0.01, 0.99, 41)))
    np.testing.assert_allclose(p.logpdf(x), ref.logpdf(x), rtol=1e-10, atol=1e-12)


TRUNCATED = [
    {"prior": "log-normal", "median": 5.0, "sd_log": 0.7, "low": 2.0, "high": 30.0},
    {"prior": "half-normal", "scale": 5.0, "low": 1.0, "high": 8.0},
    {"prior": "normal", "mean": 0.0, "sd": 1.0, "low": 6.0, "high": 9.0},   # far tail
    {"prior": "log-uniform", "low": 0.01, "high": 1.0e4},
    {"prior": "uniform", "low": -2.0, "high": 3.0},
]


@pytest.mark.parametrize("spec", TRUNCATED)
def test_truncated_density_integrates_to_one_in_both_coordinates(spec: dict) -> None:
    p = _prior(spec)
    lo, hi = p.low, p.high
    if p.log_space:   # integrate in z = ln x, where the sampler works
        mass, _ = integrate.quad(lambda z: math.exp(p.logpdf_sampling(np.array(z))),
                                 math.log(lo), math.log(hi), limit=200)
        # P(x <= c) from the z density equals the integral of the physical density
        c = math.sqrt(lo * hi)
        pz, _ = integrate.quad(lambda z: math.exp(p.logpdf_sampling(np.array(z))), math.log(lo),
                               math.log(c), limit=200)
        px, _ = integrate.quad(lambda x: math.exp(p.logpdf(np.array(x))), lo, c, limit=200,
                               points=[lo * 1.001])
        assert pz == pytest.approx(px, rel=1e-6)
    else:
        mass, _ = integrate.quad(lambda x: math.exp(p.logpdf(np.array(x))), lo, hi, limit=200)
    assert mass == pytest.approx(1.0, rel=1e-7)


def test_log_uniform_is_flat_in_log_space() -> None:
    p = _prior({"prior": "log-uniform", "low": 0.01, "high": 1.0e4})
    assert p.log_space
    z = np.log([0.02, 1.0, 500.0, 9000.0])
    lp = p.logpdf_sampling(z)
    np.testing.assert_allclose(lp, -math.log(math.log(1.0e6)))


def test_outside_support_is_minus_inf_never_nan_or_warning() -> None:
    specs = [c[0] for c in CASES] + TRUNCATED
    bad = np.array([-1.0e300, -5.0, -0.0, 0.0, 1.0e6, 1.0e300, np.inf, -np.inf, np.nan])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for spec in specs:
            p = _prior(spec)
            lp = p.logpdf(bad)
            assert not np.isnan(lp).any()
            assert lp[-1] == -np.inf          # NaN input
            assert lp[6] == -np.inf and lp[7] == -np.inf
            lz = p.logpdf_sampling(np.array([1.0e6, -1.0e6, np.nan, np.inf, -np.inf]))
            assert not np.isnan(lz).any()
            assert lz[2] == -np.inf


def test_sample_follows_the_density() -> None:
    rng = np.random.default_rng(3)
    for spec, ref in CASES[:3] + CASES[4:]:
        x = _prior(spec).sample(rng, 4000)
        assert stats.kstest(x, ref.cdf).pvalue > 1e-3, spec
    spec = TRUNCATED[0]
    x = _prior(spec).sample(rng, 2000)
    assert x.min() >= 2.0 and x.max() <= 30.0


def test_build_priors_from_config() -> None:
    raw = {
        "name": "t",
        "data": {"file": "x.csv", "columns": {"time": "t", "eps11": "e", "stress": "s"},
                 "observable": "stress"},
        "parameters": {"E": {"prior": "uniform", "low": 100, "high": 20000},
                       "G": {"value": 2.3},
                       "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 1.0e4}},
        "noise": {"sigma0": {"prior": "half-normal", "scale": 5.0}, "discrepancy": "none"},
    }
    cfg = parse_config(raw)
    ps = build_priors(cfg)
    assert ps.names == sampled_names(cfg) == ["E", "tau_max", "sigma0"]
    assert list(ps.log_space) == [False, True, False]
    theta = np.array([[2854.0, 5.79, 0.3], [2854.0, 5.79, -0.3], [50.0, 5.79, 0.3]])
    z = ps.from_physical(theta)
    np.testing.assert_allclose(ps.to_physical(z), theta)
    lp = ps.log_prior(z)
    expected = (-math.log(19900.0) - math.log(math.log(1.0e6))
                + stats.halfnorm(scale=5.0).logpdf(0.3))
    assert lp[0] == pytest.approx(expected, rel=1e-12)
    assert lp[1] == -np.inf and lp[2] == -np.inf


def test_discrepancy_hyperparameters_are_sampled_in_log_space() -> None:
    """disc_amplitude (half-normal) and disc_length (log-uniform) follow the model parameters and
    sigma0; both are sampled in ln x, the density carrying the Jacobian x; a fixed one is left out."""
    from bayes_dnlr.config import ParameterSpec

    raw = {"name": "t", "data": {"file": "x.csv", "columns": {"time": "t", "eps11": "e", "stress": "s"},
                                 "observable": "stress"},
           "noise": {"sigma0": 0.3, "discrepancy": {"kernel": "exp"}}}
    cfg = parse_config(raw)
    resolved = {"disc_amplitude": ParameterSpec(prior="half-normal", scale=2.0),
                "disc_length": ParameterSpec(prior="log-uniform", low=1.0, high=1000.0)}
    ps = build_priors(cfg, resolved)
    assert ps.names == sampled_names(cfg) == ["E", "G", "tau_max", "disc_amplitude", "disc_length"]
    assert list(ps.log_space) == [False, False, True, True, True]
    x = np.array([[2854.0, 2.3, 5.79, 0.7, 40.0]])
    lp = ps.log_prior(ps.from_physical(x))[0]
    expected = (-math.log(19900.0) - math.log(50.0) - math.log(math.log(1.0e6))
                + stats.halfnorm(scale=2.0).logpdf(0.7) + math.log(0.7) - math.log(math.log(1000.0)))
    assert lp == pytest.approx(expected, rel=1e-12)
    raw["noise"]["discrepancy"]["length"] = {"value": 30.0}
    cfg = parse_config(raw)
    resolved["disc_length"] = ParameterSpec(value=30.0)
    assert build_priors(cfg, resolved).names == sampled_names(cfg) == [
        "E", "G", "tau_max", "disc_amplitude"]


def test_sampled_sigma0_prior_kinds() -> None:
    p = Prior.from_spec("sigma0", SampledNoise(prior="log-uniform", low=0.01, high=10.0),
                        key="noise.sigma0")
    assert p.log_space and p.low == 0.01 and p.high == 10.0
    assert p.logpdf(np.array([0.005]))[0] == -np.inf


def test_log_ndtr_equals_scipy() -> None:
    from scipy.special import log_ndtr as reference

    from bayes_dnlr.inference.posterior.priors import log_ndtr

    x = np.concatenate([np.linspace(-80.0, 20.0, 20001), [-1e3, -1e5, 0.0, -37.0, -36.999]])
    ours = np.array([log_ndtr(v) for v in x])
    # libm's erfc is good to ~1e-13 relative in the far right tail (log Φ ~ -1e-80 there)
    np.testing.assert_allclose(ours, reference(x), rtol=5e-13, atol=0)
    middle = np.abs(x) < 8.0
    np.testing.assert_allclose(ours[middle], reference(x[middle]), rtol=2e-14, atol=1e-300)
    assert log_ndtr(-np.inf) == -np.inf and log_ndtr(np.inf) == 0.0 and np.isnan(log_ndtr(np.nan))
