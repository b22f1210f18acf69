"""The start check (inference/checks/start.py): the data's ISO 527-1 chord beside the model
curves' own."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.checks.start import START_Z, Noise, chord_noise_sd, chord_times, start_check
from bayes_dnlr.standards import iso527_1_modulus

RATE = 1e-3


def curve(modulus: float, n: int = 400, toe: float = 0.0):
    """A linear nominal curve at RATE, sampled every 0.05 s; ``toe``: the strain reads ahead by
    toe (1 - exp(-e/toe)), a slack the stress does not see."""
    t = np.arange(n) * 0.05
    e = RATE * t
    stress = modulus * e
    measured = e + (toe * -np.expm1(-e / toe) if toe > 0 else 0.0)
    return t, measured, stress


def test_the_same_curve_passes_and_its_chord_lies_at_its_times():
    t, e, s = curve(1500.0)
    models = np.tile(s, (50, 1)) + np.random.default_rng(0).normal(0, 1e-3, (50, t.size))
    c = start_check(e, s, models, Noise(0.01**2), t, 0.0)
    assert c is not None and c.ok and abs(c.z) < 1
    assert c.data == pytest.approx(1500.0) and c.model == pytest.approx(1500.0, rel=1e-3)
    assert c.times == pytest.approx((0.5, 2.5))


def test_a_short_toe_is_a_rising_slope_and_a_relaxing_start_is_not():
    from bayes_dnlr.inference.checks.start import convexity
    from bayes_dnlr.workflows.truth_forms import generate

    t = np.arange(0.0, 50.0, 0.1)
    e = RATE * t
    rng = np.random.default_rng(0)
    for slack, toe in ((0.0, False), (5e-4, True), (1e-3, True)):
        g = generate(t, e, {"E": 1500.0, "G": 5.0, "tau_max": 30.0}, None,
                     "strain-toe" if slack else None, slack or "mild")
        nominal = g.stress * np.exp(-g.measured_strain) + rng.normal(0, 0.01, t.size)
        z = convexity(np.expm1(g.measured_strain), nominal, 0.01**2)
        assert (z > START_Z) == toe, (slack, z)


def test_a_toe_the_model_does_not_have_fails():
    t, e, s = curve(1500.0, toe=5e-4)          # the strain reads ahead: the data's chord is lower
    model = 1500.0 * e                           # a model driven by the strain the file reports
    models = np.tile(model, (50, 1))
    c = start_check(e, s, models, Noise(0.05**2), t, 0.0)
    assert c is not None and not c.ok and c.z < -START_Z
    assert c.data < 0.9 * c.model


def test_the_chord_noise_is_the_regression_slope_s():
    e = np.linspace(0.0, 0.004, 81)
    sd = chord_noise_sd(e, Noise(0.2**2), "regression")
    inside = e[(e >= 5e-4) & (e <= 2.5e-3)]
    assert sd == pytest.approx(0.2 / np.sqrt(np.sum((inside - inside.mean()) ** 2)))
    rng = np.random.default_rng(3)
    slopes = [iso527_1_modulus(e, 1000 * e + rng.normal(0, 0.2, e.size)).modulus for _ in range(2000)]
    assert np.std(slopes) == pytest.approx(sd, rel=0.05)


def test_a_cropped_start_is_checked_on_astm_d638_s_window():
    t = np.arange(100) * 0.05
    e = 0.001 + RATE * t                         # starts past 0.05 %: no ISO 527-1 chord
    s = 1500.0 * e
    c = start_check(e, s, np.tile(s, (5, 1)), Noise(0.01), t, -1.0)
    assert c is not None and c.standard == "ASTM D638" and c.ok and c.data == pytest.approx(1500.0)
    softer = start_check(e, s, np.tile(1300.0 * e, (5, 1)), Noise(1e-4), t, -1.0)
    assert not softer.ok and softer.z > 2.576
    assert chord_times(e, t, -1.0)[1] == pytest.approx(1.5 + 1.0)
    # a curve no standard can measure (fewer samples than a window needs) gives no check
    assert start_check(e[:3], s[:3], np.tile(s[:3], (5, 1)), Noise(0.01), t[:3], -1.0) is None


def test_a_loading_that_speeds_up_is_no_toe():
    """The slope of a relaxing material rises where the loading speeds up; the model, driven by
    the same strain, rises alike, so the start check does not call it a toe."""
    from bayes_dnlr.inference.checks.start import convexity
    from bayes_dnlr.model import simulate

    t = np.arange(0.0, 40.0, 0.1)
    e = np.where(t < 5.0, 1e-4 * t, 5e-4 + 1.5e-3 * (t - 5.0))   # 1e-4 1/s, then 1.5e-3 from 5 s
    stress = simulate(t, e, {"E": 1500.0, "G": 5.0, "tau_max": 30.0})
    nominal = stress * np.exp(-e)
    noisy = nominal + np.random.default_rng(2).normal(0, 0.002, t.size)
    assert convexity(np.expm1(e), noisy, 0.002**2) > START_Z          # the data's slope rises
    assert convexity(np.expm1(e), noisy, 0.002**2, nominal) < START_Z    # as the model's does


def test_the_chord_noise_of_a_correlated_error_is_its_own():
    """A discrepancy (an exp process on the time axis) adds its own covariance to the chord's: cᵀKc,
    against the spread of the chord over draws of that process."""
    from bayes_dnlr.inference.discrepancy.gp import covariance

    t = np.arange(120) * 0.05
    e = RATE * t
    noise = Noise(0.05**2, amplitude=0.3, length=5.0, kernel="exp", axis=t)
    sd = chord_noise_sd(e, noise, "regression")
    K = covariance(t, 0.3, 5.0, "exp") + 0.05**2 * np.eye(t.size)
    L = np.linalg.cholesky(K)
    rng = np.random.default_rng(4)
    slopes = [iso527_1_modulus(e, 1500 * e + L @ rng.standard_normal(t.size)).modulus
              for _ in range(3000)]
    assert np.std(slopes) == pytest.approx(sd, rel=0.05)
    assert sd > chord_noise_sd(e, Noise(0.05**2), "regression")
