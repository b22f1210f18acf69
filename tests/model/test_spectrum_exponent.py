"""The spectrum's exponent alpha (p_j ∝ tau_j^alpha; eq. 12 has ½): the model, its derivative,
least squares and the sampling coordinate. At alpha = ½ everything is the paper's model bit for
bit."""

from __future__ import annotations

import numpy as np
import pytest
from support.model import RELAX, TABLE3_5E3, jittered, ramp

from bayes_dnlr.config import ALPHA_PRIOR, parse_config
from bayes_dnlr.inference.lsq.problem import LsqProblem
from bayes_dnlr.inference.posterior.priors import Prior, build_priors
from bayes_dnlr.model import DNLR, relaxation_times, weights
from bayes_dnlr.workflows.truth_forms import generate

RAW = {"name": "t", "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                             "observable": "stress"}}


def grids():
    t, e = ramp(5e-3, 1.9, 1500)
    yield "uniform ramp", t, e, None
    t, e = jittered(1500, 0.15, hold=400.0, n_hold=600)
    yield "jittered, hold", t, e, 380.0
    t, e = jittered(300, 0.6, seed=5)
    yield "wide jitter", t, e, None


def test_weights_at_one_half_are_eq_12_exactly_and_sum_to_one():
    s = np.sqrt(relaxation_times(1.0, 50, 6.0))
    np.testing.assert_array_equal(weights(50, 6.0, 0.5), s / s.sum())
    for a in (-0.5, 0.0, 0.3, 2.0, 9.0):
        p = weights(50, 6.0, a)
        assert p.sum() == pytest.approx(1.0, abs=1e-14) and np.all(np.isfinite(p))
    np.testing.assert_allclose(weights(50, 6.0, 0.0), np.full(50, 0.02), rtol=1e-14)


@pytest.mark.parametrize("case", list(grids()), ids=lambda c: c[0])
def test_stress_is_bit_identical_at_one_half_and_matches_an_independent_integrator(case):
    _, t, e, switch = case
    m = DNLR(t, e, relaxation_start=switch)
    base = RELAX if m.has_relaxation else TABLE3_5E3
    np.testing.assert_array_equal(m.stress({**base, "alpha": 0.5}), m.stress(base))
    for a in (0.0, 0.3, 0.8):
        ref = generate(t, e, base, switch, "spectrum-power", a).stress
        s = m.stress({**base, "alpha": a})
        assert np.max(np.abs(s - ref)) < 1e-12 * np.max(np.abs(ref))
        theta = np.array([[base[k] for k in base] + [a]])
        np.testing.assert_array_equal(m.stress_batch(theta, [*base, "alpha"])[0], s)


@pytest.mark.parametrize("case", list(grids()), ids=lambda c: c[0])
def test_the_alpha_derivative_of_the_basis_matches_finite_differences(case):
    _, t, e, switch = case
    m = DNLR(t, e, relaxation_start=switch)
    tr = 40.0 if m.has_relaxation else None
    for a in (0.2, 0.5, 0.9):
        b = m.basis(5.79, tr, grad=True, alpha=a)
        h = 1e-6
        fd = (m.basis(5.79, tr, alpha=a + h).values - m.basis(5.79, tr, alpha=a - h).values) / (2 * h)
        scale = np.abs(b.values).max(axis=0) + 1e-30
        assert np.max(np.abs(b.grad_alpha - fd) / scale) < 1e-8
        assert np.abs(b.grad_alpha[0]).max() == 0.0      # the first sample does not depend on it


def test_an_invalid_alpha_is_refused():
    t, e = ramp(5e-3, 1.0, 50)
    m = DNLR(t, e)
    with pytest.raises(ValueError, match="alpha"):
        m.stress({**TABLE3_5E3, "alpha": np.nan})
    theta = np.array([[2854.0, 2.32, 5.79, np.inf]])
    with pytest.raises(ValueError, match="row 0 of theta: alpha"):
        m.stress_batch(theta, ["E", "G", "tau_max", "alpha"])


def test_least_squares_jacobian_has_the_alpha_column():
    t, e = ramp(5e-3, 1.9, 600)
    y = DNLR(t, e).stress({**TABLE3_5E3, "alpha": 0.4})
    names = ["E", "G", "tau_max", "alpha"]
    bounds = {"E": (100.0, 2e4), "G": (0.0, 50.0), "tau_max": (0.01, 1e4), "alpha": (0.0, 1.0)}
    prob = LsqProblem(t, e, y, np.ones(t.size, bool), None, names, {}, bounds)
    p = {**TABLE3_5E3, "alpha": 0.4}
    J = prob.jacobian(p)
    h = 1e-6
    fd = (prob.predict({**p, "alpha": 0.4 + h}) - prob.predict({**p, "alpha": 0.4 - h})) / (2 * h)
    assert np.max(np.abs(J[:, 3] - fd)) < 1e-6 * np.max(np.abs(fd))
    fixed = LsqProblem(t, e, y, np.ones(t.size, bool), None, names[:3], {"alpha": 0.4},
                       {k: bounds[k] for k in names[:3]})
    assert prob.ssr(p) == fixed.ssr(p) == pytest.approx(0.0, abs=1e-16)


def test_the_spectral_coordinate_carries_the_prior_exactly():
    """z = -10^(-alpha): the density of z, mapped back, is the configured prior of alpha."""
    cfg = parse_config({**RAW, "parameters": {"alpha": ALPHA_PRIOR}})
    priors = build_priors(cfg)
    assert priors.names[-1] == "alpha"
    pa = priors.priors[-1]
    pe = priors.priors[priors.names.index("E")]
    assert pa.spectral and not pa.log_space and pe.log_space      # the E-alpha ridge
    x = np.linspace(0.01, 0.99, 7)
    np.testing.assert_allclose(pa.to_physical(pa.from_physical(x)), x, rtol=1e-14)
    z = np.linspace(-1.0, -0.1, 200001)
    dens = np.exp(pa.logpdf_sampling(z))
    assert np.sum(0.5 * (dens[1:] + dens[:-1]) * np.diff(z)) == pytest.approx(1.0, rel=1e-6)
    mean = np.sum(0.5 * (dens[1:] * pa.to_physical(z[1:]) + dens[:-1] * pa.to_physical(z[:-1]))
                  * np.diff(z))
    xs = np.linspace(0.0, 1.0, 200001)
    px = np.exp(pa.logpdf(xs))
    assert mean == pytest.approx(np.sum(0.5 * (px[1:] * xs[1:] + px[:-1] * xs[:-1]) * np.diff(xs)),
                                 rel=1e-6)


def test_by_default_and_fixed_alpha_is_eq_12_and_every_coordinate_as_before():
    default = parse_config(RAW)
    assert "alpha" not in default.parameters and default.free_parameters == ["E", "G", "tau_max"]
    fixed = parse_config({**RAW, "parameters": {"alpha": {"value": 0.5}}})
    assert fixed.fixed_values == {"alpha": 0.5}
    for cfg in (default, fixed):
        priors = build_priors(cfg)
        assert priors.names == ["E", "G", "tau_max"]
        assert not any(p.spectral or p.log_space for p in priors.priors if p.name in ("E", "G"))
        assert Prior.from_spec("E", cfg.parameters["E"]) == priors.priors[0]
