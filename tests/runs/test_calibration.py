"""Calibration at reduced size (benchmarks/calibration.py runs the full 100+ replicates).

40 noisy replicates of the synthetic ramp test through the whole sample pipeline. For a calibrated
90 % interval the number of covering replicates is Binomial(40, 0.9): P(coverage < 0.75) = 0.002,
so the band is 0.75-1.0; the z = (mean - truth) / sd of a calibrated posterior have sd 1, whose
estimate from 40 replicates has sd about 0.11: the band 0.7-1.35 is 3 of those.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from support.sampling import TRUTH, calibration, coverage


@pytest.mark.slow
def test_credible_intervals_cover_the_truth(tmp_path: Path) -> None:
    results = calibration(40, tmp_path, jobs=2, base_seed=20_000)
    cov = coverage(results, TRUTH)
    for k, c in cov.items():
        print(f"{k:<8} coverage {c['coverage']:.3f}  z mean {c['z_mean']:+.3f}  z sd {c['z_sd']:.3f}")
    assert all(r["_run"]["converged"] for r in results)
    for k, c in cov.items():
        assert 0.75 <= c["coverage"] <= 1.0, k
        assert 0.7 <= c["z_sd"] <= 1.35, k
        assert abs(c["z_mean"]) <= 3 * 1.35 / 40 ** 0.5, k


@pytest.mark.slow
def test_discrepancy_intervals_cover_the_truth_under_model_error(tmp_path: Path) -> None:
    """The calibration under model error at reduced size: a smooth correlated error
    (Ornstein-Uhlenbeck, 0.5 MPa, 20 s) plus white noise 0.3 MPa on 30 replicates of 1000 points.
    The default likelihood (discrepancy) holds the truth in a calibrated share: Binomial(30, 0.9)
    falls below 22/30 with probability 0.008. The white likelihood, on the same data, must not
    (benchmarks/calibration.py: 0.34 over 50)."""
    error = ("exp", 0.5, 20.0)
    kwargs = dict(jobs=2, base_seed=31_000, noise="residuals", error=error, n=1000)
    default = calibration(30, tmp_path / "default", discrepancy="default", **kwargs)
    white = calibration(30, tmp_path / "white", discrepancy="none", **kwargs)
    cov_default, cov_white = coverage(default, TRUTH), coverage(white, TRUTH)
    for k in cov_default:
        print(f"{k:<8} default {cov_default[k]['coverage']:.3f} (z sd {cov_default[k]['z_sd']:.2f})"
              f"   white {cov_white[k]['coverage']:.3f} (z sd {cov_white[k]['z_sd']:.2f})")
    assert all(r["_run"]["converged"] for r in default)
    for k in ("E", "G", "tau_max"):
        assert cov_default[k]["coverage"] >= 22 / 30, k
        assert 0.6 <= cov_default[k]["z_sd"] <= 1.5, k
        assert cov_white[k]["coverage"] <= 0.6, k


@pytest.mark.slow
def test_a_smooth_error_is_weighed_to_matern32_and_keeps_e_and_tau_max_calibrated(tmp_path: Path) -> None:
    """A smooth Matérn-3/2 error (1 MPa, 50 s) plus white noise 0.3 MPa, 30 replicates of 1000
    points. The kernels are weighed to matern32; the estimate (generalized least squares under the
    exp covariance) keeps E and tau_max calibrated (Binomial(30, 0.9) falls below 20/30 with
    probability 0.0003), and the matern32 sandwich widens G's interval beyond the exp model's in the
    typical replicate (median factor > 1). G stays optimistic under this error
    (benchmarks/calibration.py, 50 replicates: 0.68, sd of z 1.44; these seeds: 0.83, 1.25;
    docs/model-error.md, 'Limits'), which is asserted only as a floor."""
    results = calibration(30, tmp_path, jobs=2, base_seed=32_000, noise="residuals",
                          error=("matern32", 1.0, 50.0), discrepancy="default", n=1000)
    cov = coverage(results, TRUTH)
    weights = [r["_run"]["weights"]["matern32"] for r in results]
    widened = [r["_run"]["sd_factor"]["G"] for r in results]
    print({k: (round(c["coverage"], 3), round(c["z_sd"], 2)) for k, c in cov.items()},
          "matern32 weight > 0.5 in", sum(w > 0.5 for w in weights), "G widened in",
          sum(f > 1 for f in widened))
    assert all(r["_run"]["converged"] for r in results)
    assert sum(w > 0.5 for w in weights) >= 27
    assert sorted(widened)[len(widened) // 2] > 1.0
    for k in ("E", "tau_max"):
        assert cov[k]["coverage"] >= 20 / 30, k
        assert 0.6 <= cov[k]["z_sd"] <= 1.45, k
    assert cov["G"]["coverage"] >= 0.5
