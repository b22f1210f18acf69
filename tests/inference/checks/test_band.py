"""The band check of one quantity (inference/checks/band.py): the samples that carry its
information, and the floor a calibrated band holds there."""

from __future__ import annotations

import math

import numpy as np

from bayes_dnlr.inference.checks.band import Band, band_check, information_weights
from bayes_dnlr.inference.checks.predictive import band_floor, weights


def test_information_weights_of_one_parameter_are_its_share_and_sum_to_one():
    X = np.random.default_rng(2).standard_normal((50, 3)) * [1000.0, 1.0, 0.01]
    w = information_weights(X, np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(w, weights(X, 1), rtol=1e-10)
    assert math.isclose(w.sum(), 1.0)
    # a combination that only one sample informs puts all its weight there
    Y = np.eye(3)
    np.testing.assert_allclose(information_weights(Y, np.array([0.0, 0.0, 1.0])), [0, 0, 1], atol=1e-12)


def test_a_band_that_misses_where_the_information_lies_fails_and_elsewhere_does_not():
    t = np.arange(100.0)
    X = np.zeros((100, 2))
    X[:20, 0] = 1.0                     # the first parameter is measured on the first 20 samples
    X[20:, 1] = 1.0
    inside = np.ones(100, bool)
    inside[50:] = False                 # the band misses the second half only
    band = Band(inside, t, t, None, X, ["E", "G"], {}, first_turn=42.0)
    first = band_check(band, np.array([1.0, 0.0]), 0.0)
    lo, hi = first["information_times"]
    assert first["ok"] and first["share"] == 1.0 and 0.0 <= lo < hi <= 19.0
    assert first["floor"] == band_floor(20.0) and first["first_turn"] == 42.0
    second = band_check(band, np.array([0.0, 1.0]), 0.0)
    assert not second["ok"] and math.isclose(second["share"], 30 / 80)
    assert band_check(band, np.zeros(2), 0.0) is None
    assert band_check(Band(inside, t, t, None, None, [], {}), np.array([1.0, 0.0]), 0.0) is None
