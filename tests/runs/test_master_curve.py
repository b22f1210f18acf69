"""The master curve (runs/master_curve.py) on small synthetic tests at three temperatures, without
sampling or fitting: each test's window in reduced time, the default reference times, which test
gives each time, the temperature law's held-out check on the rows, and a joint fit's Laplace draws
split per test."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from support.joint import make_joint
from support.temperatures import TRUTH, make_temperatures

from bayes_dnlr.config import load_config
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.modulus_estimate import NO_PRIOR, Source, posterior_source
from bayes_dnlr.model.modulus import relaxation_modulus
from bayes_dnlr.model.shift import temperature_shift
from bayes_dnlr.numbers import fmt
from bayes_dnlr.runs import master_curve as mc
from bayes_dnlr.runs.modulus_block import resolved
from bayes_dnlr.runs.testset import load_tests

SD = {"E": 5.0, "G": 0.05, "tau_max": 2.0, "Ea": 2.0, "sigma_s": 0.02}


def _source(seed: int, ea: float = TRUTH["Ea"]) -> Source:
    rng = np.random.default_rng(seed)
    return posterior_source({k: rng.normal({**TRUTH, "Ea": ea}[k], SD[k], 400) for k in TRUTH}, {},
                            True, None, False)


@pytest.fixture(scope="module")
def three(tmp_path_factory):
    """Ramps at 0, 20 and 40 °C (40 samples each), the law Arrhenius at 20 °C, and posterior draws
    about the truth for each test."""
    cfg = load_config(make_temperatures(tmp_path_factory.mktemp("three"), "three", n_points=40))
    sources = {t: _source(i) for i, t in enumerate(cfg.test_names)}
    return cfg, load_tests(cfg), sources


def test_each_test_s_window_in_reduced_time(three):
    cfg, tests, sources = three
    windows = mc.reduced_windows(cfg, tests, sources, {})
    assert list(windows) == ["T0", "T20", "T40"]
    for t, w in windows.items():
        ea = float(np.median(sources[t].draws["Ea"]))
        a = temperature_shift(w["temperature"], "arrhenius", 20.0, Ea=ea)
        own = resolved(cfg.for_test(t), tests.tests[t], sources[t], {})[2]
        assert w["a_T"] == pytest.approx(a, rel=1e-12)
        assert w["resolved"] == [own.shortest, own.longest]
        assert w["reduced"] == pytest.approx([own.shortest / a, own.longest / a], rel=1e-12)
    assert windows["T20"]["a_T"] == 1.0 and windows["T0"]["temperature"] == 0.0


def test_the_default_reference_times_one_per_decade_from_the_shortest():
    assert mc.default_times({"a": {"reduced": [0.0034, 0.02]}, "b": {"reduced": [0.5, 250.0]}}) == [
        0.005, 0.01, 0.1, 1.0, 10.0, 100.0]
    assert mc.default_times({"a": {"reduced": [0.8, 100.0]}}) == [1.0, 10.0, 100.0]
    assert mc.default_times({"a": {"reduced": [0.8, 99.0]}}) == [1.0, 10.0]
    assert mc.default_times({"a": {"reduced": [2e-4, 1e6]}}) == [2e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0]
    # a window too short to reach a rounded time: its shortest time
    assert mc.default_times({"a": {"reduced": [0.0034, 0.0045]}}) == [0.0034]


def test_each_time_from_the_test_that_holds_it_farthest_from_its_ends():
    windows = {"a": {"reduced": [0.01, 10.0]}, "b": {"reduced": [1.0, 1000.0]}}
    assert mc._holder(windows, 0.5) == ("a", True)
    assert mc._holder(windows, 5.0) == ("b", True)        # 5x inside b, 2x inside a
    assert mc._holder(windows, 1000.0) == ("b", True)
    assert mc._holder(windows, 2000.0) == ("b", False)
    assert mc._holder(windows, 0.001) == ("a", False)


def test_the_law_s_held_out_check_of_the_tests_a_row_comes_from():
    block = {"held_out": [{"temperature": 0.0, "tests": {"T0": {"ok": False}, "T0b": {"ok": True}}},
                          {"temperature": 40.0, "tests": {"T40": {"ok": True}}},
                          {"temperature": 60.0, "tests": {}}]}
    assert mc._law_check(block, 0.0, 20.0) == {"temperature": 0.0, "ok": False}
    assert mc._law_check(block, 40.0, 20.0) == {"temperature": 40.0, "ok": True}
    assert mc._law_check(block, 60.0, 20.0) is None
    assert mc._law_check(block, 20.0, 20.0) is None and mc._law_check(None, 0.0, 20.0) is None
    assert mc._law_check({"held_out": []}, 0.0, 20.0) is None


def test_the_master_curve_s_rows_and_curve(three):
    cfg, tests, sources = three
    out = mc.master_curve(cfg, tests, sources, {}, {}, {}, {}, None)
    windows = mc.reduced_windows(cfg, tests, sources, {})
    assert (out["temperature"], out["law"], out["windows"]) == (20.0, "arrhenius", windows)
    times = mc.default_times(windows)
    assert [r["t"] for r in out["rows"]] == times
    for r in out["rows"]:
        test, inside = mc._holder(windows, r["t"])
        w = windows[test]
        assert r["test"] == test and r["checks"]["inside_window"] is inside and r["trust"] is inside
        assert r["resolved"] == w["reduced"] and r["source"] == "posterior"
        assert r["why"] == (f"the reduced times of {test} ({w['temperature']:g} °C): its resolved "
                            f"{w['resolved'][0]:.3g}-{w['resolved'][1]:.4g} s over a_T = "
                            f"{w['a_T']:.4g}")
        assert r["lacks"] == {"spectrum exponent": mc.NO_SPREAD}
        # E(t) at the reference temperature: the holder's draws without its own a_T
        d = sources[test].draws
        e_t = relaxation_modulus([r["t"]], d["E"], d["G"], d["tau_max"])[:, 0]
        assert r["mean"] == pytest.approx(e_t.mean(), rel=1e-12)
        assert "temperature" not in r and "shift_law" not in r["checks"]
    curve = out["curve"]
    lo = min(w["reduced"][0] for w in windows.values())
    hi = max(w["reduced"][1] for w in windows.values())
    assert curve["resolved"] == [lo, hi] and curve["t"][0] == pytest.approx(lo / 100)
    assert curve["t"][-1] == pytest.approx(hi)
    assert curve["windows"] == {t: w["reduced"] for t, w in windows.items()}
    cold = sources["T0"].draws                       # the test that reaches the shortest times
    assert curve["E_median"] == pytest.approx(float(np.median(cold["E"])))


def test_asked_times_and_a_law_that_does_not_carry_a_temperature(three):
    cfg, tests, sources = three
    windows = mc.reduced_windows(cfg, tests, sources, {})
    t0 = float(np.sqrt(np.prod(windows["T0"]["reduced"])))       # inside T0's window
    t40 = float(np.sqrt(np.prod(windows["T40"]["reduced"])))
    asked = cfg.model_copy(update={"output": cfg.output.model_copy(update={"modulus_at": [t0, t40]})})
    law = {"held_out": [{"temperature": 0.0, "tests": {"T0": {"ok": False}}},
                        {"temperature": 40.0, "tests": {"T40": {"ok": True}}}]}
    out = mc.master_curve(asked, tests, sources, {}, {}, {}, {"T40": False}, law)
    cold, warm = out["rows"]
    assert (cold["t"], cold["test"], warm["t"], warm["test"]) == (t0, "T0", t40, "T40")
    assert cold["checks"]["shift_law"] == {"temperature": 0.0, "ok": False} and not cold["trust"]
    assert cold["trust_reasons"] == [
        f"the temperature law does not carry the tests at 0 °C from the others (its held-out "
        f"check): E({fmt(t0, 3)} s) at the reference temperature from them is the law's, not the "
        "data's"]
    # T40's noise model failed: its row says so; its law passed
    assert warm["checks"]["shift_law"] == {"temperature": 40.0, "ok": True}
    assert warm["checks"]["noise_model"] is False and not warm["trust"]
    assert warm["trust_reasons"][0].startswith("a white likelihood on residuals that are not white")


def test_no_master_curve_without_a_law_or_a_second_temperature(three):
    cfg, tests, sources = three
    assert mc.master_curve(cfg, tests, {"T0": sources["T0"]}, {}, {}, {}, {}) is None
    flat = cfg.model_copy(update={"model": cfg.model.model_copy(update={
        "shift": cfg.model.shift.model_copy(update={"temperature": "none"})})})
    assert mc.master_curve(flat, tests, sources, {}, {}, {}, {}) is None
    # two tests, both at 20 °C
    both = SimpleNamespace(tests={"T0": dataclasses.replace(tests.tests["T0"], temperature=20.0),
                                  "T20": tests.tests["T20"]})
    two = {t: sources[t] for t in ("T0", "T20")}
    assert mc.master_curve(cfg, both, two, {}, {}, {}, {}) is None
    assert mc.master_curve(cfg, tests, two, {}, {}, {}, {}) is not None


# ---------------------------------------------------------------- a joint fit

def test_a_joint_source_split_into_each_test_s_own_names(tmp_path):
    cfg = load_config(make_joint(tmp_path, "joint", per_test=("tau_max",), n_points=30))
    layout = Layout.build({t: cfg.for_test(t).free_parameters for t in cfg.test_names},
                          cfg.per_test_parameters)
    draws = {k: np.full(3, float(i)) for i, k in enumerate(layout.names)}
    draws.pop("G")
    joint = Source("fit", draws, {"G": 2.32, "sigma0": 0.1}, False, None, True, {"prior": NO_PRIOR})
    split = mc.test_sources(cfg, layout, joint)
    assert list(split) == cfg.test_names
    s = split["r5e-3"]
    assert set(s.draws) == {"E", "tau_max"} and s.draws["tau_max"].tolist() == [3.0] * 3
    assert s.fixed == {"G": 2.32, "sigma0": 0.1} and s.kind == "fit" and not s.converged
    assert s.under_model_error and s.lacks == {"prior": NO_PRIOR} and s.log_prior is None
    assert split["r1e-2"].draws["tau_max"].tolist() == [4.0] * 3


def _result(cfg, white=("T0", "T20", "T40"), under=False):
    names = cfg.free_parameters
    joint = {"estimate": dict(TRUTH), "parameters": names, "converged": True,
             "covariance": np.diag([SD[k] ** 2 for k in names]).tolist()}
    if under:
        joint["discrepancy"] = {"evidence": True, "estimate": dict(TRUTH),
                                "covariance": joint["covariance"]}
    singles = {t: SimpleNamespace(to_dict=lambda t=t: {"sigma0": 0.05,
                                                       "residuals": {"white": t in white}})
               for t in cfg.test_names}
    return SimpleNamespace(to_dict=lambda: joint, singles=singles, shift_law=None)


def test_a_joint_fit_s_master_curve_from_its_laplace_draws(three):
    cfg, tests, _ = three
    out = mc.fit_master_curve(cfg, tests, _result(cfg, white=("T0", "T20")))
    rows = out["rows"]
    assert [r["t"] for r in rows] == [0.001, 0.01, 0.1, 1.0, 10.0, 100.0]
    for r in rows:
        assert r["source"] == "fit" and r["lacks"]["prior"] == NO_PRIOR
        truth = relaxation_modulus([r["t"]], TRUTH["E"], TRUTH["G"], TRUTH["tau_max"])[0]
        assert abs(r["mean"] - truth) < 4 * r["sd"]
        assert r["checks"]["band"] is not None and r["checks"]["noise_model"] is (r["test"] != "T40")
    inside = [r for r in rows if r["checks"]["inside_window"]]
    assert [r["test"] for r in inside] == ["T0"] and inside[0]["trust"]
    assert inside[0]["checks"]["band"]["ok"]
    # under model error the generalized analysis's noise model holds for every test
    under = mc.fit_master_curve(cfg, tests, _result(cfg, white=(), under=True))
    assert all(r["checks"]["noise_model"] for r in under["rows"])
    flat = cfg.model_copy(update={"model": cfg.model.model_copy(update={
        "shift": cfg.model.shift.model_copy(update={"temperature": "none"})})})
    assert mc.fit_master_curve(flat, tests, _result(cfg)) is None
    assert math.isfinite(out["curve"]["E_median"])
