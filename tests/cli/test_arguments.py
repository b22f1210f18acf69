"""Commands take a config file or a run folder wherever that makes sense; where a form cannot work,
the one-line error says what is expected."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from support.finished_run import make_finished_run

from bayes_dnlr.cli import main


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """The session's finished run with its report's figures (no report.html): the report here
    draws none of them."""
    return make_finished_run(tmp_path_factory.mktemp("runs"), figures=True)


def test_report_takes_the_config_and_the_run_folder(finished, capsys, monkeypatch):
    import bayes_dnlr.report as report

    seen = []
    monkeypatch.setattr(report, "build_report",
                        lambda d, **kw: seen.append(Path(d)) or Path(d) / "report.html")
    assert main(["report", str(finished / "config.yaml")]) == 0
    assert main(["report", str(finished)]) == 0
    assert [p.resolve() for p in seen] == [finished.resolve()] * 2
    assert capsys.readouterr().err == ""


def test_a_folder_holding_a_config_of_another_name_is_that_run(finished, tmp_path, capsys,
                                                              monkeypatch):
    """``report X`` and ``report X/config.yaml`` agree when the config's name differs from X:
    both are the run in X/<name> (``report X`` wrote a "No posterior yet" page into X)."""
    import bayes_dnlr.report as report

    holder = tmp_path / "X"
    run = Path(shutil.copytree(finished, holder / "tiny"))
    text = (run / "config.yaml").read_text().replace("file: tiny.csv", "file: tiny/tiny.csv")
    (holder / "config.yaml").write_text(text)
    seen = []
    monkeypatch.setattr(report, "build_report",
                        lambda d, **kw: seen.append(Path(d)) or Path(d) / "report.html")
    for arg in (holder / "config.yaml", holder):
        assert main(["report", "--force", str(arg)]) == 0
    assert [p.resolve() for p in seen] == [run.resolve()] * 2
    assert not (holder / "report.html").exists() and capsys.readouterr().err == ""
    shutil.rmtree(run)
    assert main(["report", str(holder)]) == 2
    assert "writes them into" in capsys.readouterr().err


def test_report_from_a_config_writes_the_report(finished, capsys):
    assert main(["report", str(finished / "config.yaml")]) == 0
    assert (finished / "report.html").is_file()
    assert capsys.readouterr().out.strip().endswith("report.html")


def test_sample_and_fit_take_the_run_folder(finished, capsys):
    assert main(["sample", str(finished), "--quiet"]) == 0      # finished: the summary, no sampling
    out = capsys.readouterr().out
    assert "posterior mean" in out and "E " in out
    assert main(["fit", str(finished), "--quiet"]) == 0          # same config: fit.json is current


def test_compare_and_export_take_the_config(finished, capsys):
    assert main(["compare", str(finished / "config.yaml")]) == 0
    assert "E posterior (MPa)" in capsys.readouterr().out
    assert (finished.parent / "compare.md").is_file()
    assert main(["export", str(finished / "config.yaml"), "--format", "csv", "--nu", "0.45"]) == 0
    assert (finished / "export" / "csv" / "cards.csv").is_file()


def test_a_missing_name_says_what_each_command_takes(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["sample", "etfe0"]) == 2
    assert capsys.readouterr().err == ("error: etfe0: config file not found (sample takes the config "
                                       "file, e.g. etfe0/config.yaml)\n")
    assert main(["report", "etfe0.yaml"]) == 2
    assert capsys.readouterr().err == (
        "error: etfe0.yaml: no such run folder or config file; report takes a run folder or its "
        "config file, e.g. runs/hdpe-a-5e-3 or runs/hdpe-a-5e-3/config.yaml\n")


def test_a_run_folder_without_a_written_config(finished, tmp_path, capsys):
    """The run folder of a config kept elsewhere holds only the copy fit/sample wrote: sample says to
    give the config file; an empty folder says the same."""
    runs = tmp_path / "runs"
    runs.mkdir()
    shutil.copy(finished / "tiny.csv", runs / "tiny.csv")
    (runs / "mine.yaml").write_text((finished / "config.yaml").read_text())   # name: tiny -> runs/tiny/
    assert main(["fit", str(runs / "mine.yaml"), "--quiet"]) == 0
    assert (runs / "tiny" / "config.yaml").is_file()                    # the resolved copy
    capsys.readouterr()
    assert main(["sample", str(runs / "tiny")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {runs / 'tiny'}: sample takes the config file, e.g. "
                          f"{runs / 'tiny'}/config.yaml; ")
    assert "is the copy that fit/sample wrote" in err and err.count("\n") == 1
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["fit", str(empty)]) == 2
    assert capsys.readouterr().err == (f"error: {empty}: fit takes the config file, e.g. "
                                       f"{empty}/config.yaml; {empty} is a directory with no config.yaml\n")


def test_report_of_a_config_not_run_yet(tmp_path, capsys):
    cfg = tmp_path / "new" / "config.yaml"
    cfg.parent.mkdir()
    cfg.write_text("name: other\ndata: {file: x.csv, columns: {time: t, stress: s, strain: e}, "
                   "observable: stress}\n")
    assert main(["report", str(cfg)]) == 2
    err = capsys.readouterr().err
    assert err == (f"error: {cfg}: its run folder {cfg.parent / 'other'} does not exist yet: run "
                   f"`python -m bayes_dnlr sample {cfg}` first\n")
    assert not (cfg.parent / "other").exists()


def test_sample_report_writes_the_report_then_keeps_it_current(finished, tmp_path, capsys):
    """`sample --report` ends with the report `report RUN_DIR` would write, and leaves a current
    one as it is."""
    run = Path(shutil.copytree(finished, tmp_path / finished.name))
    (run / "report.html").unlink(missing_ok=True)
    assert main(["sample", str(run / "config.yaml"), "--quiet", "--report"]) == 0
    page = run / "report.html"
    assert page.is_file() and capsys.readouterr().out.strip().endswith("report.html")
    stamp = page.stat().st_mtime_ns
    assert main(["sample", str(run), "--quiet", "--report"]) == 0
    assert "is current" in capsys.readouterr().out and page.stat().st_mtime_ns == stamp


def test_a_run_folder_whose_config_is_not_text_is_a_one_line_error(tmp_path, capsys):
    (tmp_path / "config.yaml").write_bytes(b"\xff\xfe\x00not a config")
    assert main(["fit", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "config.yaml" in err and "UTF-8" in err
    assert "Traceback" not in err
