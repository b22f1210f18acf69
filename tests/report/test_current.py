"""report skips a current report (newer than its config, data and results); --force rebuilds it
(the re-run of `make demo` rebuilt an unchanged report)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from support.finished_run import make_finished_run

import bayes_dnlr.report as report
from bayes_dnlr.cli import main
from bayes_dnlr.report.current import stale_inputs


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    return make_finished_run(tmp_path_factory.mktemp("runs"))


def _age(path: Path, seconds: float) -> None:
    t = path.stat().st_mtime - seconds
    os.utime(path, (t, t))


def test_current_report_is_skipped_stale_or_forced_is_rebuilt(finished, monkeypatch, capsys):
    built = []

    def fake(run_dir, **_):          # the CLI also passes the user's config and a warning callback
        built.append(run_dir)
        (Path(run_dir) / "report.html").write_text("<html></html>")
        return Path(run_dir) / "report.html"

    monkeypatch.setattr(report, "build_report", fake)
    (finished / "report.html").unlink(missing_ok=True)
    assert stale_inputs(finished) is None                       # no report: build it
    assert main(["report", str(finished)]) == 0 and len(built) == 1
    for p in finished.iterdir():                                # the inputs are older than the report
        if p.name != "report.html" and p.is_file():
            _age(p, 10)
    assert stale_inputs(finished) == []
    capsys.readouterr()
    assert main(["report", str(finished)]) == 0 and len(built) == 1      # current: skipped
    assert "report.html is current" in capsys.readouterr().out
    assert main(["report", str(finished), "--force"]) == 0 and len(built) == 2
    for name in ("summary.json", "tiny.csv", "config.yaml"):    # any newer input: rebuilt
        for p in finished.iterdir():
            if p.name != "report.html" and p.is_file():
                _age(p, 10)
        os.utime(finished / name)
        assert stale_inputs(finished) == [finished / name]
        n = len(built)
        assert main(["report", str(finished)]) == 0 and len(built) == n + 1
