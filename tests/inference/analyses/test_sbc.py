"""SBC helpers (ranks, PIT, simultaneous ECDF bands), the synthetic correlated error that the
discrepancy SBC adds to its data, and the shifted model's SBC (benchmarks/sbc.py --shift)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from bayes_dnlr.config import load_config
from bayes_dnlr.inference.analyses.sbc import (
    ecdf,
    inside_band,
    pit_from_ranks,
    rank_of,
    simultaneous_band,
    thin_draws,
)
from bayes_dnlr.inference.discrepancy.gp import covariance
from bayes_dnlr.workflows.simulate import correlated_error, simulate_test


def test_rank_thin_and_pit():
    assert rank_of(0.5, np.array([0.1, 0.7, 0.4, 0.9])) == (2, 4)
    draws = np.arange(20).reshape(10, 2)            # (steps, walkers)
    np.testing.assert_array_equal(thin_draws(draws, 2.3), [0, 1, 6, 7, 12, 13, 18, 19])
    u = pit_from_ranks(np.array([0, 4]), np.array([4, 4]), np.random.default_rng(0))
    assert 0 <= u[0] < 0.2 and 0.8 <= u[1] < 1.0


def test_band_matches_arviz_and_holds_95_percent_of_uniform_ecdfs():
    n = 100
    z, lo, hi, gamma = simultaneous_band(n, 0.95, sims=2000, rng=np.random.default_rng(1))
    assert 0 < gamma < 0.05 and np.all(lo <= z) and np.all(hi >= z)
    ecdf_utils = pytest.importorskip("arviz_stats.ecdf_utils")
    _, _, alo, ahi = ecdf_utils.ecdf_pit(np.linspace(0, 1, n), 0.95, 1000, rng=np.random.default_rng(2))
    assert np.abs(alo[1:-1] - lo).max() <= 1.0 / n + 1e-12        # the same band, up to one count
    assert np.abs(ahi[1:-1] - hi).max() <= 1.0 / n + 1e-12
    rng = np.random.default_rng(3)
    inside = np.mean([inside_band(rng.uniform(size=n), z, lo, hi) for _ in range(1000)])
    assert 0.93 <= inside <= 0.97                                    # simultaneous 95 %
    skewed = np.mean([inside_band(rng.beta(1.3, 1.0, size=n), z, lo, hi) for _ in range(200)])
    assert skewed < 0.6                                              # it has power


def test_ranks_of_an_exact_posterior_are_uniform_and_of_a_too_narrow_one_are_not():
    """Conjugate normal: θ ~ N(0,1), y ~ N(θ, 1) (10 obs) -> posterior N(Σy/11, 1/11)."""
    rng = np.random.default_rng(4)
    n_sims, L = 300, 99
    ranks, narrow = [], []
    for _ in range(n_sims):
        theta = rng.normal()
        y = rng.normal(theta, 1.0, 10)
        mean, sd = y.sum() / 11, 1 / np.sqrt(11)
        ranks.append(rank_of(theta, rng.normal(mean, sd, L))[0])
        narrow.append(rank_of(theta, rng.normal(mean, 0.5 * sd, L))[0])
    z, lo, hi, _ = simultaneous_band(n_sims, 0.95, rng=np.random.default_rng(5))
    u = pit_from_ranks(np.array(ranks), np.full(n_sims, L), rng)
    assert inside_band(u, z, lo, hi)
    u_narrow = pit_from_ranks(np.array(narrow), np.full(n_sims, L), rng)
    assert not inside_band(u_narrow, z, lo, hi)
    assert ecdf(u_narrow, np.array([0.05]))[0] > 0.15               # too many extreme ranks


@pytest.mark.parametrize("kernel", ["exp", "matern32"])
def test_correlated_error_has_the_kernel_covariance(kernel):
    rng = np.random.default_rng(6)
    t = np.sort(rng.uniform(0.0, 60.0, 20))                          # a non-uniform grid
    draws = correlated_error(t, kernel, 0.7, 8.0, rng, size=40000)
    se = 0.7**2 * np.sqrt(2.0 / 40000)
    assert np.abs(np.cov(draws.T) - covariance(t, 0.7, 8.0, kernel)).max() < 5 * se
    fine = correlated_error(np.linspace(0, 1, 2001), kernel, 1.0, 100.0, rng)   # steps << length
    assert np.all(np.isfinite(fine)) and np.abs(np.diff(fine)).max() < 0.2


def test_simulate_adds_the_correlated_error_after_the_other_draws(tmp_path):
    raw = {"name": "c", "data": {"file": "c.csv", "columns": {"time": "t", "eps11": "e", "stress": "s"},
                                 "observable": "stress"},
           "truth": {"params": {"E": 2854.0, "G": 2.32, "tau_max": 5.79}, "strain_rate": 5e-3,
                     "strain_max": 1.0, "n_points": 400, "noise": {"strain_sd": 0, "stress_sd": 0.3},
                     "seed": 3}}
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(raw))
    white = simulate_test(load_config(path))
    y_white = np.loadtxt(white.path, delimiter=",", skiprows=1)[:, 2]
    raw["data"]["file"] = "c2.csv"
    raw["truth"]["noise"]["correlated"] = {"kernel": "exp", "amplitude": 1.0, "length": 20.0}
    path.write_text(yaml.safe_dump(raw))
    corr = simulate_test(load_config(path))
    y_corr = np.loadtxt(corr.path, delimiter=",", skiprows=1)[:, 2]
    delta = y_corr - y_white                      # the white noise is the same draw: only δ differs
    dt = float(np.median(np.diff(white.time)))
    assert 0.4 < delta.std() < 2.0
    lag1 = np.corrcoef(delta[:-1], delta[1:])[0, 1]
    assert lag1 > np.exp(-dt / 20.0) - 0.05       # smooth: OU lag-1 correlation e^{-Δt/ℓ} ≈ 0.95
    resid = y_white - white.stress
    assert abs(np.corrcoef(resid[:-1], resid[1:])[0, 1]) < 0.15     # the white part stays white


def _sbc_args(**kw) -> argparse.Namespace:
    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
    base = {"sims": 3, "jobs": 1, "scheduler": None, "points": None, "target_ess": 400.0,
            "likelihood": "white", "seed": 2018, "moves": "de", "alpha": False, "shift": True}
    return argparse.Namespace(**(base | kw))


def test_the_shifted_sbc_writes_one_run_of_three_temperatures_per_draw(tmp_path):
    """--shift: each simulation is a config of its own (a manifest cannot address tests:), three
    ramps at the benchmark's temperatures from the drawn truth, Ea and sigma_s in the prior, G left
    to its prior where the windows hardly see it."""
    args = _sbc_args()
    from sbc import SHIFT_PRIOR, SHIFT_TEMPERATURES, write_inputs

    _, configs, truths = write_inputs(args, tmp_path)
    assert len(configs) == 3 and set(truths) == {"sim0000", "sim0001", "sim0002"}
    cfg = load_config(configs[1])
    truth = truths["sim0001"]
    assert set(truth) == {"E", "G", "tau_max", "Ea", "sigma_s"}
    assert SHIFT_PRIOR["Ea"]["low"] <= truth["Ea"] <= SHIFT_PRIOR["Ea"]["high"]
    assert cfg.parameter_names == ["E", "G", "tau_max", "Ea", "sigma_s"] and not cfg.fit.hold_unidentified
    views = cfg.test_configs()
    assert [v.data.temperature for v in views] == list(SHIFT_TEMPERATURES)
    assert len({v.truth.seed for v in views}) == 3
    for v in views:
        assert v.truth.params == pytest.approx(truth) and v.truth.temperature == v.data.temperature


@pytest.mark.slow
def test_the_shifted_model_s_sbc_ranks_are_uniform(tmp_path, monkeypatch):
    """20 simulations of the shifted SBC end to end (the benchmark runs 200): every run converges
    and every rank ECDF, Ea's and sigma_s's among them, stays inside its 95 % band."""
    _sbc_args()
    import sbc

    monkeypatch.setattr(sys, "argv", ["sbc.py", "--shift", "--sims", "20", "--jobs", "2",
                                      "--out", str(tmp_path)])
    with pytest.raises(SystemExit) as end:
        sbc.main()
    assert end.value.code == 0
