"""Tests at several temperatures in one fit (docs/theory.md, "The shift factor"): the law's
parameters shared and identified, each test's E(t) at its own temperature, the master curve at the
reference temperature (runs/master_curve.py), the held-out check of the law (runs/shift_law.py) and
`consistency` in reduced time."""

from __future__ import annotations

import json

import numpy as np
import pytest
from support.temperatures import SHIFT, TRUTH, make_temperatures

from bayes_dnlr.config import load_config
from bayes_dnlr.model.modulus import relaxation_modulus
from bayes_dnlr.model.shift import temperature_shift
from bayes_dnlr.runs.fit import fit


@pytest.fixture(scope="module")
def three(tmp_path_factory):
    path = make_temperatures(tmp_path_factory.mktemp("temperatures"), "three")
    fit(load_config(path))
    return path, json.loads((path.parent / "fit.json").read_text())


def test_tests_at_several_temperatures_identify_the_shared_law(three):
    _, f = three
    for k in ("E", "tau_max", "Ea", "sigma_s"):
        assert abs(f["estimate"][k] - TRUTH[k]) < 4 * f["sd"][k], (k, f["estimate"][k], f["sd"][k])
    # each test alone held Ea (it cannot tell it from tau_max) and still fitted its curve
    for name, single in f["single_fits"].items():
        assert single["fixed"]["Ea"] == 100.0 and "Ea" not in single["parameters"], name


def test_each_test_s_e_t_is_at_its_own_temperature(three):
    path, f = three
    for name, single in f["single_fits"].items():
        [row] = single["modulus_at"]
        T = float(name[1:])
        a_t = temperature_shift(T, "arrhenius", 20.0, Ea=TRUTH["Ea"])
        truth = relaxation_modulus([row["t"]], TRUTH["E"], TRUTH["G"], TRUTH["tau_max"],
                                   shift_factor=a_t)[0]
        if T != 20.0:
            assert row["temperature"] == T
        if row["trust"]:            # a test alone may sit on a bound (T0's tau_max): then untrusted
            assert abs(row["mean"] - truth) < 4 * row["sd"], (name, row["mean"], truth, row["sd"])


def test_the_master_curve_holds_the_reference_e_t_over_the_tests_reduced_windows(three):
    _, f = three
    ref = f["modulus_reference"]
    assert ref["temperature"] == 20 and ref["law"] == "arrhenius"
    w = ref["windows"]
    # the cold test reaches shorter reduced times than any test at the reference temperature
    assert w["T0"]["a_T"] > 1 > w["T40"]["a_T"] and w["T20"]["a_T"] == pytest.approx(1.0)
    assert w["T0"]["reduced"][0] < w["T20"]["reduced"][0] < w["T40"]["reduced"][0]
    inside = [r for r in ref["rows"] if r["checks"]["inside_window"]]
    assert {r["test"] for r in inside} >= {"T0", "T20"}
    for r in inside:
        truth = relaxation_modulus([r["t"]], TRUTH["E"], TRUTH["G"], TRUTH["tau_max"])[0]
        assert abs(r["mean"] - truth) < 4 * r["sd"], (r["t"], r["mean"], truth, r["sd"])
        assert r["lacks"]["spectrum exponent"]
    assert ref["curve"]["windows"]["T0"] == w["T0"]["reduced"]


def test_the_law_is_held_out_one_temperature_at_a_time(three):
    _, f = three
    law = f["shift_law"]
    assert [e["temperature"] for e in law["held_out"]] == [0.0, 20.0, 40.0]
    for e in law["held_out"]:
        [(name, x)] = e["tests"].items()
        assert x["points"] == 150 and 0 < x["p"] <= 1 and x["ok"] == (x["p"] >= 0.01)
        assert set(e["law"]) == {"Ea", "sigma_s"}
    assert law["ok"] is all(x["ok"] for e in law["held_out"] for x in e["tests"].values())


def test_two_temperatures_cannot_hold_one_out_and_say_so(tmp_path):
    path = make_temperatures(tmp_path, "two", (10.0, 30.0), n_points=80)
    f = fit(load_config(path)).to_dict()
    assert f["shift_law"]["ok"] is None and "3 are needed" in f["shift_law"]["note"]


@pytest.mark.slow
def test_a_wrong_law_fails_its_held_out_check(tmp_path):
    """WLF data fitted with Arrhenius: every temperature's tests lie beyond the others' prediction,
    and the verdict withdraws E's trust."""
    wlf = {**SHIFT, "temperature": "wlf"}
    params = {k: v for k, v in TRUTH.items() if k != "Ea"} | {"C1": 17.4, "C2": 51.6}
    path = make_temperatures(tmp_path, "wlf", (0.0, 10.0, 20.0, 30.0), truth_shift=wlf, params=params)
    f = fit(load_config(path)).to_dict()
    assert f["shift_law"]["ok"] is False
    assert sum(not x["ok"] for e in f["shift_law"]["held_out"] for x in e["tests"].values()) >= 3
    from bayes_dnlr.runs.verdict import shift_law_words

    assert "does not predict the tests at" in shift_law_words(f["shift_law"])


def test_consistency_compares_in_reduced_time_or_says_why_not(three):
    from bayes_dnlr.runs.consistency import reduced_times
    from bayes_dnlr.runs.testset import load_tests

    path, f = three
    cfg = load_config(path)
    times, factor, note = reduced_times(cfg, load_tests(cfg), f)
    assert factor["T20"] == pytest.approx(1.0) and factor["T0"] > 1 > factor["T40"]
    # 20 °C apart at 250 kJ/mol the windows do not overlap in reduced time
    assert times == [] and "do not overlap" in note
    assert np.isfinite(list(factor.values())).all()
