"""fit.json's and summary.json's ``modulus_at`` (runs/modulus_block.py): E(t) from every draw of
either source, its times, its own trust; and ``consistency``, whether the tests of a joint run
agree (runs/consistency.py)."""

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


def test_the_fit_s_e_t_comes_from_the_same_estimator_with_real_checks(clean):
    """fit.json's E(t): the fit's Laplace draws through the same band, start and trust as the
    posterior's; its start check sees the draws' spread, not one curve twice."""
    path, s = clean
    fit = json.loads((path.parent / "fit.json").read_text())
    [row] = fit["modulus_at"]
    [post] = s["modulus_at"]
    assert row["source"] == "fit" and post["source"] == "posterior"
    assert row["t"] == post["t"] and row["trust"] and row["trust_reasons"] == []
    assert row["lacks"] == {"prior": "a least-squares fit has no prior"} and "lacks" not in post
    truth = relaxation_modulus([1.0], HDPE["E"], HDPE["G"], HDPE["tau_max"])[0]
    assert abs(row["mean"] - truth) < 4 * row["sd"]
    assert abs(row["mean"] - post["mean"]) < 2 * max(row["sd"], post["sd"])
    c = row["checks"]
    assert c["band"]["ok"] and c["band"]["n_eff"] > 5 and c["converged"] and c["noise_model"]
    if c["start"] is not None:
        assert c["start"]["model_sd"] > 0


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


def test_e_t_never_exceeds_e_in_one_analysis(clean):
    _, s = clean
    [row] = s["modulus_at"]
    curve = s["modulus_curve"]
    assert row["mean"] <= s["posterior"]["E"]["mean"]
    assert max(curve["q50"]) <= curve["E_median"] * (1 + 1e-9)


def _row(**checks):
    base = {"inside_window": True, "band": {"share": 0.92, "floor": 0.83, "ok": True, "n_eff": 50,
                                            "information_times": [0.5, 20.0], "first_turn": None,
                                            "relaxation_start": None, "window": [0.0, 380.0]},
            "start": None, "bounds": {}, "prior": None, "noise_model": True, "converged": True}
    return {"t": 1.0, "resolved": [0.8, 380.0], "checks": {**base, **checks}}


@pytest.mark.parametrize("failed, words", [
    ({"inside_window": False}, "outside the times the test resolves"),
    ({"band": {"share": 0.6, "floor": 0.83, "ok": False, "n_eff": 50, "information_times": [0.5, 20.0],
               "first_turn": 19.8, "relaxation_start": None, "window": [0.0, 60.0]}},
     "identify on the first loading"),
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
    from bayes_dnlr.runs.verdict import modulus_reasons

    assert modulus_reasons(_row()) == []
    reasons = modulus_reasons(_row(**failed))
    assert len(reasons) == 1 and words in reasons[0]
    # a bound that moves E(t) by less than its sd, or a flat prior, withdraws nothing
    assert modulus_reasons(_row(bounds={"tau_max": 0.9}, prior=0.01)) == []


def test_a_toe_already_compensated_is_not_advised_again():
    from bayes_dnlr.runs.verdict import modulus_reasons

    start = {"ok": False, "toe": True, "z": 0.0, "data_chord": 900.0, "model_chord": 900.0,
             "times": [0.1, 0.5], "convexity_z": 7.0}
    [first] = modulus_reasons(_row(start=start))
    assert "compensate it (data.toe: compensate)" in first
    [again] = modulus_reasons(_row(start={**start, "compensated": True}))
    assert "data.toe: compensate" in again and "compensate it" not in again


def test_the_band_floor_is_a_one_sided_binomial_bound():
    from bayes_dnlr.inference.checks.predictive import band_floor

    assert band_floor(100) == pytest.approx(0.9 - 2.326 * 0.03)
    assert band_floor(9) == pytest.approx(0.9 - 2.326 * 0.1)
    assert band_floor(1e6) == pytest.approx(0.9, abs=1e-3)


def test_the_band_s_remedy_names_the_part_the_model_describes():
    from bayes_dnlr.runs.verdict import band_remedy

    assert "first loading, data.window: {time_max: 19.8}" in band_remedy(
        {"first_turn": 19.8, "relaxation_start": None, "window": [0.0, 59.8]})
    assert "data.window: {time_max: 88}" in band_remedy(
        {"first_turn": None, "relaxation_start": 8.0, "window": [0.0, 149.5]})
    assert "docs/model-form.md" in band_remedy(
        {"first_turn": None, "relaxation_start": None, "window": [0.0, 59.8]})


def test_widening_is_advised_only_for_a_parameter_the_window_identifies():
    from bayes_dnlr.runs.verdict import _bound_words

    entry = {"parameter": "tau_max", "side": "high", "bound": 1e4, "E_shift_sd": {"E": 3.0}}
    ok, [words] = _bound_words([{**entry, "identified": True}])
    assert not ok and "Widen parameters.tau_max and run again" in words
    ok, [words] = _bound_words([{**entry, "identified": False}])
    assert not ok and "Widen parameters.tau_max" not in words and "Do not just widen it" in words


def test_a_cyclic_test_has_one_analysis(tmp_path):
    """Cycles fitted over their whole history: E(t), E and the verdict come from one posterior, and
    E(t) lies below E."""
    truth = {"params": {"E": 2000.0, "G": 5.0, "tau_max": 60.0}, "strain_rate": 1e-3,
             "strain_max": 0.02, "cycles": {"count": 3}, "sample_rate": 5,
             "noise": {"strain_sd": 0.0, "stress_sd": 0.02}, "seed": 5}
    path = make_run(tmp_path, "cycles", truth, sigma0=0.02, sampler={"max_steps": 300, "target_ess": 100})
    s = sample(load_config(path), progress=False).summary
    [row] = s["modulus_at"]
    assert row["source"] == "posterior" and "whole_window" not in row
    truth_e = relaxation_modulus([row["t"]], 2000.0, 5.0, 60.0)[0]
    assert abs(row["mean"] - truth_e) < 3 * row["sd"]
    assert row["mean"] < s["posterior"]["E"]["mean"]
    c = row["checks"]
    assert c["band"]["ok"] and c["band"]["first_turn"] == pytest.approx(6.67, abs=0.3)
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


def test_a_bound_refit_of_a_test_at_another_temperature_carries_the_temperature_law(tmp_path):
    """E(t) of a test away from the reference temperature needs a_T of each bound refit: the refits
    keep the law's parameters (Ea here), and E(t)'s move is the refit's at that temperature."""
    from bayes_dnlr.inference.layout import Layout
    from bayes_dnlr.inference.modulus_estimate import AtTemperature, bound_moves
    from bayes_dnlr.model.shift import temperature_shift
    from bayes_dnlr.runs.modulus_block import posterior_refits

    data = {"columns": {"time": "t", "eps11": "e", "stress": "s"}, "observable": "stress"}
    raw = {"name": "t", "model": {"shift": {"temperature": "arrhenius", "reference_temperature": 20}},
           "tests": [{"name": f"T{c}", "data": {**data, "file": f"T{c}.csv", "temperature": c}}
                     for c in (10, 30)]}
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(raw))
    cfg = load_config(tmp_path / "config.yaml")
    layout = Layout.build({t: cfg.for_test(t).free_parameters for t in cfg.test_names},
                          cfg.per_test_parameters)
    before = {"E": 2800.0, "G": 2.0, "tau_max": 6.0, "Ea": 150.0}
    after = {**before, "tau_max": 4.0, "Ea": 140.0}
    [refit] = posterior_refits([{"parameter": "tau_max", "estimates": {"before": before, "after": after}}],
                               layout, "T10", cfg.for_test("T10"))
    assert refit.before["Ea"] == 150.0 and refit.after["Ea"] == 140.0
    at = AtTemperature("arrhenius", 20.0, 10.0)
    moves = bound_moves([refit], 1.0, 10.0, 50, 6.0, at)
    a0, a1 = (temperature_shift(10.0, "arrhenius", 20.0, Ea=p["Ea"]) for p in (before, after))
    expected = (relaxation_modulus([1.0], 2800.0, 2.0, 4.0 * a1)[0]
                - relaxation_modulus([1.0], 2800.0, 2.0, 6.0 * a0)[0]) / 10.0
    assert moves == {"tau_max": pytest.approx(expected)}


def test_the_master_curve_of_a_fit_that_holds_g_uses_the_held_value(tmp_path):
    """A joint fit at several temperatures whose windows cannot identify G holds it at 0
    (fit.json identifiability): the master curve's draws and bands take G from there."""
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.workflows.simulate import simulate_tests

    shift = {"temperature": "arrhenius", "reference_temperature": 20.0}
    tests = []
    for k, c in enumerate((0.0, 10.0, 20.0)):
        tests.append({"name": f"T{c:g}", "data": {
            "file": f"T{c:g}.csv", "columns": {"time": "t", "eps11": "e", "stress": "s"},
            "observable": "stress", "temperature": c}, "noise": {"sigma0": 0.3, "discrepancy": "none"},
            "truth": {"params": {"E": 2854.0, "G": 2.32, "tau_max": 5.79, "Ea": 150.0}, "shift": shift,
                      "temperature": c, "strain_rate": 5e-3, "strain_max": 0.005, "n_points": 120,
                      "noise": {"strain_sd": 0.0, "stress_sd": 0.3}, "seed": 11 + k}})
    raw = {"name": "held", "tests": tests, "model": {"shift": shift}, "fit": {"multistart": 0}}
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(raw))
    cfg = load_config(tmp_path / "config.yaml")
    simulate_tests(cfg)
    result = fit(cfg)
    f = json.loads((cfg.run_dir / "fit.json").read_text())
    assert "G" in f["identifiability"]["held"] and "G" not in f["estimate"]
    rows = f["modulus_reference"]["rows"]
    assert rows and result.modulus_reference["rows"] == rows
    for r in rows:          # E(t) of the held G = 0 at the reference temperature, near the truth's
        true = relaxation_modulus([r["t"]], 2854.0, 2.32, 5.79)[0]
        assert r["hdi_90"][0] < r["mean"] < r["hdi_90"][1] and abs(r["mean"] - true) < 0.1 * true
