"""Residual whiteness: lag-1 autocorrelation, Durbin-Watson, runs test, verdict."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.lsq.whiteness import (
    durbin_watson,
    lag1_autocorrelation,
    residual_diagnostics,
    runs_test,
)


def ar1(n: int, phi: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    w = rng.normal(size=n)
    e = np.empty(n)
    e[0] = w[0]
    for i in range(1, n):
        e[i] = phi * e[i - 1] + w[i]
    return e


def test_white_noise_is_called_white_in_most_replicates():
    calls = [residual_diagnostics(np.random.default_rng(s).normal(0, 0.3, 2000))["white"]
             for s in range(100)]
    # two tests at 1 % each: about 2 % false alarms expected
    assert sum(calls) >= 94


def test_correlated_residuals_are_not_white_and_the_verdict_says_bias():
    e = ar1(2000, 0.8, seed=1)
    d = residual_diagnostics(e)
    assert d["white"] is False
    assert d["lag1_autocorrelation"] == pytest.approx(0.8, abs=0.05)
    assert d["runs_test"]["n_runs"] < d["runs_test"]["expected"]
    assert d["runs_test"]["p_value"] < 1e-6
    assert "NOT white" in d["verdict"] and "model bias" in d["verdict"]


def test_a_smooth_systematic_misfit_is_detected_even_below_the_noise():
    rng = np.random.default_rng(2)
    x = np.linspace(0, 1, 2000)
    e = 0.3 * rng.normal(size=x.size) + 0.15 * np.sin(6 * np.pi * x)    # wavy bias, half the noise
    assert residual_diagnostics(e)["white"] is False


def test_durbin_watson_is_close_to_two_minus_two_r1():
    e = ar1(5000, 0.5, seed=3)
    assert durbin_watson(e) == pytest.approx(2 * (1 - lag1_autocorrelation(e)), abs=0.01)
    assert durbin_watson(np.random.default_rng(4).normal(size=5000)) == pytest.approx(2.0, abs=0.1)


def test_runs_test_counts_runs():
    r = runs_test(np.array([1, 1, -1, -1, -1, 1, -1, 0, -1, 1.0]))   # zeros dropped
    assert r["n_runs"] == 5          # ++ --- + -- +
    n_pos, n_neg = 4, 5
    assert r["expected"] == pytest.approx(2 * n_pos * n_neg / 9 + 1)
    alternating = runs_test(np.tile([1.0, -1.0], 500))
    assert alternating["n_runs"] == 1000 and alternating["z"] > 10
    blocks = runs_test(np.repeat([1.0, -1.0], 500))
    assert blocks["n_runs"] == 2 and blocks["z"] < -10 and blocks["p_value"] < 1e-10


def test_rms_against_a_given_sigma0_is_reported():
    e = np.random.default_rng(5).normal(0, 1.0, 1000)
    d = residual_diagnostics(e, sigma0=0.3, sigma0_source="config")
    assert d["rms"] == pytest.approx(1.0, rel=0.1)
    assert "x sigma0" in d["verdict"]
    assert "sigma0" not in residual_diagnostics(e, sigma0=1.0, sigma0_source="config")["verdict"]


def test_the_verdict_says_signed_only_when_its_statistics_do():
    """Residuals whose signs run long while r1 and Durbin-Watson are those of white noise (a small
    signed wave under rare large residuals): not white by the runs test, but not 'signed' by the
    statistics the verdict quotes (a Durbin-Watson of 1.98 was once called signed)."""
    rng = np.random.default_rng(7)
    n = 2000
    e = 0.01 * np.sign(np.sin(2 * np.pi * np.arange(n) / 200 + 0.1))
    rare = rng.random(n) < 0.1
    e[rare] = rng.normal(size=int(rare.sum()))
    d = residual_diagnostics(e)
    assert abs(d["durbin_watson"] - 2) < 0.1 and abs(d["lag1_autocorrelation"]) < 0.05
    assert d["runs_test"]["p_value"] < 1e-10 and d["white"] is False
    assert "signed" not in d["verdict"]
    assert d["verdict"].startswith("NOT white by the runs test alone: the signs form longer runs")
    assert f"Durbin-Watson ({d['durbin_watson']:.2f})" in d["verdict"]


def test_alternating_residuals_are_called_alternating():
    e = ar1(2000, -0.6, seed=8)
    d = residual_diagnostics(e)
    assert d["white"] is False and d["durbin_watson"] > 2.5
    assert "alternate in sign" in d["verdict"] and "signed" not in d["verdict"]
