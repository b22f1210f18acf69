"""Do the tests agree (inference/analyses/consistency.py): Cochran's Q and the pair furthest apart."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from bayes_dnlr.inference.analyses.consistency import P_AGREE, agreement


def test_q_by_hand_and_the_worst_pair():
    values = {"a": 100.0, "b": 104.0, "c": 90.0}
    sds = {"a": 2.0, "b": 3.0, "c": 4.0}
    a = agreement("E", values, sds)
    w = np.array([1 / 4, 1 / 9, 1 / 16])
    x = np.array([100.0, 104.0, 90.0])
    pooled = np.sum(w * x) / np.sum(w)
    assert a.pooled == pytest.approx(pooled)
    assert a.q == pytest.approx(np.sum(w * (x - pooled) ** 2))
    assert a.df == 2 and a.p == pytest.approx(chi2.sf(a.q, 2))
    assert set(a.worst_pair) == {"b", "c"} and a.worst_z == pytest.approx(14 / 5)


def test_tests_of_one_material_agree_and_of_two_do_not():
    rng = np.random.default_rng(0)
    agree = sum(agreement("E", {str(i): 1000 + 10 * rng.standard_normal() for i in range(4)},
                          dict.fromkeys(map(str, range(4)), 10.0)).agree for _ in range(2000))
    assert 0.97 < agree / 2000 < 1.0                        # false alarms at about P_AGREE
    two = agreement("E", {"x": 1000.0, "y": 1060.0}, {"x": 10.0, "y": 10.0})
    assert not two.agree and two.p < P_AGREE


def test_fewer_than_two_usable_tests_give_nothing():
    assert agreement("E", {"a": 1.0, "b": float("nan")}, {"a": 1.0, "b": 1.0}) is None
    assert agreement("E", {"a": 1.0, "b": 2.0}, {"a": 1.0, "b": 0.0}) is None
