"""The report's model-error section: the two analyses of E and the checks, under white noise and
under the model discrepancy, with the residual autocorrelation and δ's posterior mean."""

from __future__ import annotations

import json

import pytest
from support.drawing import figures_not_drawn
from support.sampling import write_case

from bayes_dnlr.config import load_config
from bayes_dnlr.report import build_report
from bayes_dnlr.runs.sample import sample

SAMPLER = {"walkers": 16, "max_steps": 1500, "target_ess": 150, "checkpoint_every": 50}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """One synthetic test with a correlated model error, sampled with the default discrepancy and
    with the white likelihood."""
    folder = tmp_path_factory.mktemp("noise")
    out = {}
    for name, disc in (("disc", "default"), ("white", "none")):
        path = write_case(folder, name, n=400, seed=3, error=("exp", 1.0, 40.0), noise="residuals",
                          discrepancy=disc, sampler=SAMPLER)
        sample(load_config(path), progress=False)
        out[name] = path.parent
    return out


def test_discrepancy_run_reports_both_intervals_and_the_verdict(runs, monkeypatch) -> None:
    run = runs["disc"]
    summary = json.loads((run / "summary.json").read_text())
    noise = summary["noise"]
    assert noise["model"] == "discrepancy" and noise["evidence_of_model_error"]
    assert {"disc_amplitude", "disc_length"} <= set(summary["parameters"])
    # the text is read; of the figures, those of the test's sections (δ on the residuals, the ACF
    # of the residuals whitened by it) are drawn, not the corner, trace and rank plots
    figures_not_drawn(monkeypatch, keep=("fit_plot", "acf_plot", "sensitivity_plot", "sensitivity_xy_plot"))
    page = build_report(run).read_text()
    assert "6. Model error: the two analyses and the checks" in page
    for row in ("white noise, linearized (the paper", "with the discrepancy, linearized (GLS",
                "posterior, with the discrepancy"):
        assert row in page, row
    assert "±6.5 %" in page                                   # the paper's by-hand figure as context
    assert noise["verdict"][:60] in page
    assert "The model discrepancy δ" in page and "likelihood ratio" in page.lower()
    assert (run / "figures" / "acf.png").is_file()
    assert "posterior mean of the model discrepancy δ" in page
    assert "model + discrepancy δ + noise σ0" in page
    # the residuals are not white: never the green "agrees" box
    assert 'class="box ok">The posterior agrees' not in page
    assert "least squares (GLS)" in page
    # the posterior's correlations beside the Δ̃ it is compared with (GLS), then the paper's
    fit = json.loads((run / "fit.json").read_text())
    gls_err = fit["discrepancy"]["delta_tilde"][0][0]
    assert "Linearized Δ̃ (eq. 35) of the estimate under model error (GLS" in page
    assert page.index("of the estimate under model error (GLS") < page.index("Δ̃ (eq. 35, white noise)")
    assert f">{100 * gls_err:.2f} %<" in page


def test_white_run_on_correlated_data_says_its_interval_is_too_narrow(runs, monkeypatch) -> None:
    run = runs["white"]
    summary = json.loads((run / "summary.json").read_text())
    assert summary["noise"]["model"] == "white"
    assert summary["noise"]["fit_residuals_white"] is False
    assert any("too narrow" in w for w in summary["warnings"])
    figures_not_drawn(monkeypatch)          # the page's text is read, not its figures
    page = build_report(run).read_text()
    assert "too narrow" in page
    assert 'class="box ok">The posterior agrees' not in page
    assert "posterior, white likelihood" in page
    assert "Linearized Δ̃ (eq. 35): Err in % on the diagonal" in page     # the white one alone
    assert "Δ̃ (eq. 35, white noise)" not in page


def test_discrepancy_interval_is_wider_and_recovers_the_truth(runs) -> None:
    """The same data: the white posterior of E is narrower than the discrepancy one (it treats the
    correlated error as independent noise); the discrepancy posterior is within 3 sd of the truth
    (coverage over many replicates is benchmarks/calibration.py's job)."""
    s_disc = json.loads((runs["disc"] / "summary.json").read_text())["posterior"]["E"]
    s_white = json.loads((runs["white"] / "summary.json").read_text())["posterior"]["E"]
    assert s_disc["sd"] > 1.5 * s_white["sd"]
    assert abs(s_disc["mean"] - 2854.0) <= 3 * s_disc["sd"]
