"""summary.json's ``modulus_at`` (runs/modulus.py): E(t) from every draw, its times, its own trust;
and ``consistency``, whether the tests of a joint run agree (runs/consistency.py)."""

from __future__ import annotations

import json

import pytest
import yaml
from support.joint import make_joint
from support.runs import HDPE, make_run, ramp_truth

from bayes_dnlr.config import load_config
from bayes_dnlr.model.modulus import relaxation_modulus
from bayes_dnlr.runs.sample import sample


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    folder = tmp_path_factory.mktemp("modulus")
    path = make_run(folder, "clean", ramp_truth(0.6, n_points=300),
                    sampler={"max_steps": 400, "target_ess": 200})
    return path, sample(load_config(path), progress=False).summary


def test_a_clean_ramp_gives_a_trusted_e_t_at_its_shortest_resolved_time(clean):
    _, s = clean
    [row] = s["modulus_at"]
    # 300 points to strain 0.6 at 5e-3 1/s: 0.401 s steps, two of them 0.80 s: 1 s
    assert row["t"] == 1.0 and "rounded up to 1 s" in row["why"]
    truth = relaxation_modulus([1.0], HDPE["E"], HDPE["G"], HDPE["tau_max"])[0]
    assert abs(row["mean"] - truth) < 4 * row["sd"]
    assert row["hdi_90"][0] < row["median"] < row["hdi_90"][1]
    assert row["trust"] and row["trust_reasons"] == []
    c = row["checks"]
    assert c["inside_window"] and c["band"]["ok"] and c["converged"]
    assert c["start"] is None or c["start"]["ok"]


def test_asked_times_outside_the_resolved_window_are_not_trusted_and_outputs_follow_the_setting(clean):
    path, before = clean
    raw = yaml.safe_load(path.read_text())
    raw["output"] = {"modulus_at": [5.0, 0.5, 1.0e5]}
    path.write_text(yaml.safe_dump(raw))
    s = sample(load_config(path), progress=False).summary
    assert s["steps"] == before["steps"]                    # the chain is not sampled again
    rows = {r["t"]: r for r in s["modulus_at"]}
    assert sorted(rows) == [0.5, 5.0, 1.0e5]
    far = rows[1.0e5]
    assert not far["trust"] and "outside the times the test resolves" in far["trust_reasons"][0]
    assert rows[5.0]["checks"]["inside_window"] and not rows[0.5]["checks"]["inside_window"]
    assert s["settings"]["modulus_at"] == [0.5, 5.0, 1.0e5]


def test_a_strain_toe_fails_the_start_check(tmp_path):
    """A slack at the start (the strain reads ahead of the specimen's by up to 1e-3): the model fits
    it as a softer start and E(t) comes out low; the start's slope rises, which gives the toe away."""
    truth = {"params": {"E": 1500.0, "G": 5.0, "tau_max": 30.0}, "strain_rate": 1e-3,
             "strain_max": 0.05, "sample_rate": 10, "model_form": {"kind": "strain-toe", "strength": 1e-3},
             "noise": {"strain_sd": 0.0, "stress_sd": 0.01}, "seed": 4}
    path = make_run(tmp_path, "toe", truth, sigma0=0.01, data={"strain_input": "measured"},
                    sampler={"max_steps": 300, "target_ess": 100})
    [row] = sample(load_config(path), progress=False).summary["modulus_at"]
    truth = relaxation_modulus([row["t"]], 1500.0, 5.0, 30.0)[0]
    assert row["hdi_90"][1] < truth                          # the model fits the toe as a softer start
    start = row["checks"]["start"]
    assert start is not None and start["toe"] and not start["ok"] and start["convexity_z"] > 2.576
    assert not row["trust"] and any("a toe" in r for r in row["trust_reasons"])


def test_a_joint_run_says_whether_its_tests_agree(tmp_path):
    same = make_joint(tmp_path, "same", per_test=("tau_max",))
    s = sample(load_config(same), progress=False).summary
    assert set(s["modulus_at"]["tests"]) == {"r2.5e-3", "r5e-3", "r1e-2"}
    c = s["consistency"]
    assert c["agree"], c["words"]
    assert {q["quantity"] for q in c["quantities"]} >= {"E"}
    # one test of another material: its E 40 % higher
    other = make_joint(tmp_path, "other", per_test=("tau_max",))
    raw = yaml.safe_load(other.read_text())
    raw["tests"][2]["truth"]["params"]["E"] *= 1.4
    other.write_text(yaml.safe_dump(raw, sort_keys=False))
    from bayes_dnlr.workflows.simulate import simulate_tests

    simulate_tests(load_config(other), overwrite=True)
    s = sample(load_config(other), progress=False).summary
    c = s["consistency"]
    assert not c["agree"] and "do not agree" in c["words"] and "r1e-2" in c["words"]
    text = json.dumps(c)
    assert "cochran_q" in text


def _row(**checks):
    base = {"inside_window": True, "band": {"share": 0.92, "floor": 0.83, "ok": True, "n_eff": 50,
                                            "information_times": [0.5, 20.0], "remedy": "read them"},
            "start": None, "bounds": {}, "prior": None, "noise_model": True, "converged": True}
    return {"t": 1.0, "resolved": [0.8, 380.0], "checks": {**base, **checks}}


@pytest.mark.parametrize("failed, words", [
    ({"inside_window": False}, "outside the times the test resolves"),
    ({"band": {"share": 0.6, "floor": 0.83, "ok": False, "n_eff": 50, "information_times": [0.5, 20.0],
               "remedy": "identify on the first loading"}}, "identify on the first loading"),
    ({"start": {"ok": False, "toe": False, "z": -4.0, "data_chord": 900.0, "model_chord": 1100.0,
                "times": [0.1, 0.5], "convexity_z": 0.0}}, "does not follow the start"),
    ({"start": {"ok": False, "toe": True, "z": 0.0, "data_chord": 900.0, "model_chord": 900.0,
                "times": [0.1, 0.5], "convexity_z": 7.0}}, "a toe"),
    ({"bounds": {"tau_max": 1.5}}, "the prior box decides"),
    ({"prior": 0.2}, "the prior shapes"),
    ({"noise_model": False}, "white likelihood"),
    ({"converged": False}, "not converged"),
])
def test_each_check_withdraws_e_t_s_trust_and_says_why(failed, words):
    from bayes_dnlr.runs.modulus import _reasons

    assert _reasons(_row(), "") == []
    reasons = _reasons(_row(**failed), "")
    assert len(reasons) == 1 and words in reasons[0]
    # a bound that moves E(t) by less than its sd, or a flat prior, withdraws nothing
    assert _reasons(_row(bounds={"tau_max": 0.9}, prior=0.01), "") == []


def test_the_band_floor_is_a_one_sided_binomial_bound():
    from bayes_dnlr.inference.checks.predictive import band_floor

    assert band_floor(100) == pytest.approx(0.9 - 2.326 * 0.03)
    assert band_floor(9) == pytest.approx(0.9 - 2.326 * 0.1)
    assert band_floor(1e6) == pytest.approx(0.9, abs=1e-3)


def test_the_band_s_remedy_names_the_part_the_model_describes():
    import numpy as np

    from bayes_dnlr.runs.bands import Band
    from bayes_dnlr.runs.modulus import _window_remedy

    t = np.arange(300) * 0.2
    cyc = np.concatenate([np.linspace(0, 0.01, 100), np.linspace(0.01, 0.002, 100),
                          np.linspace(0.002, 0.02, 100)])
    band = Band(np.ones(300, bool), t, cyc, None, None, [], {})
    assert "first loading, data.window: {time_max: 19.8}" in _window_remedy(band)
    long = np.arange(300) * 0.5
    hold = np.minimum(long, 8.0) * 1e-3
    band = Band(np.ones(300, bool), long, hold, 8.0, None, [], {})
    assert "data.window: {time_max: 88}" in _window_remedy(band)
    ramp = t * 1e-3
    assert "docs/model-form.md" in _window_remedy(Band(np.ones(300, bool), t, ramp, None, None, [], {}))


def test_widening_is_advised_only_for_a_parameter_the_window_identifies():
    from bayes_dnlr.runs.verdict import _bound_words

    entry = {"parameter": "tau_max", "side": "high", "bound": 1e4, "E_shift_sd": {"E": 3.0}}
    ok, [words] = _bound_words([{**entry, "identified": True}])
    assert not ok and "Widen parameters.tau_max and run again" in words
    ok, [words] = _bound_words([{**entry, "identified": False}])
    assert not ok and "Widen parameters.tau_max" not in words and "Do not just widen it" in words


def test_a_cyclic_test_takes_e_t_from_its_first_loading(tmp_path):
    """Cycles fitted over their whole history: E(t) comes from the first loading, where the model
    holds, with the whole window's posterior E(t) beside it."""
    truth = {"params": {"E": 2000.0, "G": 5.0, "tau_max": 60.0}, "strain_rate": 1e-3,
             "strain_max": 0.02, "cycles": {"count": 3}, "sample_rate": 5,
             "noise": {"strain_sd": 0.0, "stress_sd": 0.02}, "seed": 5}
    path = make_run(tmp_path, "cycles", truth, sigma0=0.02, sampler={"max_steps": 300, "target_ess": 100})
    s = sample(load_config(path), progress=False).summary
    [row] = s["modulus_at"]
    assert row["source"].startswith("first loading") and "its peak at t = 6.66667 s" in row["why"]
    truth_e = relaxation_modulus([row["t"]], 2000.0, 5.0, 60.0)[0]
    assert abs(row["mean"] - truth_e) < 3 * row["sd"]
    assert abs(row["whole_window"]["mean"] - truth_e) < 3 * row["whole_window"]["sd"]
    assert row["resolved"][1] == pytest.approx(6.67, abs=0.01)
    half = 1.6449 * row["sd"]
    assert row["hdi_90"] == pytest.approx([row["mean"] - half, row["mean"] + half], rel=1e-4)
    c = row["checks"]
    # the model is the data's: its band holds the first loading, its start follows the data's
    assert c["band"]["ok"] and c["band"]["share"] >= c["band"]["floor"] and c["band"]["n_eff"] > 5
    assert c["band"]["information_times"][1] <= 6.67 + 1e-6
    assert c["start"] is not None and c["start"]["ok"] and abs(c["start"]["z"]) < 2.576
    assert c["converged"] and c["inside_window"] and row["trust"]
    curve = s["modulus_curve"]
    assert curve["resolved"] == row["resolved"]
    assert all(a <= b <= d for a, b, d in zip(curve["q05"], curve["q50"], curve["q95"], strict=True))
    assert curve["E_hdi_90"][0] < curve["E_median"] < curve["E_hdi_90"][1]


def test_a_chain_that_samples_a_parameter_the_fit_now_holds_is_refused(tmp_path):
    from types import SimpleNamespace

    from bayes_dnlr.errors import StaleRunError
    from bayes_dnlr.runs.sample import _check_holds

    cfg = load_config(make_run(tmp_path, "r", ramp_truth(0.2, n_points=50)))
    held = {"identifiability": {"held": {"G": {"value": 0.0}}}}
    with pytest.raises(StaleRunError, match="they differ on G"):
        _check_holds(cfg, SimpleNamespace(names=["E", "G", "tau_max", "sigma0"]), held)
    _check_holds(cfg, SimpleNamespace(names=["E", "tau_max"]), held)
    _check_holds(cfg, SimpleNamespace(names=["E", "G", "tau_max"]), {})
    with pytest.raises(StaleRunError, match="they differ on G"):
        _check_holds(cfg, SimpleNamespace(names=["E", "tau_max"]), {})


def test_e_t_s_move_when_a_bound_is_widened_is_its_own_refit_s():
    from types import SimpleNamespace

    from bayes_dnlr.inference.layout import Layout
    from bayes_dnlr.runs.modulus import _bound_shift

    cfg = SimpleNamespace(for_test=lambda t: SimpleNamespace(fixed_values={"G": 0.0}),
                          model=SimpleNamespace(modes=50, decades=6.0))
    layout = Layout.build({"t": ["E", "tau_max"]}, [], plain=True)
    before, after = {"E": 2000.0, "tau_max": 50.0}, {"E": 2100.0, "tau_max": 40.0}
    entries = [{"parameter": "tau_max", "estimates": {"before": before, "after": after}},
               {"parameter": "E", "note": "no refit"}]
    expected = (relaxation_modulus([1.0], 2100.0, 0.0, 40.0)[0]
                - relaxation_modulus([1.0], 2000.0, 0.0, 50.0)[0]) / 10.0
    assert _bound_shift(entries, layout, "t", 1.0, 10.0, cfg) == {"tau_max": pytest.approx(expected)}
    assert _bound_shift(entries, layout, "t", 1.0, 0.0, cfg) == {}


def test_the_exponent_s_spread_is_the_slope_along_the_refit_times_alpha_s_sd():
    import numpy as np

    from bayes_dnlr.inference.modulus import gradient
    from bayes_dnlr.runs.modulus import spectrum_spread, spread

    point = {"E": 2854.0, "G": 2.32, "tau_max": 5.79, "alpha": 0.5}
    block = {"sampled": False, "derivative": {"E": -2900.0, "G": 0.05, "tau_max": -1.7},
             "score": {"sd": 0.05}}
    fit = {"spectrum_exponent": block, "discrepancy": {"alpha_score": {"sd": 0.2}}}
    s = spectrum_spread(fit, point, [1.0, 10.0], False, 50, 6.0)
    g = gradient(point, ["E", "G", "tau_max", "alpha"], [1.0, 10.0])
    slope = g[:, 3] + g[:, 0] * -2900.0 + g[:, 1] * 0.05 + g[:, 2] * -1.7
    np.testing.assert_allclose(s["slope"], slope)
    np.testing.assert_allclose(s["added_sd"], np.abs(slope) * 0.05)
    # under the discrepancy, the score test on the whitened residuals gives alpha's sd
    assert spectrum_spread(fit, point, [1.0], True, 50, 6.0)["alpha_sd"] == 0.2
    sampled = {"spectrum_exponent": {**block, "sampled": True}}
    assert spectrum_spread(sampled, point, [1.0], False, 50, 6.0) is None
    assert spectrum_spread({}, point, [1.0], False, 50, 6.0) is None
    # the spread keeps the median and adds about the sd asked, never a negative modulus
    values = np.full((20000, 2), 1000.0)
    out = spread(values, np.array([0.0, 10.0]))
    np.testing.assert_array_equal(out[:, 0], 1000.0)
    assert out[:, 1].std() == pytest.approx(10.0, rel=0.05)
    assert np.median(out[:, 1]) == pytest.approx(1000.0, abs=0.5)
    assert np.all(spread(values, np.array([5000.0, 5000.0])) > 0)


def test_a_toe_on_a_cyclic_test_withdraws_the_trust_of_its_first_loading_e_t(tmp_path):
    """Cycles whose first loading starts with a slack: E(t) still comes from the first loading,
    and that fit's own start check sees the slope rise and withdraws its trust."""
    truth = {"params": {"E": 2000.0, "G": 5.0, "tau_max": 60.0}, "strain_rate": 1e-3,
             "strain_max": 0.02, "cycles": {"count": 3}, "sample_rate": 5,
             "model_form": {"kind": "strain-toe", "strength": 1e-3},
             "noise": {"strain_sd": 0.0, "stress_sd": 0.02}, "seed": 5}
    path = make_run(tmp_path, "cycles-toe", truth, sigma0=0.02, data={"strain_input": "measured"},
                    sampler={"max_steps": 300, "target_ess": 100})
    [row] = sample(load_config(path), progress=False).summary["modulus_at"]
    assert row["source"].startswith("first loading")
    start = row["checks"]["start"]
    assert start is not None and start["toe"] and not start["ok"]
    assert not row["trust"] and any("a toe" in r for r in row["trust_reasons"])
