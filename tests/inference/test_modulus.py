"""E(t) as a result (inference/modulus.py): where a test resolves it, the default times, the
delta method of ``fit`` against Monte Carlo, and which samples carry its information."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayes_dnlr.inference.modulus import (
    default_times,
    gradient,
    information_weights,
    linearized,
    nice_time,
    resolved_window,
)
from bayes_dnlr.model.modulus import relaxation_modulus

POINT = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}


@pytest.mark.parametrize("t, expected", [(0.38, 0.5), (0.5, 0.5), (0.76, 1.0), (1.2, 2.0), (2.01, 5.0),
                                         (7.0, 10.0), (0.0012, 0.002), (99.0, 100.0)])
def test_nice_times_round_up_to_1_2_5(t, expected):
    assert nice_time(t) == pytest.approx(expected)


def test_a_ramp_from_rest_resolves_two_steps_in():
    t = np.linspace(0.0, 380.0, 1001)
    e = 5e-3 * t
    w = resolved_window(t, e, np.ones(t.size, bool), 5e-3)
    assert w.origin == 0.0 and w.shortest == pytest.approx(0.76) and w.longest == pytest.approx(380.0)
    times, why = default_times(w)
    assert times == [1.0] and "rounded up to 1 s" in why and "2 sampling steps of 0.38 s" in why


def test_a_file_that_starts_at_a_strain_already_reached_began_before_it():
    t = np.linspace(10.0, 20.0, 101)            # 0.1 s steps, from strain 0.005 at 1e-3 1/s
    e = 0.005 + 1e-3 * (t - 10.0)
    w = resolved_window(t, e, np.ones(t.size, bool), 1e-3)
    assert w.origin == pytest.approx(5.0)        # 0.005 / 1e-3 = 5 s before the first sample
    # the first 5 s were not measured: E(t) resolved from twice that
    assert w.shortest == pytest.approx(10.0) and "already has strain 0.005" in w.how
    assert "not measured" in w.how


def test_an_unloaded_start_before_the_first_sample_is_the_origin():
    # a model-only sample at zero strain (initial_state: ramp-from-zero), never in the window
    t = np.concatenate([[4.0], np.linspace(10.0, 20.0, 101)])
    e = np.concatenate([[0.0], 0.006 + 1e-3 * (t[1:] - 10.0)])
    window = np.ones(t.size, bool)
    window[0] = False
    w = resolved_window(t, e, window, 1e-3)
    assert w.origin == 4.0 and w.shortest == pytest.approx(10.2 - 4.0)
    w = resolved_window(t, e, window, 1e-3, unmeasured_start=True)
    assert w.shortest == pytest.approx(12.0)           # twice the 6 s before the first sample


def test_the_gradient_is_the_finite_difference_of_e_t():
    names = ["E", "G", "tau_max", "alpha"]
    point = {**POINT, "alpha": 0.45}
    times = [0.3, 1.0, 7.0]
    g = gradient(point, names, times)
    for j, k in enumerate(names):
        h = 1e-6 * max(abs(point[k]), 1.0)

        def at(v, k=k):
            p = {**point, k: v}
            return relaxation_modulus(times, p["E"], p["G"], p["tau_max"], p["alpha"])

        np.testing.assert_allclose(g[:, j], (at(point[k] + h) - at(point[k] - h)) / (2 * h), rtol=1e-5)


def test_the_linearized_sd_is_the_spread_of_e_t_over_a_small_gaussian_cloud():
    names = ["E", "G", "tau_max"]
    sd = np.array([3.0, 0.002, 0.01])
    corr = np.array([[1.0, -0.2, -0.99], [-0.2, 1.0, 0.2], [-0.99, 0.2, 1.0]])
    cov = corr * np.outer(sd, sd)
    [row] = linearized(POINT, cov, names, [1.0])
    draws = np.random.default_rng(1).multivariate_normal([POINT[k] for k in names], cov, 200_000)
    mc = relaxation_modulus([1.0], draws[:, 0], draws[:, 1], draws[:, 2])[:, 0]
    assert row["mean"] == pytest.approx(relaxation_modulus([1.0], *POINT.values())[0])
    assert row["sd"] == pytest.approx(mc.std(), rel=0.02)
    assert row["hdi_90"][1] - row["hdi_90"][0] == pytest.approx(2 * 1.6449 * row["sd"], rel=1e-4)


def test_information_weights_of_one_parameter_are_its_share_and_sum_to_one():
    from bayes_dnlr.inference.checks.predictive import weights

    X = np.random.default_rng(2).standard_normal((50, 3)) * [1000.0, 1.0, 0.01]
    w = information_weights(X, np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(w, weights(X, 1), rtol=1e-10)
    assert math.isclose(w.sum(), 1.0)
    # a combination that only one sample informs puts all its weight there
    Y = np.eye(3)
    np.testing.assert_allclose(information_weights(Y, np.array([0.0, 0.0, 1.0])), [0, 0, 1], atol=1e-12)
