"""One page builder for any number of tests: a run with one test keeps its sections and their
numbers; a run with several adds the sections across tests and draws each test's sections under
its name, with the run's analyses (joint white and GLS) beside the run's results."""

from __future__ import annotations

import html
import json
import re

import yaml
from support.drawing import figures_not_drawn
from support.joint import RATES, make_joint
from support.runs import make_run, ramp_truth

from bayes_dnlr.config import load_config
from bayes_dnlr.numbers import fmt_at
from bayes_dnlr.report import build_report
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.workflows.simulate import simulate_tests

WHITE_ROW = "white noise, linearized (the paper&#x27;s eq. 32)"
GLS_ROW = "with the discrepancy, linearized ("          # then the analysis' own words


def _h2(page: str) -> list[str]:
    return [html.unescape(h) for h in re.findall(r"<h2>(.*?)</h2>", page)]


def _row(block: str, label: str) -> str:
    """The estimate cell of the row whose label starts with ``label`` in a table in ``block``."""
    return re.search(rf"<th[^>]*>{re.escape(label)}[^<]*</th><td>([^<]*)</td>", block).group(1)


def test_a_run_with_one_test_keeps_its_sections(tmp_path, monkeypatch):
    path = make_run(tmp_path, "one", ramp_truth(0.4, n_points=150))
    fit(load_config(path))
    figures_not_drawn(monkeypatch)      # the sections and the figures' names are read, not the figures
    page = build_report(path.parent).read_text()
    assert _h2(page) == ["1. Parameters", "3. Correlations: the linearized Δ̃ (eq. 35)",
                         "5. Fit and residuals", "6. Model error: the two analyses and the checks",
                         "7. Sensitivities (eq. 37)",
                         "8. Standards, Deborah number and independent measurements"]
    assert "<h3>one (" not in page and "fit-one.png" not in page
    assert {p.name for p in (path.parent / "figures").glob("*.png")} == {
        "fit.png", "sensitivity.png", "sensitivity_xy.png", "acf.png"}


def test_a_joint_page_sets_the_runs_analyses_beside_each_test(tmp_path, monkeypatch):
    """Three rates, one with a smooth model error: each test's model-error section shows the
    run's joint white and GLS estimates of E, never the test's own single fit."""
    path = make_joint(tmp_path, "bias", discrepancy=True)
    raw = yaml.safe_load(path.read_text())
    for t in raw["tests"]:
        t["noise"] = {"sigma0": "residuals"}
    raw["tests"][1]["truth"]["noise"]["correlated"] = {"kernel": "matern32", "amplitude": 0.5,
                                                       "length": 20.0}
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    cfg = load_config(path)
    simulate_tests(cfg, overwrite=True)
    fit(cfg)
    result = json.loads((path.parent / "fit.json").read_text())
    figures_not_drawn(monkeypatch)      # the sections and the figures' names are read, not the figures
    page = build_report(path.parent).read_text()
    assert _h2(page) == ["1. Parameters", "3. Correlations: the linearized Δ̃ (eq. 35)",
                         "4. Tables 3 and 5 of the paper, from the run's posterior",
                         "5. Is E rate-independent?", "7. Fit and residuals of every test",
                         "8. Model error of every test: the two analyses and the checks",
                         "9. Sensitivities (eq. 37)",
                         "10. Standards, Deborah number and independent measurements"]
    white = fmt_at(result["estimate"]["E"], result["sd"]["E"])
    gls = result.get("discrepancy")
    sections = page.split("<h3>Model error: ")[1:]
    assert len(sections) == len(RATES)
    for t, block in zip(RATES, sections, strict=True):
        block = block.split("<h2>")[0]
        assert block.startswith(f"{t} (")
        assert _row(block, WHITE_ROW) == white
        if gls is not None:
            assert _row(block, GLS_ROW) == fmt_at(gls["estimate"]["E"], gls["sd"]["E"])
        table = block.split("E: the two analyses")[1].split("</table>")[0]
        own = fmt_at(result["single_fits"][t]["estimate"]["E"], result["single_fits"][t]["sd"]["E"])
        assert own == white or f">{own}<" not in table
    for t in RATES:
        assert (path.parent / "figures" / f"acf-{t}.png").is_file()
        for w in result["single_fits"][t]["warnings"]:
            assert html.escape(f"{t}: {w}") in page


def test_the_header_names_a_far_data_file_by_its_absolute_path(tmp_path):
    """The run's config names its data relative to the run folder; one beside it reads so, one far
    away by its absolute path, not '../../../..' up to the root."""
    from types import SimpleNamespace

    from bayes_dnlr.report.html import _data_file

    def cfg(name, base):
        return SimpleNamespace(data=SimpleNamespace(file=name), data_path=base / name)

    run = tmp_path / "a" / "b" / "run"
    assert _data_file(cfg("data.csv", run)) == "data.csv"
    assert _data_file(cfg("../data.csv", run)) == "../data.csv"
    assert _data_file(cfg("../../../x/data.csv", run)) == str((tmp_path / "x" / "data.csv").resolve())
    assert _data_file(cfg("/abs/data.csv", run)) == "/abs/data.csv"
