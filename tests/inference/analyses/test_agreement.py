"""The package's one test of agreement (inference/analyses/agreement.py): Cochran's Q, the pair
furthest apart, I², the DerSimonian-Laird spread and the random-effects mean, at one level."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from bayes_dnlr.inference.analyses.agreement import P_AGREE, agreement


def test_q_by_hand_and_the_worst_pair():
    values = {"a": 100.0, "b": 104.0, "c": 90.0}
    sds = {"a": 2.0, "b": 3.0, "c": 4.0}
    a = agreement("E", values, sds)
    w = np.array([1 / 4, 1 / 9, 1 / 16])
    x = np.array([100.0, 104.0, 90.0])
    pooled = np.sum(w * x) / np.sum(w)
    q = np.sum(w * (x - pooled) ** 2)
    assert a.pooled == pytest.approx(pooled) and a.pooled_sd == pytest.approx(w.sum() ** -0.5)
    assert a.q == pytest.approx(q)
    assert a.df == 2 and a.p == pytest.approx(chi2.sf(a.q, 2))
    assert set(a.worst_pair) == {"b", "c"} and a.worst_z == pytest.approx(14 / 5)
    assert a.i2 == pytest.approx((q - 2) / q)
    tau = math.sqrt((q - 2) / (w.sum() - (w @ w) / w.sum()))
    assert a.tau == pytest.approx(tau)
    wr = 1 / (1 / w + tau**2)
    assert a.re_mean == pytest.approx(np.sum(wr * x) / wr.sum())
    assert a.re_sd == pytest.approx(wr.sum() ** -0.5) and a.re_sd > a.pooled_sd
    d = a.to_dict()
    assert d["level"] == P_AGREE and d["agree"] is a.agree and d["worst_pair"] == list(a.worst_pair)


def test_within_chance_no_spread_and_the_random_effects_mean_is_the_weighted_one():
    a = agreement("E(2 s)", {"a": 500.0, "b": 501.0, "c": 499.5}, {"a": 2.0, "b": 2.0, "c": 4.0})
    assert a.agree and a.q < a.df and a.i2 == 0.0 and a.tau == 0.0
    assert a.re_mean == pytest.approx(a.pooled) and a.re_sd == pytest.approx(a.pooled_sd)
    assert a.figures().startswith("Q = 0.") and "2 degrees of freedom" in a.figures()


def test_false_alarms_at_the_level_and_two_values_apart_disagree():
    rng = np.random.default_rng(0)
    n = 4000
    sds = rng.uniform(5, 20, (n, 4))
    x = 1000 + sds * rng.standard_normal((n, 4))
    fired = sum(not agreement("E", dict(enumerate(v)), dict(enumerate(s))).agree
                for v, s in zip(x, sds, strict=True))
    assert fired / n == pytest.approx(P_AGREE, abs=4 * math.sqrt(P_AGREE / n))
    two = agreement("E", {"x": 1000.0, "y": 1060.0}, {"x": 10.0, "y": 10.0})
    assert not two.agree and two.p < P_AGREE and two.pair_text() == "x and y, 4.2 combined sd apart"


def test_fewer_than_two_usable_estimates_give_nothing():
    assert agreement("E", {"a": 1.0, "b": float("nan")}, {"a": 1.0, "b": 1.0}) is None
    assert agreement("E", {"a": 1.0, "b": 2.0}, {"a": 1.0, "b": 0.0}) is None
