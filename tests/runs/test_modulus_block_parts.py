"""The parts of fit.json's and summary.json's ``modulus_at`` (runs/modulus_block.py) on small
synthetic tests, without sampling: which bounds a fit's E(t) is refitted across, the fit's and the
posterior's sources, the linear range's end, the stored local fits, the trust."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from support.joint import make_joint
from support.runs import HDPE, make_run, ramp_truth

from bayes_dnlr.config import load_config
from bayes_dnlr.data.cycles import Turns
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.modulus_estimate import (
    NO_PRIOR,
    AtTemperature,
    LocalEstimate,
    ModulusEstimate,
    posterior_source,
)
from bayes_dnlr.inference.modulus_window import times_for
from bayes_dnlr.model.modulus import relaxation_modulus
from bayes_dnlr.runs import modulus_block
from bayes_dnlr.runs.testset import load_tests
from bayes_dnlr.runs.verdict import modulus_reasons

HDPE_30 = ramp_truth(0.2, n_points=30)          # the paper's HDPE, 30 samples to strain 0.2


@pytest.fixture(scope="module")
def boxed(tmp_path_factory):
    """A ramp whose tau_max (5.79 s) lies beyond its prior box's upper end, 3 s."""
    path = make_run(tmp_path_factory.mktemp("boxed"), "boxed", HDPE_30,
                    parameters={"tau_max": {"prior": "log-uniform", "low": 0.01, "high": 3.0}})
    cfg = load_config(path)
    return cfg, load_tests(cfg).tests[cfg.name]


def test_a_fit_on_a_bound_is_refitted_with_that_bound_widened_and_a_physical_limit_is_not(boxed):
    """tau_max on its box's upper end: refitted with that end ×10, where it finds the truth; G on 0,
    a modulus's physical limit: left alone (the bound check's rule, runs/checks.py)."""
    cfg, data = boxed
    refits = modulus_block._fit_refits(cfg, data, {}, {"E": 2854.0, "G": 0.0, "tau_max": 3.0})
    assert [r.parameter for r in refits] == ["tau_max"]
    [r] = refits
    assert r.before == {"E": 2854.0, "G": 0.0, "tau_max": 3.0}
    assert r.after["tau_max"] == pytest.approx(5.79, rel=0.05)


# ---------------------------------------------------------------- small helpers of the block

@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """The paper's HDPE ramp, 30 samples at 1.38 s to strain 0.2 (40 s), and a fit at its truth."""
    path = make_run(tmp_path_factory.mktemp("clean"), "clean", HDPE_30)
    cfg = load_config(path)
    tests = load_tests(cfg)
    return cfg, tests, tests.tests[cfg.name]


FIT = {"estimate": dict(HDPE), "parameters": ["E", "G", "tau_max"],
       "covariance": np.diag([25.0, 1e-4, 1e-4]).tolist(), "converged": True, "sigma0": 0.1,
       "residuals": {"white": True}}
WHY = ("the shortest time the test resolves, 2.76 s (2 sampling steps of 1.38 s into the loading), "
       "rounded up to 5 s")


def _truth(t: float, G: float = HDPE["G"]) -> float:
    return float(relaxation_modulus([t], HDPE["E"], G, HDPE["tau_max"])[0])


def test_a_model_has_e_t_when_it_has_e_and_tau_max(clean):
    cfg, _, _ = clean
    assert modulus_block.has_modulus(cfg)
    assert not modulus_block.has_modulus(SimpleNamespace(parameters={"E": 1.0, "G": 1.0}))


def test_the_trust_is_the_verdict_s_reasons_and_none_is_trust():
    ok = {"t": 1.0, "resolved": [0.5, 10.0], "source": "fit",
          "checks": {"inside_window": True, "converged": True}}
    far = {**ok, "t": 20.0, "checks": {"inside_window": False, "converged": True}}
    result = modulus_block.judged(ModulusEstimate([ok, far], {}), "r1: ")
    assert [r["trust"] for r in result.rows] == [True, False]
    assert result.rows[0]["trust_reasons"] == []
    assert result.rows[1]["trust_reasons"] == modulus_reasons(far, "r1: ")
    assert result.rows[1]["trust_reasons"][0].startswith("r1: E(20.0 s) lies outside")


def test_a_test_s_temperature_for_its_e_t():
    law = SimpleNamespace(model=SimpleNamespace(shift=SimpleNamespace(
        temperature="arrhenius", reference_temperature=20.0)))
    assert modulus_block.at_temperature(law, SimpleNamespace(temperature=np.array([39.0, 41.5]))) == \
        AtTemperature("arrhenius", 20.0, 40.25)
    assert modulus_block.at_temperature(law, SimpleNamespace()) == AtTemperature()
    none = SimpleNamespace(model=SimpleNamespace(shift=SimpleNamespace(temperature="none")))
    assert modulus_block.at_temperature(none, SimpleNamespace(temperature=40.0)) == AtTemperature()


def test_the_first_turn_of_a_test():
    t = np.array([0.0, 1.0, 2.5, 4.0])
    assert modulus_block._first_turn(SimpleNamespace(first_peak=None, time=t)) == math.inf
    assert modulus_block._first_turn(SimpleNamespace(first_peak=2, time=t)) == 2.5


# ---------------------------------------------------------------- the linear range

def test_the_window_ends_where_the_stress_the_score_points_to_is_reached(clean):
    cfg, _, data = clean
    source = posterior_source({"E": np.full(10, 2854.0)}, {"G": 2.32, "tau_max": 5.79}, True, None,
                              False)
    # HDPE's stress passes 2.18 x 8 = 17.4 MPa at its third sample, 4.14 s
    times, why, w, linear = modulus_block.resolved(cfg, data, source,
                                                   {"stress_score": {"z": 4.0, "sigma_s": 8.0}})
    assert (times, why) == ([5.0], WHY)
    assert w.longest == pytest.approx(4.137931) and w.shortest == pytest.approx(2.758621)
    assert linear == {"time": pytest.approx(4.137931), "stress": pytest.approx(17.418544),
                      "sigma_s": 8.0, "model_shift": False}
    assert w.how.endswith("the one the stress score points to (z = 4.0); the model has no stress "
                          "shift): there the stress has sped the relaxation up 2×")
    # not asked, or asked without a sigma_s: the whole window
    for fit in ({"stress_score": {"z": 1.0, "sigma_s": 8.0}}, {"stress_score": {"z": 4.0}}, {}):
        times, why, w, linear = modulus_block.resolved(cfg, data, source, fit)
        assert w == times_for(cfg, data)[2] and linear is None
    # a sigma_s the stress never reaches: the window as it was, no linear range to name
    times, why, w, linear = modulus_block.resolved(cfg, data, source,
                                                   {"stress_score": {"z": 4.0, "sigma_s": 500.0}})
    assert w.longest == 40.0 and linear is None


def test_with_a_stress_shift_the_model_s_sigma_s_ends_the_window(clean):
    cfg, _, data = clean
    shifted = cfg.with_shift(stress="eyring")
    source = posterior_source({"sigma_s": np.array([7.0, 8.0, 9.0])},
                              {"E": 2854.0, "G": 2.32, "tau_max": 5.79}, True, None, False)
    # the score of a stress-blind fit is not read: the model has the shift
    _, _, w, linear = modulus_block.resolved(shifted, data, source,
                                             {"stress_score": {"z": 4.0, "sigma_s": 500.0}})
    assert linear == {"time": pytest.approx(4.137931), "stress": pytest.approx(17.418544),
                      "sigma_s": 8.0, "model_shift": True}
    assert "(2.18 sigma_s, sigma_s = 8 MPa, the model's)" in w.how


def test_a_stress_refit_only_where_the_data_ask_for_it(clean):
    cfg, _, data = clean
    assert modulus_block.stress_refit(cfg, data, {**FIT, "stress_score": {"z": 1.0}}) is None
    assert modulus_block.stress_refit(cfg, data, FIT) is None
    no_modulus = SimpleNamespace(parameters={"E": 1.0})
    assert modulus_block.stress_refit(no_modulus, data, {**FIT, "stress_score": {"z": 4.0}}) is None
    refit = modulus_block.stress_refit(cfg, data, {**FIT, "stress_score": {"z": 4.0, "sigma_s": 8.0}})
    assert set(refit) == {"estimate", "sigma_s", "converged"} and refit["converged"] is True
    assert refit["sigma_s"] == refit["estimate"]["sigma_s"] > 0
    # a straight HDPE ramp: the shift barely moves E
    assert refit["estimate"]["E"] == pytest.approx(HDPE["E"], rel=0.05)


# ---------------------------------------------------------------- a fit

def test_a_fit_s_analysis_white_or_under_model_error():
    assert not modulus_block.under_model_error(FIT)
    under = {**FIT, "discrepancy": {"evidence": True, "estimate": {"E": 2800.0},
                                    "covariance": [[9.0]]}}
    assert modulus_block.under_model_error(under)
    for d in ({"evidence": False, "estimate": {"E": 1.0}, "covariance": [[1.0]]},
              {"evidence": True, "estimate": {}, "covariance": [[1.0]]},
              {"evidence": True, "estimate": {"E": 1.0}, "covariance": None}):
        assert not modulus_block.under_model_error({**FIT, "discrepancy": d})
    est, cov, names, is_under = modulus_block.analysis(under)
    assert est == {**HDPE, "E": 2800.0} and cov.tolist() == [[9.0]] and is_under
    assert names == ["E", "G", "tau_max"]
    est, cov, names, is_under = modulus_block.analysis(FIT)
    assert est == HDPE and cov.tolist() == FIT["covariance"] and not is_under
    est, cov, names, _ = modulus_block.analysis({"estimate": {"E": 1.0, "tau_max": 2.0}})
    assert cov is None and names == ["E", "tau_max"]


def test_a_fit_s_view_holds_what_the_fit_held(clean):
    cfg, _, _ = clean
    fit = {"identifiability": {"held": {"G": {"value": 2.0}}}, "fixed": {"G": 9.0, "tau_max": 5.0,
                                                                        "Ea": 100.0}}
    view = modulus_block.fit_view(cfg, fit)
    assert view.free_parameters == ["E"] and view.fixed_values == {"G": 2.0, "tau_max": 5.0}
    assert modulus_block.fit_view(cfg, {}) is cfg


def test_the_fit_s_source_is_its_laplace_draws(clean):
    cfg, _, _ = clean
    view = cfg.with_holds({"G": 2.32})
    fit = {"estimate": {"E": 2854.0, "tau_max": 5.79}, "parameters": ["E", "tau_max"],
           "covariance": [[25.0, 0.0], [0.0, 1e-4]]}
    source = modulus_block._source_of_fit(view, fit)
    assert source.kind == "fit" and source.fixed == {"G": 2.32} and source.converged is True
    assert not source.under_model_error and set(source.draws) == {"E", "tau_max"}
    assert source.draws["E"].std() == pytest.approx(5.0, rel=0.15)
    assert modulus_block._source_of_fit(view, {**fit, "converged": False}).converged is False


def test_the_fit_s_e_t_with_its_checks(clean):
    cfg, _, data = clean
    result = modulus_block.fit_rows(cfg, data, FIT)
    [row] = result.rows
    assert (row["t"], row["source"], row["why"]) == (5.0, "fit", WHY)
    assert row["resolved"] == [pytest.approx(2.758621), 40.0]
    assert abs(row["mean"] - _truth(5.0)) < 4 * row["sd"] and 0 < row["sd"] < 5
    assert row["trust"] and row["trust_reasons"] == [] and row["lacks"] == {"prior": NO_PRIOR}
    c = row["checks"]
    assert c["band"]["ok"] and c["band"]["window"] == [0.0, 40.0] and c["start"]["ok"]
    assert c["noise_model"] is True and c["converged"] is True and c["bounds"] == {}
    assert result.curve["source"] == "fit" and result.curve["resolved"] == row["resolved"]
    # residuals that are not white under a white likelihood: the noise model fails, named
    waves = modulus_block.fit_rows(cfg, data, {**FIT, "residuals": {"white": False}}, "r1: ",
                                   times=[3.0, 30.0])
    assert [r["t"] for r in waves.rows] == [3.0, 30.0]
    assert all(r["why"] == "times every test of the run resolves" for r in waves.rows)
    assert all(r["checks"]["noise_model"] is False for r in waves.rows)
    assert waves.rows[0]["trust_reasons"] == [
        "r1: a white likelihood on residuals that are not white: E(3.00 s)'s interval ignores the "
        "model error"]
    not_converged = modulus_block.fit_rows(cfg, data, {**FIT, "converged": False})
    assert not_converged.rows[0]["trust_reasons"] == ["the fit has not converged"]


def test_the_fit_s_e_t_holds_what_the_fit_held(clean):
    cfg, _, data = clean
    held = {"estimate": {"E": 2854.0, "tau_max": 5.79}, "parameters": ["E", "tau_max"],
            "covariance": [[25.0, 0.0], [0.0, 1e-4]], "sigma0": 0.1,
            "identifiability": {"held": {"G": {"value": 2.32}}}}
    [row] = modulus_block.fit_rows(cfg, data, held).rows
    assert abs(row["mean"] - _truth(5.0)) < 4 * row["sd"]


def test_no_e_t_without_a_fit_or_a_modulus(clean):
    cfg, _, data = clean
    assert modulus_block.fit_rows(cfg, data, {}) is None
    assert modulus_block.fit_rows(SimpleNamespace(parameters={"E": 1.0}), data, FIT) is None


# ---------------------------------------------------------------- local fits

def test_local_fits_where_the_start_alone_holds_enough_samples(clean):
    """E(t) fitted on the loading up to 10 t: only where that holds at least 12 samples and at
    most half the window's 30."""
    cfg, _, data = clean
    local = modulus_block.local_estimates(cfg, data, FIT, [0.5, 1.0, 1.9, 2.1, 5.0], 1.0)
    assert list(local) == [1.9]
    [(t, e)] = local.items()
    assert (e.end, e.time_max) == (pytest.approx(19.0), pytest.approx(20.0))
    assert abs(e.mean - _truth(1.9)) < 4 * e.sd and 0 < e.sd < 5
    assert modulus_block.local_estimates(cfg, data, {}, [1.9], 1.0) == {}


def test_a_local_fit_ends_at_the_first_turn(clean):
    cfg, _, data = clean
    turned = dataclasses.replace(data, turns=Turns((14,), ()))
    assert turned.first_peak == 14
    local = modulus_block.local_estimates(cfg, turned, FIT, [2.0], 0.0)
    assert local[2.0].time_max == pytest.approx(float(data.time[14]))


def test_stored_local_fits_are_read_back_at_every_time_or_not_at_all():
    c = {"local_mean": 900.0, "local_sd": 1.5, "window_end": 19.0, "time_max": 20.0, "z": 0.1,
         "ok": True}
    fit = {"modulus_at": [{"t": 1.9, "checks": {"local": c}}, {"t": 5.0, "checks": {"local": None}},
                          "an entry of an older version"]}
    assert modulus_block._stored_local(fit, [1.9, 5.0]) == {1.9: LocalEstimate(900.0, 1.5, 19.0, 20.0)}
    assert modulus_block._stored_local(fit, [1.9, 2.0]) is None
    assert modulus_block._stored_local({}, [1.9]) is None


# ---------------------------------------------------------------- a posterior

def _draws(names: list[str], n: int = 800, seed: int = 1) -> np.ndarray:
    """Normal draws about the HDPE truth (a joint run's tau_max of each test at 5.79 s too)."""
    rng = np.random.default_rng(seed)
    sd = {"E": 5.0, "G": 0.01, "tau_max": 0.01}
    return np.column_stack([rng.normal(HDPE[k.split("[")[0]], sd[k.split("[")[0]], n) for k in names])


def test_a_posterior_s_e_t_of_one_test(clean):
    cfg, tests, _ = clean
    layout = Layout.build({cfg.name: cfg.free_parameters}, [], plain=True)
    draws = _draws(layout.names).reshape(100, 8, 3)          # (steps, walkers, parameters)
    checks = {"noise_model": {cfg.name: {"likelihood": "white", "ok": True}}, "bound_limited": []}
    rows, curve = modulus_block.posterior_block(cfg, tests, layout, draws, layout.names, {}, checks,
                                                None, True, FIT)
    [row] = rows
    assert (row["t"], row["source"], row["why"], row["trust"]) == (5.0, "posterior", WHY, True)
    assert abs(row["mean"] - _truth(5.0)) < 4 * row["sd"] and "lacks" not in row
    assert row["checks"]["band"] is None and row["checks"]["local"] is None
    assert curve["source"] == "posterior" and curve["resolved"] == row["resolved"]
    # the noise-model check's failure and the stopping rule reach the trust
    failed = {**checks, "noise_model": {cfg.name: {"likelihood": "white", "ok": False}}}
    [row] = modulus_block.posterior_block(cfg, tests, layout, draws, layout.names, {}, failed, None,
                                          False, FIT)[0]
    assert row["trust_reasons"] == [
        "a white likelihood on residuals that are not white: E(5.00 s)'s interval ignores the model "
        "error", "the chain has not converged"]


def test_a_posterior_reads_the_fit_s_local_fits_rather_than_fit_again(clean):
    cfg, tests, _ = clean
    layout = Layout.build({cfg.name: cfg.free_parameters}, [], plain=True)
    stored = {"local_mean": _truth(5.0) + 30.0, "local_sd": 1.0, "window_end": 50.0,
              "time_max": 50.0, "z": 0.0, "ok": True}
    fit = {**FIT, "modulus_at": [{"t": 5.0, "checks": {"local": stored}}]}
    checks = {"noise_model": {}, "bound_limited": []}
    [row] = modulus_block.posterior_block(cfg, tests, layout, _draws(layout.names), layout.names, {},
                                          checks, None, True, fit)[0]
    local = row["checks"]["local"]
    assert (local["local_mean"], local["local_sd"], local["window_end"]) == (
        pytest.approx(_truth(5.0) + 30.0), 1.0, 50.0)
    assert local["z"] == pytest.approx(row["mean"] - stored["local_mean"], abs=5.0)
    assert not local["ok"] and not row["trust"]


@pytest.fixture(scope="module")
def joint(tmp_path_factory):
    path = make_joint(tmp_path_factory.mktemp("joint"), "joint", per_test=("tau_max",), n_points=30)
    cfg = load_config(path)
    layout = Layout.build({t: cfg.for_test(t).free_parameters for t in cfg.test_names},
                          cfg.per_test_parameters)
    return cfg, load_tests(cfg), layout


def test_a_joint_posterior_gives_each_test_its_e_t_under_its_own_names(joint):
    cfg, tests, layout = joint
    draws = _draws(layout.names)
    names = layout.names
    checks = {"noise_model": {"r5e-3": {"likelihood": "discrepancy", "ok": True},
                              "r1e-2": {"likelihood": "white", "ok": False}},
              "bound_limited": []}
    sources = modulus_block.posterior_sources(cfg, layout, draws, names, checks, None, True)
    assert list(sources) == ["r2.5e-3", "r5e-3", "r1e-2"]
    s = sources["r5e-3"]
    assert set(s.draws) == {"E", "G", "tau_max"} and s.under_model_error
    np.testing.assert_array_equal(s.draws["tau_max"], draws[:, names.index("tau_max[r5e-3]")])
    np.testing.assert_array_equal(s.draws["E"], draws[:, names.index("E")])
    assert not sources["r2.5e-3"].under_model_error
    block, curves = modulus_block.posterior_block(cfg, tests, layout, draws, names, {}, checks, None,
                                                  True, {"single_fits": {}})
    assert list(block) == ["tests"] and list(block["tests"]) == list(curves) == list(sources)
    assert [r["trust"] for rows in block["tests"].values() for r in rows] == [True, True, False]
    [reason] = block["tests"]["r1e-2"][0]["trust_reasons"]
    assert reason.startswith("r1e-2: a white likelihood on residuals that are not white")


def test_the_bound_check_s_refits_in_a_test_s_own_names(joint):
    cfg, _, layout = joint
    view = cfg.for_test("r5e-3").with_holds({"G": 2.32})
    before = {"E": 2854.0, "tau_max[r5e-3]": 3.0, "tau_max[r1e-2]": 9.0}
    after = {"E": 2850.0, "tau_max[r5e-3]": 5.8, "tau_max[r1e-2]": 9.5}
    entries = [{"parameter": "tau_max[r5e-3]", "estimates": {"before": before, "after": after}},
               {"parameter": "G", "note": "a physical limit"},
               {"parameter": "E", "estimates": {"before": {"E": 1.0}, "after": {"E": 2.0}}}]
    [r] = modulus_block.posterior_refits(entries, layout, "r5e-3", view)
    assert r.parameter == "tau_max[r5e-3]"
    assert r.before == {"E": 2854.0, "G": 2.32, "tau_max": 3.0}
    assert r.after == {"E": 2850.0, "G": 2.32, "tau_max": 5.8}


def test_whether_a_test_s_posterior_used_the_discrepancy():
    checks = {"noise_model": {"a": {"likelihood": "discrepancy"}, "b": {"likelihood": "white"}}}
    assert modulus_block.uses_discrepancy(checks, "a")
    assert not modulus_block.uses_discrepancy(checks, "b")
    assert not modulus_block.uses_discrepancy(checks, "c") and not modulus_block.uses_discrepancy({}, "a")
