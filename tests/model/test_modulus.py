"""E(t), the relaxation modulus of the DNLR model (model/modulus.py): the stress per unit strain
after a small step, against the integrator itself and against its limits."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.model import simulate
from bayes_dnlr.model.modulus import relaxation_modulus, spectrum_weights
from bayes_dnlr.model.spectrum import weights

PARAMS = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}


def step_response(params: dict[str, float], times: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """The model's stress per unit strain after a strain step of ``step`` applied over 1e-9 s."""
    t = np.concatenate([[0.0, 1e-9], times])
    e = np.where(t > 0, step, 0.0)
    return simulate(t, e, params)[2:] / step


@pytest.mark.parametrize("alpha", [0.5, 0.3, 0.7])
def test_it_is_the_integrator_s_response_to_a_small_step(alpha):
    times = np.geomspace(1e-3, 200.0, 60)
    params = {**PARAMS, "alpha": alpha}
    expected = step_response(params, times)
    got = relaxation_modulus(times, PARAMS["E"], PARAMS["G"], PARAMS["tau_max"], alpha)
    np.testing.assert_allclose(got, expected, rtol=1e-5)


def test_its_limits_are_e_and_the_relaxed_stiffness():
    E, G, tau = PARAMS["E"], PARAMS["G"], PARAMS["tau_max"]
    assert relaxation_modulus([0.0], E, G, tau)[0] == pytest.approx(E, rel=1e-12)
    assert relaxation_modulus([1e6 * tau], E, G, tau)[0] == pytest.approx(3 * G, rel=1e-9)
    values = relaxation_modulus(np.geomspace(1e-6, 1e4, 200), E, G, tau)
    assert np.all(np.diff(values) <= 0)                       # it only relaxes


def test_draws_broadcast_and_a_scalar_call_gives_one_row():
    times = [0.5, 1.0, 2.0]
    k = 7
    rng = np.random.default_rng(0)
    E = 2800 + 50 * rng.standard_normal(k)
    tau = 5.8 * np.exp(0.05 * rng.standard_normal(k))
    alpha = 0.5 + 0.05 * rng.standard_normal(k)
    many = relaxation_modulus(times, E, 2.32, tau, alpha)
    assert many.shape == (k, 3)
    for i in range(k):
        one = relaxation_modulus(times, E[i], 2.32, tau[i], alpha[i])
        assert one.shape == (3,)
        np.testing.assert_allclose(many[i], one, rtol=1e-12)


def test_per_draw_weights_are_eq_12_s():
    for a in (0.5, 0.2, 0.9):
        np.testing.assert_allclose(spectrum_weights(np.array([a, a]))[1], weights(50, 6.0, a), rtol=1e-12)
    mixed = spectrum_weights(np.array([0.4, 0.6]))
    np.testing.assert_allclose(mixed.sum(axis=1), 1.0)
    np.testing.assert_allclose(mixed[1], weights(50, 6.0, 0.6), rtol=1e-12)
