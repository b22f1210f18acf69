"""Where a quantity's information lies (inference/checks/band.py): the least-squares weights of a
combination of parameters whose columns have very different scales, a parameter no sample moves,
and the band check's numbers, in the times of the loading."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.checks.band import Band, band_check, information_weights
from bayes_dnlr.inference.checks.predictive import band_floor


def test_the_weights_of_a_combination_are_those_of_least_squares_whatever_the_columns_scales():
    rng = np.random.default_rng(5)
    X = rng.standard_normal((40, 3)) * [2000.0, 1.0, 1e-3]       # E, G, tau_max in their units
    g = np.array([1.0, -3.0, 5e4])                              # dE(t)/dβ
    h = g @ np.linalg.pinv(X)
    np.testing.assert_allclose(information_weights(X, g), h**2 / np.sum(h**2), rtol=1e-8)


def test_a_parameter_no_sample_moves_draws_its_information_from_none_in_particular():
    X = np.zeros((4, 2))
    X[:, 0] = [1.0, 2.0, 0.0, 0.0]
    # the second column is zero: no sample tells anything of it, each sample weighs 1/4
    np.testing.assert_allclose(information_weights(X, np.array([0.0, 1.0])), np.full(4, 0.25))
    # and the first parameter's weights are as if the second were not there
    np.testing.assert_allclose(information_weights(X, np.array([1.0, 0.0])), [0.2, 0.8, 0.0, 0.0])
    wide = np.zeros((4, 3))
    assert information_weights(wide, np.array([1.0, 0.0, 0.0])).tolist() == [0.25] * 4


def test_the_band_check_s_numbers_in_the_loading_s_times():
    # one parameter whose sensitivity halves at each sample: weights 3/4, 3/16, 3/64, ...
    time = 10.0 + np.arange(30.0)
    X = (0.5 ** np.arange(30.0))[:, None]
    inside = np.ones(30, bool)
    inside[1] = False
    band = Band(inside, time, time, 25.0, X, ["E"], {"E": 1000.0}, first_turn=None)
    w = 0.25 ** np.arange(30.0)
    w /= w.sum()
    n_eff = 1.0 / np.sum(w**2)
    c = band_check(band, np.array([1.0]), 3.0)
    assert c == {"share": pytest.approx(1.0 - w[1]), "n_eff": pytest.approx(n_eff),
                 "floor": pytest.approx(band_floor(n_eff)), "ok": True,
                 # the two samples that hold 90 % of the weight: 10 and 11 s on the file's clock
                 "information_times": [7.0, 8.0], "first_turn": None, "relaxation_start": 25.0,
                 "window": [10.0, 39.0]}
    inside[0] = False
    assert band_check(band, np.array([1.0]), 3.0)["ok"] is False
