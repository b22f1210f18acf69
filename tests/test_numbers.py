"""One precision rule (bayes_dnlr/numbers.py): the same value reads the same in the console table,
the report's headline and tables, and compare ("2869 ± 13.77" against "2869 ± 14")."""

from __future__ import annotations

from pathlib import Path

import pytest
from support.finished_run import make_finished_run

from bayes_dnlr.numbers import fmt, fmt_at, fmt_sd, interval, pct, pm


@pytest.mark.parametrize(("x", "sd", "text"), [
    (2869.37, 13.77, "2869 ± 14"),                  # the sd to 2 digits, the value to its decimals
    (2.3194873, 0.000613, "2.31949 ± 0.00061"),     # more decimals than 4 digits when the sd asks
    (5.76213, 0.0268, "5.762 ± 0.027"),
    (28690.4, 137.7, "28690 ± 138"),                # integer digits are never rounded away
    (2869.37, None, "2869"),
    (2.55583e-19, 16.0, "0 ± 16"),                  # zero at the sd's last digit: an optimum on 0
    (-3e-9, 0.0032, "0.0000 ± 0.0032"),
    (4e-6, 1e-7, "4.000e-06 ± 1.0e-07"),            # small but resolved: as before
])
def test_the_rule(x, sd, text):
    assert pm(x, sd) == text


def test_sd_and_interval_follow_the_same_rule():
    assert fmt_sd(13.77) == "14" and fmt_sd(0.000613) == "0.00061"
    assert interval(2846.91, 2891.02, 13.77) == "[2847, 2891]"
    assert fmt(2869.37) == "2869" and fmt_at(2869.37, 13.77) == "2869"


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    return make_finished_run(tmp_path_factory.mktemp("runs"))


def test_one_value_one_string_everywhere(finished, capsys):
    from bayes_dnlr.cli import main
    from bayes_dnlr.report.compare import compare_runs
    from bayes_dnlr.report.html import _headline
    from bayes_dnlr.report.tables import parameter_table
    from bayes_dnlr.runs.results import load_run

    assert main(["sample", str(finished / "config.yaml"), "--quiet"]) == 0
    console = capsys.readouterr().out
    run = load_run(finished)
    e = run.summary["posterior"]["E"]
    text = pm(e["mean"], e["sd"])
    assert f"E = {text} MPa" in _headline(run, None)                       # report headline
    assert f" {text} " in console                                           # console summary
    assert f"| {text} |" in compare_runs([finished]).markdown()             # compare
    row = next(r for r in parameter_table(run).rows if r[0].startswith("E"))
    assert f"{row[2]} ± {row[3]}" == text                                   # report table
    hdi = interval(*e["hdi_90"], e["sd"])
    assert hdi in console and hdi in _headline(run, None) and hdi == row[5]


def test_err_percent_never_prints_thirty_digits():
    from bayes_dnlr.numbers import err_pct

    assert err_pct(0.00488) == "0.488"
    assert err_pct(3.5e22) == ">1e4"              # G on its bound: sd / |estimate| explodes
    assert pct(5.4e19) == ">1e4 %" and pct(0.0137) == "1.37 %" and pct(None) == "–"
    assert err_pct(float("nan")) == "nan" and err_pct(None) == "nan"


@pytest.mark.parametrize(("x", "text"), [(7.15e-280, "0 %"), (1.0, "100 %"), (0.99999, "100 %"),
                                         (0.2503, "25 %"), (0.0123, "1.23 %"), (0.75, "75 %")])
def test_a_kernels_weight_reads_as_a_share(x, text):
    from bayes_dnlr.numbers import share

    assert share(x) == text
