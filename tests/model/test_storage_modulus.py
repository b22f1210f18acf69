"""E'(ω) and E''(ω), the linear storage and loss moduli of the DNLR modes (model/modulus.py), against
the integrator itself driven by a small sinusoidal strain, and against their limits."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.model import DNLR
from bayes_dnlr.model.modulus import (
    FROZEN,
    complex_modulus,
    fastest_mode_product,
    relaxation_modulus,
    storage_modulus,
)

PARAMS = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
PER_CYCLE = 2000        # samples per period: the interpolant's harmonics alias into the projection
#                         by about E/E'·(π/M)², 1e-4 of E' at 0.01 Hz with M = 2000


def sine_response(f: float, params: dict[str, float], eps0: float = 1e-6) -> tuple[float, float]:
    """(E', E'') read off the integrator's stress under ε = ε0 sin(2πft) from rest: the in-phase and
    quadrature parts of the last 10 periods (least squares with a constant and a slope, which take
    what is left of the slow modes' start)."""
    period = 1.0 / f
    settle = 12 * params["tau_max"] * params.get("shift", 1.0)
    cycles = 20 + (int(np.ceil(settle / period)) if period > settle / 200 else 0)
    t = np.arange(cycles * PER_CYCLE + 1) * (period / PER_CYCLE)
    stress = DNLR(t, eps0 * np.sin(2 * np.pi * f * t)).stress(
        {k: v for k, v in params.items() if k != "shift"})
    last = slice(-10 * PER_CYCLE - 1, None)
    tt = t[last]
    A = np.column_stack([np.ones_like(tt), tt - tt[0], np.sin(2 * np.pi * f * tt),
                         np.cos(2 * np.pi * f * tt)])
    c = np.linalg.lstsq(A, stress[last], rcond=None)[0]
    return c[2] / eps0, c[3] / eps0


@pytest.mark.parametrize("alpha", [0.5, 0.3])
@pytest.mark.parametrize("f", [0.01, 0.2, 3.0, 45.0, 2e3, 5e6])
def test_it_is_the_integrator_s_steady_response_to_a_small_sine(f, alpha):
    params = {**PARAMS, "alpha": alpha}
    e1, e2 = sine_response(f, params)
    s, loss = complex_modulus(f, PARAMS["E"], PARAMS["G"], PARAMS["tau_max"], alpha)
    assert e1 == pytest.approx(s[0], rel=1e-4)
    assert e2 == pytest.approx(loss[0], rel=1e-4)


def test_its_limits_are_the_relaxed_stiffness_and_e():
    E, G, tau = PARAMS["E"], PARAMS["G"], PARAMS["tau_max"]
    f = np.geomspace(1e-9, 1e12, 300)
    s, loss = complex_modulus(f, E, G, tau)
    assert s[0] == pytest.approx(3 * G, rel=1e-6)
    assert s[-1] == pytest.approx(E, rel=1e-9)
    assert np.all(np.diff(s) >= 0)                      # the modes freeze one after the other
    assert np.all(loss > 0) and loss[0] < 1e-3 * E and loss[-1] < 1e-3 * E


def test_every_mode_is_frozen_above_frozen():
    E, G, tau = PARAMS["E"], PARAMS["G"], PARAMS["tau_max"]
    f = FROZEN / (2 * np.pi * tau * 1e-6)
    assert fastest_mode_product(f, tau) == pytest.approx(FROZEN)
    for alpha in (0.0, 0.5, 1.0):          # whatever the weights: each mode keeps 99 % of its own
        assert storage_modulus(f, E, G, tau, alpha) >= E - 0.01 * (E - 3 * G)
    # one mode alone at τ_1 (the fastest): below FROZEN it loses more than 1 % of its weight
    assert storage_modulus(f / 3, E, 0.0, tau * 1e-6, modes=1) < 0.99 * E


def test_a_shift_moves_the_time_scale():
    """a_T multiplies every τ_j: E'(ω) at shift a is E'(aω) at shift 1."""
    E, G, tau = PARAMS["E"], PARAMS["G"], PARAMS["tau_max"]
    f = np.geomspace(0.01, 100, 9)
    np.testing.assert_allclose(storage_modulus(f, E, G, tau, shift=30.0),
                               storage_modulus(30.0 * f, E, G, tau), rtol=1e-12)


def test_draws_broadcast_and_storage_is_the_relaxation_modulus_transformed():
    rng = np.random.default_rng(1)
    k = 5
    E = 2800 + 50 * rng.standard_normal(k)
    tau = 5.8 * np.exp(0.05 * rng.standard_normal(k))
    s, loss = complex_modulus([1.0, 45.0], E, 2.32, tau, 0.5)
    assert s.shape == loss.shape == (k, 2)
    for i in range(k):
        one = storage_modulus([1.0, 45.0], E[i], 2.32, tau[i])
        np.testing.assert_allclose(s[i], one, rtol=1e-12)
    # E'(ω) = E(0) − ω ∫ (E(t) − E(∞))... checked through one mode: E(t) and E'(ω) of a spectrum
    # with all its weight on one τ (modes=1) are the Maxwell pair
    t1, w = 5.79, 2 * np.pi * 0.1
    assert relaxation_modulus([t1], 100.0, 0.0, t1, modes=1)[0] == pytest.approx(100 / np.e)
    assert storage_modulus(0.1, 100.0, 0.0, t1, modes=1) == pytest.approx(
        100 * (w * t1) ** 2 / (1 + (w * t1) ** 2))
