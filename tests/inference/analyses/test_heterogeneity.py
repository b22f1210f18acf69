"""The check before pooling (inference/analyses/heterogeneity.py): two materials among the tests
fail it and the smaller set is named; specimens of one material that differ by a few per cent pass;
tests that agree within their own uncertainty pass; the statistics by hand; between groups."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayes_dnlr.inference.analyses import heterogeneity as het


def test_weighted_spread_by_hand():
    s = het.weighted_spread([2900.0, 2850.0, 2800.0], [20.0, 15.0, 25.0])
    w = np.array([1 / 400, 1 / 225, 1 / 625])
    m = np.array([2900.0, 2850.0, 2800.0])
    mean = float(w @ m / w.sum())
    q = float(w @ (m - mean) ** 2)
    assert s["weighted_mean"] == pytest.approx(mean) and s["Q"] == pytest.approx(q)
    assert s["dof"] == 2 and s["p_value"] == pytest.approx(math.exp(-q / 2))   # χ²₂: sf = e^(-q/2)
    assert s["I2"] == pytest.approx((q - 2) / q)
    assert s["tau"] == pytest.approx(math.sqrt((q - 2) / (w.sum() - (w @ w) / w.sum())))


def test_two_materials_do_not_look_like_one_and_the_smaller_set_stands_out():
    rng = np.random.default_rng(1)
    means = np.r_[2500 + rng.normal(0, 25, 3), 1500 + rng.normal(0, 25, 4)]
    names = ["b1", "b2", "b3", "a1", "a2", "a3", "a4"]
    c = het.one_material(names, means, [25.0] * 7)
    assert c["passed"] is False and c["stand_out"] == ["b1", "b2", "b3"]        # in input order
    assert c["relative_spread"] > het.RELATIVE_SPREAD_MAX and c["split"]["p_value"] < het.P_SPLIT
    assert [len(s["tests"]) for s in c["split"]["sets"]] == [4, 3]           # low E first
    assert "do not look like one material" in c["words"] and "standing out: b1, b2, b3" in c["words"]
    assert "Label each test's material" in c["words"]
    labelled = het.one_material(names, means, [25.0] * 7, labelled=True)
    assert "Label each" not in labelled["words"] and "Check these tests" in labelled["words"]


def test_one_material_with_a_real_spread_passes():
    """Six specimens of one sheet (the shipped example's true E, sd 25 MPa each): they differ far
    beyond their own uncertainty (I² ~ 0.96), by 4 % of E, and form no separate sets."""
    c = het.one_material(list("abcdef"), [2953, 3014, 2965, 2753, 2711, 2857], [25.0] * 6)
    assert c["p_value"] < 1e-6 and c["I2"] > 0.9                             # a real spread
    assert c["relative_spread"] < het.RELATIVE_SPREAD_MAX
    assert c["passed"] is True and c["stand_out"] == []
    assert "as specimens of one material do" in c["words"]


def test_tests_that_agree_pass_and_too_few_are_not_checked():
    c = het.one_material(["a", "b", "c"], [1502.0, 1495.0, 1510.0], [20.0] * 3)
    assert c["passed"] is True and c["p_value"] > 0.5
    assert "agree within their own uncertainty" in c["words"]
    two = het.one_material(["a", "b"], [1500.0, 2500.0], [20.0] * 2)
    assert two["passed"] is None and "too few" in two["words"]


def test_the_split_test_is_calibrated_on_one_normal_population():
    """One normal population of 8 specimens (sd 4 % of E): the split test fires in about P_SPLIT
    of the populations, not more."""
    rng = np.random.default_rng(11)
    fired = 0
    for _ in range(200):
        sds = rng.uniform(20, 50, 8)
        means = rng.normal(rng.normal(2500, 100, 8), sds)
        fired += het.one_material([str(i) for i in range(8)], means, sds, seed=int(rng.integers(1e6))
                                  )["passed"] is False
    assert fired <= 8          # P(X > 8) < 0.001 for Binomial(200, 0.01)


def test_between_groups():
    differ = het.between_groups({"A": (1500.0, 20.0), "B": (2500.0, 25.0)})
    assert differ["passed"] is False and "no E spans them" in differ["words"]
    assert "1 degree of freedom" in differ["words"]
    same = het.between_groups({"A": (1500.0, 20.0), "B": (1510.0, 25.0)})
    assert same["passed"] is True and "could be one material" in same["words"]
    assert het.between_groups({"A": (1.0, 1.0)})["passed"] is None
