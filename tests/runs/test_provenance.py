"""``report`` marks results made from another config or data than the current ones (a red box at
the top of the page and ``warning:`` lines in the console) instead of showing them as current; the
CLI's words for replacing them are its own (``--force``, ``--restart``)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from support.finished_run import make_finished_run

from bayes_dnlr.report import build_report
from bayes_dnlr.runs.results import stale_notes

STALE_BOX = 'class="box stale"'


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """The session's finished run with its report's figures: the reports here draw none of them."""
    return make_finished_run(tmp_path_factory.mktemp("prov"), figures=True)


@pytest.fixture
def run(finished, tmp_path) -> Path:
    return Path(shutil.copytree(finished, tmp_path / "tiny", ignore=shutil.ignore_patterns(
        "report.html")))



def _edit_data(run: Path) -> None:
    """One stress value of the data file changed by 0.01 MPa."""
    data = run / "tiny.csv"
    rows = data.read_text().splitlines()
    cells = rows[5].split(",")
    cells[2] = repr(float(cells[2]) + 0.01)
    rows[5] = ",".join(cells)
    data.write_text("\n".join(rows) + "\n")


def _edit_model(run: Path) -> None:
    cfg = run / "config.yaml"
    cfg.write_text(cfg.read_text() + "model: {modes: 40, decades: 6}\n")


def test_current_results_are_not_marked(run):
    assert stale_notes(run) == []
    assert STALE_BOX not in build_report(run).read_text()


def test_an_edited_config_marks_the_fit_and_the_chain(run, cli_here):
    _edit_model(run)
    r = cli_here("report", str(run))
    assert r.returncode == 0, r.stderr
    lines = [x for x in r.stderr.splitlines() if x.startswith("warning: ")]
    assert any("fit.json was made from a different config (sections model" in x for x in lines), r.stderr
    assert any("chains.h5 was sampled from another config or data" in x and "model" in x for x in lines)
    assert any(f"fit --force {run / 'config.yaml'}" in x for x in lines)
    assert any(f"sample --restart {run / 'config.yaml'}" in x for x in lines)
    page = (run / "report.html").read_text()
    assert page.count(STALE_BOX) == 1
    assert page.index(STALE_BOX) < page.index("<h2>")          # at the top, before any section
    assert "sections model" in page


def test_a_changed_data_file_is_marked(run):
    _edit_data(run)
    notes = stale_notes(run)
    assert len(notes) == 2
    assert "a different data file" in notes[0] and "the data file changed" in notes[1]


def test_a_folder_with_only_its_resolved_config(run):
    """The config as resolved for the results (its data path rewritten) is not the user's: no
    config is blamed; a changed data file still is."""
    (run / "config.yaml").unlink()
    (run / "config.resolved.yaml").rename(run / "config.yaml")
    assert stale_notes(run) == []
    assert stale_notes(run, source=run / "config.yaml") == []
    _edit_data(run)
    notes = stale_notes(run)
    assert notes and all("data file" in n for n in notes) and not any("config (" in n for n in notes)


def test_the_fit_refusal_speaks_cli(run, cli_here):
    _edit_model(run)
    r = cli_here("fit", str(run / "config.yaml"))
    assert r.returncode == 2
    assert "overwrite=True" not in r.stderr and "(restart=True)" not in r.stderr
    assert f"`python -m bayes_dnlr fit --force {run / 'config.yaml'}` replaces it" in r.stderr
