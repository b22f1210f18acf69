"""The references as observations (inference/references): predictions against the model layer,
gradients against finite differences, the likelihood term, the linearized analysis with data
references against the exact stacked least squares, and the check's rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from bayes_dnlr.inference.references import compare
from bayes_dnlr.inference.references.condition import condition, physical_to_u
from bayes_dnlr.inference.references.terms import (
    LOSS,
    RELAXATION,
    STORAGE,
    Reference,
    ReferenceLikelihood,
    gradient,
    log_likelihood,
    predict,
    regime,
)
from bayes_dnlr.model.modulus import complex_modulus, relaxation_modulus

P = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}


def ref(quantity, at, value, sd, use="data", test=None) -> Reference:
    m = len(value)
    return Reference(0, "r", "other", use, np.array(quantity), np.asarray(at, float),
                     np.asarray(value, float), np.asarray(sd, float), test, np.ones(m), np.full(m, np.nan))


def test_predictions_are_the_model_layer_s():
    r = ref([STORAGE, LOSS, RELAXATION, STORAGE], [45.0, 45.0, 0.5, 5e6], [1, 1, 1, 1], [1, 1, 1, 1])
    got = predict(r, {**P, "alpha": 0.4})
    s, loss = complex_modulus(45.0, P["E"], P["G"], P["tau_max"], 0.4)
    assert got[0] == pytest.approx(s[0]) and got[1] == pytest.approx(loss[0])
    assert got[2] == pytest.approx(relaxation_modulus(0.5, P["E"], P["G"], P["tau_max"], 0.4)[0])
    assert got[3] == pytest.approx(P["E"], rel=1e-6)
    draws = {"E": np.array([2800.0, 2900.0]), "G": 2.32, "tau_max": np.array([5.0, 6.0])}
    many = predict(r, draws)
    assert many.shape == (2, 4)
    assert many[1, 0] == pytest.approx(predict(r, {"E": 2900.0, "G": 2.32, "tau_max": 6.0})[0])


def test_the_regime_says_when_every_mode_is_frozen():
    assert regime(ref([STORAGE], [5e6], [1], [1]), P)[0] == "frozen"
    assert regime(ref([STORAGE], [45.0], [1], [1]), P)[0] == "spectrum"
    assert regime(ref([RELAXATION], [0.5], [1], [1]), P)[0] == "relaxation"


@pytest.mark.parametrize("names", [["E", "G", "tau_max"], ["E", "G", "tau_max", "alpha"]])
def test_gradient_against_finite_differences(names):
    r = ref([STORAGE, LOSS, RELAXATION], [0.3, 3.0, 0.5], [1, 1, 1], [1, 1, 1])
    point = {**P, "alpha": 0.45}
    g = gradient(r, point, names)
    for j, k in enumerate(names):
        h = 1e-6 * abs(point[k])
        up, down = dict(point), dict(point)
        up[k] += h
        down[k] -= h
        np.testing.assert_allclose(g[:, j], (predict(r, up) - predict(r, down)) / (2 * h), rtol=1e-5)


def test_the_likelihood_is_gaussian_in_the_prediction():
    r = ref([STORAGE, LOSS], [1.0, 1.0], [2400.0, 400.0], [30.0, 10.0])
    g = predict(r, P)
    expected = sum(-0.5 * ((v - m) / s) ** 2 - math.log(s) - 0.5 * math.log(2 * math.pi)
                   for v, m, s in zip(r.value, g, r.sd, strict=True))
    assert log_likelihood([r], P)[0] == pytest.approx(expected)
    term = ReferenceLikelihood([r], ["E", "tau_max"], lambda k, t: k, {"G": 2.32})
    theta = np.array([[2854.0, 5.79], [2700.0, 5.0]])
    assert term(theta)[0] == pytest.approx(expected)
    assert term(theta)[1] == pytest.approx(log_likelihood([r], {"E": 2700.0, "G": 2.32, "tau_max": 5.0})[0])


def _tensile_problem():
    """A linear-Gaussian stand-in for a tensile test's analysis: the criterion |y − Xβ|² with X the
    sensitivities of E(t) at a few times (a ramp sees E(t) over its duration)."""
    t = np.geomspace(0.5, 300, 40)

    def model(beta):
        return relaxation_modulus(t, beta[0], beta[1], beta[2])

    truth = np.array([3000.0, 2.4, 5.0])
    rng = np.random.default_rng(3)
    y = model(truth) + 3.0 * rng.standard_normal(t.size)
    sol = least_squares(lambda b: (y - model(b)) / 3.0, truth * 0.95, x_scale=[30, 0.1, 0.1])
    return model, y, sol


def test_conditioning_agrees_with_the_exact_stacked_least_squares():
    model, y, sol = _tensile_problem()
    names, is_log = ["E", "G", "tau_max"], np.array([False, False, True])
    est = dict(zip(names, sol.x, strict=True))
    cov = np.linalg.inv(sol.jac.T @ sol.jac)
    truth = {"E": 3000.0, "G": 2.4, "tau_max": 5.0}
    q, at, sd = [STORAGE, STORAGE, LOSS], [5e6, 10.0, 10.0], np.array([30.0, 28.0, 3.0])
    values = predict(ref(q, at, [1, 1, 1], sd), truth) + sd * np.array([0.7, -1.1, 0.4])
    r = ref(q, at, values, sd)
    c = condition([r], names, is_log, est, physical_to_u(cov, sol.x, is_log), None,
                  {"E": (100, 2e4), "G": (0, 50), "tau_max": (0.01, 1e4)}, lambda k, t: k, {})
    assert c.converged

    def beta(u):
        b = np.array(u, dtype=float)
        b[is_log] = np.exp(b[is_log])
        return b

    def both(u):
        b = beta(u)
        p = dict(zip(names, b, strict=True))
        return np.concatenate([(y - model(b)) / 3.0, (r.value - predict(r, p)) / r.sd])

    u0 = np.where(is_log, np.log(sol.x), sol.x)
    exact = least_squares(both, u0, x_scale=np.sqrt(np.diag(physical_to_u(cov, sol.x, is_log))),
                          method="lm")
    b = beta(exact.x)
    sd = np.sqrt(np.diag(c.covariance))
    got = np.array([c.estimate[k] for k in names])
    assert np.all(np.abs(got - b) <= 0.05 * sd), (got, b, sd)
    v_exact = np.linalg.inv(exact.jac.T @ exact.jac)
    np.testing.assert_allclose(np.sqrt(np.diag(c.covariance_u)), np.sqrt(np.diag(v_exact)), rtol=0.02)
    assert sd[0] < np.sqrt(cov[0, 0])                   # the references shrink E's interval


def test_the_sandwich_carries_over():
    """With a working Fisher matrix A and an estimator covariance V ≠ A⁻¹, the references add their
    information to both: V' = A'⁻¹ (AVA + JᵀWJ) A'⁻¹ (a reference with no weight changes nothing)."""
    names, is_log = ["E", "G", "tau_max"], [False, False, True]
    est = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
    A = np.diag([1 / 20.0**2, 1 / 0.001**2, 1 / 0.01**2])
    V = 4.0 * np.linalg.inv(A)
    far = ref([STORAGE], [5e6], [2854.0], [1e9])
    c = condition([far], names, is_log, est, V, A, {k: (0, 1e5) for k in names}, lambda k, t: k, {})
    scale = np.sqrt(np.outer(np.diag(V), np.diag(V)))
    np.testing.assert_allclose(c.covariance_u / scale, V / scale, atol=1e-9)
    scale = np.sqrt(np.outer(np.diag(A), np.diag(A)))
    np.testing.assert_allclose(c.fisher_u / scale, A / scale, atol=1e-9)
    near = ref([STORAGE], [5e6], [2854.0], [5.0])          # E'(5 MHz) = E: E's variance only
    c = condition([near], names, is_log, est, V, A, {k: (0, 1e5) for k in names}, lambda k, t: k, {})
    a2 = A[0, 0] + 1 / 5.0**2
    assert c.covariance_u[0, 0] == pytest.approx((A[0, 0] * V[0, 0] * A[0, 0] + 1 / 25.0) / a2**2, rel=1e-4)
    assert c.covariance_u[1, 1] == pytest.approx(V[1, 1], rel=1e-6)


def test_the_check_fires_outside_the_99_percent_interval():
    pred = compare.linearized(np.array([2800.0]), np.array([[1.0]]), np.array([[30.0**2]]), "white")
    sd = np.array([40.0])
    inside = compare.agreement(np.array([2800 + 2.5 * 50]), sd, pred, sweep=False)
    outside = compare.agreement(np.array([2800 + 2.7 * 50]), sd, pred, sweep=False)
    assert inside.z[0] == pytest.approx(2.5) and not inside.fired
    assert outside.fired and outside.p_value < compare.CHECK_P
    none = compare.agreement(np.array([2800.0]), np.array([np.nan]),
                             compare.linearized(np.array([2800.0]), np.array([[1.0]]), np.zeros((1, 1)),
                                                "white"), sweep=False)
    assert none.fired is None                           # neither sd known: nothing to check


def test_a_sweep_is_checked_as_a_whole():
    rng = np.random.default_rng(0)
    m = 20
    mean = np.full(m, 1000.0)
    C = 25.0 * np.ones((m, m)) + np.eye(m)            # the posterior's uncertainty is shared
    pred = compare.Prediction(mean, C, mean, np.column_stack([mean - 9, mean + 9]), "posterior")
    sd = np.full(m, 10.0)
    fired = [compare.agreement(mean + 10 * rng.standard_normal(m) + 5 * rng.standard_normal(), sd,
                               pred, sweep=True).fired for _ in range(200)]
    assert sum(fired) <= 8                            # about 1 % expected
    assert compare.agreement(mean + 40.0 * np.sin(np.arange(m)), sd, pred, sweep=True).fired


def test_a_reference_at_another_temperature_is_carried_by_the_model_s_law_draw_by_draw():
    """With a temperature law, a reference measured at 40 °C is the reference spectrum's with every
    τ_j times a_T(40 °C) of each draw's Ea; at the reference temperature, or without a temperature,
    a_T = 1; the gradient in Ea is the prediction's own."""
    from bayes_dnlr.model.shift import temperature_shift

    m = 3
    r = Reference(0, "r", "dma", "data", np.array([STORAGE, LOSS, RELAXATION]),
                  np.array([1.0, 1.0, 2.0]), np.ones(m), np.ones(m), None, np.ones(m),
                  np.full(m, 40.0), law=("arrhenius", 20.0))
    draws = {**P, "Ea": np.array([200.0, 300.0])}
    got = predict(r, draws)
    for i, ea in enumerate((200.0, 300.0)):
        a = temperature_shift(40.0, "arrhenius", 20.0, Ea=ea)
        s, loss = complex_modulus(1.0, P["E"], P["G"], P["tau_max"] * a)
        assert got[i, 0] == pytest.approx(s[0]) and got[i, 1] == pytest.approx(loss[0])
        assert got[i, 2] == pytest.approx(relaxation_modulus(2.0, P["E"], P["G"], P["tau_max"] * a)[0])
    at_ref = Reference(0, "r", "dma", "data", np.array([STORAGE]), np.array([1.0]), np.ones(1),
                       np.ones(1), None, np.ones(1), np.full(1, 20.0), law=("arrhenius", 20.0))
    assert predict(at_ref, {**P, "Ea": 250.0})[0] == pytest.approx(complex_modulus(1.0, **P)[0][0])
    g = gradient(r, {**P, "Ea": 250.0}, ["Ea"])
    h = 1e-3
    fd = (predict(r, {**P, "Ea": 250.0 + h}) - predict(r, {**P, "Ea": 250.0 - h})) / (2 * h)
    np.testing.assert_allclose(g[:, 0], fd, rtol=1e-4)
