"""The report's tables say which analysis each column belongs to: beside the generalized least
squares (the posterior used the model discrepancy), Err (eq. 33) is the GLS one and says so."""

from __future__ import annotations

from support.runs import make_run, ramp_truth

from bayes_dnlr.config import load_config
from bayes_dnlr.numbers import pct
from bayes_dnlr.report.tables import parameter_table
from bayes_dnlr.runs.results import RunResults

NAMES = ["E", "G", "tau_max"]


def _run(tmp_path, noise_model: str) -> RunResults:
    cfg = load_config(make_run(tmp_path, "gls", ramp_truth(0.4, n_points=100)))
    white = {"E": 2900.0, "G": 2.3, "tau_max": 5.8}
    fit = {"parameters": NAMES, "estimate": white, "sd": {"E": 145.0, "G": 0.01, "tau_max": 0.1},
           "err": {"E": 0.05, "G": 0.01 / 2.3, "tau_max": 0.1 / 5.8},
           "discrepancy": {"estimate": {"E": 2800.0, "G": 2.2, "tau_max": 5.5},
                           "sd": {"E": 56.0, "G": 0.02, "tau_max": 0.2},
                           "err": {"E": 0.02, "G": 0.02 / 2.2, "tau_max": 0.2 / 5.5}}}
    post = {k: {"mean": v, "sd": 1.0, "median": v, "hdi_90": [v - 1, v + 1], "ess_bulk": 1000,
                "ess_tail": 1000, "r_hat": 1.0} for k, v in white.items()}
    summary = {"parameters": NAMES, "posterior": post, "noise": {"model": noise_model}}
    return RunResults(run_dir=tmp_path / "gls", cfg=cfg, fit=fit, summary=summary)


def _column(table, header: str) -> dict[str, str]:
    j = table.header.index(header)
    return {row[0]: row[j] for row in table.rows}


def test_err_beside_the_gls_columns_is_the_gls_one(tmp_path):
    t = parameter_table(_run(tmp_path, "discrepancy"))
    assert "least squares (GLS)" in t.header
    assert "Err (eq. 33, GLS)" in t.header and "Err (eq. 33)" not in t.header
    assert _column(t, "Err (eq. 33, GLS)")["E"] == pct(0.02)         # 56 / 2800, not the white 5 %
    assert _column(t, "least squares (GLS)")["E"] == "2800"


def test_err_beside_the_white_columns_stays_the_papers(tmp_path):
    t = parameter_table(_run(tmp_path, "white"))
    assert "Gauss-Newton" in t.header and "Err (eq. 33)" in t.header
    assert _column(t, "Err (eq. 33)")["E"] == pct(0.05)
