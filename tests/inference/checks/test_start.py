"""The start check (inference/checks/start.py): the data's ISO 527-1 chord beside the model
curves' own."""

from __future__ import annotations

import numpy as np
import pytest
from support.real_data import RELAX, reads_export

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
    from bayes_dnlr.inference.checks.toe import toe_test
    from bayes_dnlr.workflows.truth_forms import generate

    t = np.arange(0.0, 50.0, 0.1)
    e = RATE * t
    rng = np.random.default_rng(0)
    for slack, toe in ((0.0, False), (5e-4, True), (1e-3, True)):
        g = generate(t, e, {"E": 1500.0, "G": 5.0, "tau_max": 30.0}, None,
                     "strain-toe" if slack else None, slack or "mild")
        nominal = g.stress * np.exp(-g.measured_strain) + rng.normal(0, 0.01, t.size)
        found = toe_test(np.expm1(g.measured_strain), nominal)
        assert found.found == toe and found.rises >= 10, (slack, found)
        assert (found.p < 0.005) == toe


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
    from bayes_dnlr.inference.checks.toe import toe_test
    from bayes_dnlr.model import simulate

    t = np.arange(0.0, 40.0, 0.1)
    # 2e-5 1/s, sped up to 1.5e-3 between 8 and 10 s: the slow start relaxes, the fast one does not
    rate = np.interp(t, [0.0, 8.0, 10.0, 40.0], [2e-5, 2e-5, 1.5e-3, 1.5e-3])
    e = np.concatenate(([0.0], np.cumsum(0.05 * (rate[1:] + rate[:-1]))))
    stress = simulate(t, e, {"E": 1500.0, "G": 5.0, "tau_max": 30.0})
    nominal = stress * np.exp(-e)
    noisy = nominal + np.random.default_rng(2).normal(0, 2e-4, t.size)
    assert toe_test(np.expm1(e), noisy).found                   # the data's slope rises
    assert not toe_test(np.expm1(e), noisy, nominal).found      # as the model's does


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


def test_the_check_says_whether_the_toe_was_compensated():
    t, e, s = curve(1500.0, toe=5e-4)
    models = np.tile(1500.0 * e, (50, 1))
    plain = start_check(e, s, models, Noise(0.05**2), t, 0.0)
    done = start_check(e, s, models, Noise(0.05**2), t, 0.0, compensated=True)
    assert plain.to_dict()["compensated"] is False and done.to_dict()["compensated"] is True
    assert done.to_dict()["toe"] == plain.to_dict()["toe"]           # the check itself is the same


def test_clean_straight_starts_are_called_a_toe_at_the_test_s_level():
    """The largest of 14 rises is no normal deviate: against 2.576 a straight start with white
    noise was called a toe 5 % of the time; calibrated as the maximum it is, 0.5 %
    (benchmarks/toe_check.py measures it at 100-1000 samples)."""
    from bayes_dnlr.inference.checks.toe import TOE_ALPHA, toe_test

    rng = np.random.default_rng(11)
    e = np.linspace(0.0, 0.0099, 100)
    tests = [toe_test(e, 1500.0 * e + rng.normal(0.0, 0.01, e.size)) for _ in range(600)]
    assert np.mean([t.found for t in tests]) <= 3 * TOE_ALPHA
    assert np.mean([t.z > START_Z for t in tests]) > 0.02          # what 2.576 used to call a toe
    assert 3.2 < tests[0].threshold < 3.7 and tests[0].rises == 14
    # the p value is the share of the null law beyond z: below TOE_ALPHA exactly when found
    assert all((t.p < TOE_ALPHA) == t.found for t in tests)


@reads_export(RELAX)
def test_the_real_relaxation_starts_are_no_toe(make_config):
    """The film's three 20 °C relaxation specimens: a DIC strain whose scatter moves the stress
    (1.4-5.5e-5 of strain, 0.02-0.07 MPa) far more than the force's noise (0.001-0.002 MPa) does;
    counted as scatter, their starts rise by no more than that (z 1.9-3.6 against about 4)."""
    from bayes_dnlr.data import load_test
    from bayes_dnlr.inference.checks.toe import toe_test

    for specimen in (1, 2, 3):
        test = load_test(make_config(file=str(RELAX), specimen=specimen, specimen_columns=9,
                                     columns={"time": 1, "strain": 2, "stress": 8},
                                     strain_unit="fraction", strain_measure="nominal",
                                     observable="stress", relaxation_start="auto", area0=None,
                                     window={}))
        ramp = test.time <= test.relaxation_start
        toe = toe_test(test.nominal_strain[ramp], test.nominal_stress[ramp])
        assert not toe.found and toe.rises >= 14, (specimen, toe)


def test_the_model_s_chord_is_the_draws_median_and_robust_spread():
    from bayes_dnlr.inference.checks.start import centre_and_spread

    rng = np.random.default_rng(5)
    normal = 1100.0 + 20.0 * rng.standard_normal(20000)
    centre, spread = centre_and_spread(normal)
    assert centre == pytest.approx(1100.0, abs=0.5) and spread == pytest.approx(20.0, rel=0.03)
    # draws piled at a parameter's far prior edge (chords hundreds of MPa off) do not make the
    # spread so wide that any data chord agrees: the mean's sd here is about 300 MPa
    piled = np.concatenate([normal[:15000], np.full(5000, 125.0)])
    assert piled.std() > 300.0
    centre, spread = centre_and_spread(piled)
    assert abs(centre - 1100.0) < 30.0 and spread < 60.0
