"""The check before pooling (inference/analyses/heterogeneity.py): the one test of agreement
decides; tests that agree within their own uncertainty pass; tests that differ beyond it fail
however small their relative spread (I² = 98 % is not one material); two materials fail and the
smaller set stands out; the quantity compared and the fallback's reason are in the words."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.analyses import heterogeneity as het
from bayes_dnlr.inference.analyses.agreement import P_AGREE, agreement


def test_the_figures_are_those_of_the_one_test_of_agreement():
    means, sds = [2900.0, 2850.0, 2800.0], [20.0, 15.0, 25.0]
    c = het.one_material(list("abc"), means, sds)
    a = agreement("E", dict(zip("abc", means, strict=True)), dict(zip("abc", sds, strict=True)))
    assert c["Q"] == pytest.approx(a.q) and c["p_value"] == pytest.approx(a.p)
    assert c["I2"] == pytest.approx(a.i2) and c["tau"] == pytest.approx(a.tau)
    assert c["weighted_mean"] == pytest.approx(a.pooled) and c["dof"] == 2
    assert c["random_effects"] == {"mean": pytest.approx(a.re_mean), "sd": pytest.approx(a.re_sd)}
    assert set(c["worst_pair"]) == {"a", "c"} and c["limits"] == {"p_agree": P_AGREE}
    assert c["passed"] is (a.p >= P_AGREE)


def test_a_small_relative_spread_far_beyond_the_uncertainty_is_not_one_material():
    """Three tests 2 % apart with sds of 0.2 %: I² = 0.98; the old rule (τ under 10 % of E) called
    them one material."""
    c = het.one_material(["a", "b", "c"], [1180.0, 1200.0, 1158.0], [2.4, 2.4, 2.4],
                         quantity="E(0.5 s)")
    assert c["I2"] > 0.98 and c["relative_spread"] < 0.05
    assert c["passed"] is False
    assert "E(0.5 s) differ beyond their own uncertainty" in c["words"]
    assert "not shown as one material" in c["words"] and "I² = 99 %" in c["words"]
    assert "furthest apart: b and c" in c["words"]


def test_two_materials_do_not_look_like_one_and_the_smaller_set_stands_out():
    rng = np.random.default_rng(1)
    means = np.r_[2500 + rng.normal(0, 25, 3), 1500 + rng.normal(0, 25, 4)]
    names = ["b1", "b2", "b3", "a1", "a2", "a3", "a4"]
    c = het.one_material(names, means, [25.0] * 7)
    assert c["passed"] is False and c["stand_out"] == ["b1", "b2", "b3"]        # in input order
    assert [len(s["tests"]) for s in c["split"]["sets"]] == [4, 3]           # low E first
    assert "standing out: b1, b2, b3" in c["words"] and "Label each test's material" in c["words"]
    labelled = het.one_material(names, means, [25.0] * 7, labelled=True)
    assert "Label each" not in labelled["words"] and "check these tests" in labelled["words"]


def test_tests_that_agree_pass_and_one_test_is_not_checked():
    c = het.one_material(["a", "b", "c"], [1502.0, 1495.0, 1510.0], [20.0] * 3)
    assert c["passed"] is True and c["p_value"] > 0.5 and c["stand_out"] == []
    assert "agree within their own uncertainty" in c["words"]
    two = het.one_material(["a", "b"], [1500.0, 2500.0], [20.0] * 2)
    assert two["passed"] is False and "split" not in two and "a and b" in two["words"]
    one = het.one_material(["a"], [1500.0], [20.0])
    assert one["passed"] is None and "too few" in one["words"]


def test_the_fallback_says_why_e_is_compared():
    c = het.one_material(["a", "b"], [1500.0, 1505.0], [20.0] * 2,
                         note="E(t) not compared: no time at which every test has E(t)")
    assert c["quantity"] == "E" and c["note"].startswith("E(t) not compared")
    assert c["words"].endswith("(E(t) not compared: no time at which every test has E(t))")


def test_between_groups():
    differ = het.between_groups({"A": (1500.0, 20.0), "B": (2500.0, 25.0)}, quantity="E(2 s)")
    assert differ["passed"] is False and "no value spans them" in differ["words"]
    assert "E(2 s) differ" in differ["words"] and "1 degree of freedom" in differ["words"]
    same = het.between_groups({"A": (1500.0, 20.0), "B": (1510.0, 25.0)})
    assert same["passed"] is True and "could be one material" in same["words"]
    assert het.between_groups({"A": (1.0, 1.0)})["passed"] is None
