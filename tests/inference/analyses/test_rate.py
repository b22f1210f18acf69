"""The rate question in the data: a joint run with one E per test answers whether E
depends on the strain rate: "consistent" on data made with one E, "rate-dependent" on data made
with E rising 10 % per decade of rate. Both under each test's discrepancy likelihood (the default,
which falls back to white noise where a test shows no model error)."""

from __future__ import annotations

import pytest
from support.drawing import figures_not_drawn
from support.joint import make_joint


def _verdict(tmp_path, name: str, per_decade: float, *, whole_page: bool):
    """The rate analysis of a sampled joint run with one E per test, and the report's words on it:
    the whole page (``whole_page``: built by every section, its figures not drawn, which is 7-8 s
    of drawing that the report's own tests check), or only the rate section the page is built with
    (report.across_tests.rate_section)."""
    from bayes_dnlr.config import load_config
    from bayes_dnlr.report import build_report
    from bayes_dnlr.report.across_tests import rate_question, rate_section
    from bayes_dnlr.runs.results import load_run
    from bayes_dnlr.runs.sample import sample

    path = make_joint(tmp_path, name, per_test=("E", "tau_max"), e_per_decade=per_decade,
                      discrepancy=True, sampler={"max_steps": 300, "walkers": 24})
    sample(load_config(path), progress=False)
    run = load_run(path.parent)
    assert [n for n in run.names if n.startswith("E[")] == ["E[r2.5e-3]", "E[r5e-3]", "E[r1e-2]"]
    ra = rate_question(run)
    if whole_page:
        return ra, build_report(path.parent).read_text()
    return ra, "".join(rate_section(run, ra))


@pytest.mark.slow
def test_one_e_is_consistent(tmp_path, monkeypatch):
    """The size of the rate question (data made with one E are not called rate-dependent): a
    statistical check, in the slow suite; its power, below, builds the rate section by default."""
    figures_not_drawn(monkeypatch)
    ra, page = _verdict(tmp_path, "one-e", 0.0, whole_page=True)
    assert ra.verdict == "consistent", ra.words
    assert ra.log_bf01 > 0 and ra.slope["lo95"] <= 0 <= ra.slope["hi95"]
    assert "The rate question: consistent." in page and "Savage-Dickey" in page


def test_e_rising_ten_percent_per_decade_is_rate_dependent(tmp_path):
    ra, section = _verdict(tmp_path, "rising-e", 0.10, whole_page=False)
    assert ra.verdict == "rate-dependent", ra.words
    # the trend recovers the 10 % per decade within its interval
    assert ra.slope["lo95"] < 10.0 < ra.slope["hi95"], ra.slope
    assert ra.differences["r1e-2"]["mean"] > 0
    assert "The rate question: rate-dependent." in section


@pytest.mark.parametrize("per_decade", [0.0])
def test_shared_e_gives_no_rate_verdict(tmp_path, per_decade):
    """With E shared the joint posterior cannot ask the question: no verdict is invented."""
    from bayes_dnlr.config import load_config
    from bayes_dnlr.report.across_tests import rate_question
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.results import load_run

    path = make_joint(tmp_path, "shared", e_per_decade=per_decade)
    fit(load_config(path))
    run = load_run(path.parent)
    assert rate_question(run) is None


def test_rates_within_a_factor_two_are_one_rate():
    """The rate question needs rates apart: replicates at one nominal rate are refused with why."""
    import numpy as np

    from bayes_dnlr.inference.analyses.rate import MIN_RATE_RATIO, one_rate, rate_analysis

    assert one_rate({"a": 2.5e-3, "b": 5e-3, "c": 1e-2}) is None
    assert one_rate({"a": 1e-3, "b": MIN_RATE_RATIO * 1e-3}) is None
    assert "fewer than two distinct strain rates" in one_rate({"a": 5e-3, "b": 5e-3})
    assert "fewer than two distinct strain rates" in one_rate({"a": 5e-3, "b": float("nan")})
    why = one_rate({"a": 1.16e-3, "b": 1.22e-3})
    assert why.startswith("the strain rates (0.00116-0.00122 1/s) span a factor 1.05, less than 2")
    draws = {k: np.random.default_rng(1).normal(1600.0, 260.0, 400) for k in "ab"}
    with pytest.raises(ValueError, match="span a factor 1.05"):
        rate_analysis(draws, {"a": 1.16e-3, "b": 1.22e-3}, priors={})
