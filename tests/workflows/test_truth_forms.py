"""Richer generating models (truth_forms.py, ``truth.model_form``): independent of the fitted
model's code, equal to it for the trivial form, and each kind doing what its name says."""

from __future__ import annotations

import numpy as np
import pytest
from support.model import RELAX, TABLE3_5E3, jittered, ramp
from support.simulate import truth

from bayes_dnlr.config import ConfigError
from bayes_dnlr.data import load_test
from bayes_dnlr.model import simulate
from bayes_dnlr.workflows.simulate import simulate_test
from bayes_dnlr.workflows.truth_forms import KINDS, generate, langevin_factor, spectrum_weights


def cases():
    t, e = ramp(5e-3, 1.9, 1000)
    yield "uniform ramp", t, e, None, TABLE3_5E3
    t, e = jittered(800, 0.3)
    yield "jittered ramp", t, e, None, TABLE3_5E3
    t, e = ramp(5e-3, 2.0, 400, hold=600.0, n_hold=300)
    yield "ramp and hold", t, e, 400.0, RELAX


@pytest.mark.parametrize("case", list(cases()), ids=lambda c: c[0])
def test_the_trivial_form_is_the_fitted_model(case):
    _, t, e, switch, params = case
    g = generate(t, e, params, switch, None)
    ref = simulate(t, e, params, relaxation_start=switch)
    assert np.max(np.abs(g.stress - ref)) < 1e-12 * np.max(np.abs(ref))
    np.testing.assert_array_equal(g.measured_strain, e)


@pytest.mark.parametrize("alpha", [0.0, 0.3, 0.8])
def test_a_power_spectrum_is_the_model_with_that_exponent(alpha):
    t, e = ramp(5e-3, 2.0, 400, hold=600.0, n_hold=300)
    g = generate(t, e, RELAX, 400.0, "spectrum-power", alpha)
    ref = simulate(t, e, {**RELAX, "alpha": alpha}, relaxation_start=400.0)
    assert np.max(np.abs(g.stress - ref)) < 1e-12 * np.max(np.abs(ref))


@pytest.mark.parametrize("kind", ["spectrum-power", "spectrum-lognormal", "spectrum-two-slope"])
def test_spectrum_shapes_sum_to_one_and_differ_from_eq_12(kind):
    for strength in ("mild", "strong"):
        value = KINDS[kind][1][strength]
        p = spectrum_weights(kind, value, 50, 6.0)
        assert p.sum() == pytest.approx(1.0, abs=1e-14) and np.all(p > 0)
        assert np.max(np.abs(p - spectrum_weights("", 0.5, 50, 6.0))) > 1e-3


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_kind_keeps_E_the_instantaneous_modulus(kind):
    """The stress of a step much shorter than the fastest mode is E Δε in every form: the weights
    sum to 1 and the relaxed state starts at 0 (a strain-channel error changes what is measured,
    not the specimen)."""
    t = np.array([0.0, 1e-12, 10.0, 20.0, 30.0])
    e = 5e-3 * t
    g = generate(t, e, TABLE3_5E3, None, kind, "strong")
    assert g.stress[1] / e[1] == pytest.approx(TABLE3_5E3["E"], rel=1e-6)


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_kind_changes_the_test_more_when_strong(kind):
    t, e = ramp(5e-3, 1.9, 600)
    base = generate(t, e, TABLE3_5E3, None, None)
    diffs = []
    for strength in ("mild", "strong"):
        g = generate(t, e, TABLE3_5E3, None, kind, strength)
        diffs.append(max(np.max(np.abs(g.stress - base.stress)),
                         TABLE3_5E3["E"] * np.max(np.abs(g.measured_strain - e))))
    assert 0.1 < diffs[0] < diffs[1]         # MPa


def test_langevin_hardening_is_stiffer_than_haward_thackray():
    e = np.linspace(0.0, 1.9, 50)
    f = langevin_factor(e, 25.0)
    assert f[0] == pytest.approx(1.0, abs=1e-12)
    assert np.all(np.diff(f) >= 0) and f[-1] > 1.5
    with pytest.raises(ValueError, match="locking stretch"):
        langevin_factor(e, 10.0)


def test_strain_toe_and_drift_change_only_the_measured_strain():
    t, e = ramp(5e-3, 1.9, 400)
    clean = generate(t, e, TABLE3_5E3, None, None)
    toe = generate(t, e, TABLE3_5E3, None, "strain-toe", 2e-3)
    np.testing.assert_array_equal(toe.stress, clean.stress)
    assert toe.measured_strain[-1] - e[-1] == pytest.approx(2e-3, rel=1e-6)
    assert np.all(toe.measured_strain >= e)
    drift = generate(t, e, TABLE3_5E3, None, "strain-drift", 0.05)
    assert drift.measured_strain[-1] - e[-1] == pytest.approx(0.05 * 1.9, rel=1e-12)


def test_simulate_writes_the_richer_test_and_the_measured_strain(make_config):
    form = {"kind": "strain-toe", "strength": "strong"}
    cfg = make_config(truth=truth(noise={"strain_sd": 0.0, "stress_sd": 0.0}, model_form=form),
                      strain_input="measured")
    res = simulate_test(cfg)
    test = load_test(cfg)
    g = generate(res.time, res.strain, cfg.truth.params, None, "strain-toe", "strong")
    np.testing.assert_allclose(test.strain, g.measured_strain, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(res.stress, g.stress, rtol=1e-12)


def test_an_unknown_kind_is_a_config_error(make_config):
    with pytest.raises(ConfigError, match="model_form"):
        make_config(truth=truth(model_form={"kind": "spectrum-cubic"}))


@pytest.mark.parametrize("kind", [None, "spectrum-power", "spectrum-lognormal", "spectrum-two-slope",
                                  "two-process", "hardening-langevin", "strain-toe"])
def test_the_true_relaxation_modulus_is_the_generator_s_step_response(kind):
    """E(t) of a richer generating model (the truth E(t) of the benchmarks) is the stress per unit
    strain its own integrator gives after a small step of the specimen's strain."""
    from bayes_dnlr.workflows.truth_forms import generate, relaxation_modulus

    params = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
    times = np.geomspace(1e-3, 300.0, 40)
    t = np.concatenate([[0.0, 1e-9], times])
    step = 1e-6
    e = np.where(t > 0, step, 0.0)
    got = generate(t, e, params, None, kind).stress[2:] / step
    np.testing.assert_allclose(relaxation_modulus(times, params, kind), got, rtol=1e-5)
