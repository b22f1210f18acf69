"""A full disk in every command that writes: one line naming the file that could not be written
(`error: disk full: cannot write …`, exit 2), no temporary and no empty folder left behind, what
was there before unchanged. Simulated here (ENOSPC raised where the bytes are written); on a real
small tmpfs, filled up, under -m slow. Chains.h5 has its own tests (tests/runs/test_disk_full.py)."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from support.disk import fill, small_tmpfs
from support.finished_run import make_finished_run

from bayes_dnlr import cli
from bayes_dnlr.report import canvas, figure_cache

REPO = Path(__file__).resolve().parents[2]
ENOSPC = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def _left(folder: Path) -> list[str]:
    """Temporaries, kept sets and journals below ``folder``."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob(".*")
                  if p.name.endswith((".tmp", ".before", ".publishing", ".old")))


def _one_line(err: str, path_part: str) -> None:
    assert err.startswith("error: disk full: cannot write ") and err.count("\n") == 1, err
    assert path_part in err, err


def test_report_on_a_full_disk_names_the_figure_and_leaves_no_temporary(tmp_path, monkeypatch,
                                                                         capsys) -> None:
    run = make_finished_run(tmp_path, figures=True, page=True)
    page = (run / "report.html").read_bytes()
    monkeypatch.setattr(figure_cache, "_free_core", lambda: False)      # drawn in this process
    shutil.rmtree(run / "figures")

    def full(fig, tmp):
        Path(tmp).write_bytes(b"half a png")
        raise ENOSPC

    monkeypatch.setattr(canvas, "_save", full)
    assert cli.main(["report", str(run), "--force"]) == 2
    _one_line(capsys.readouterr().err, str(run / "figures"))
    assert _left(run) == [] and (run / "report.html").read_bytes() == page


def test_init_on_a_full_disk_leaves_no_folder(tmp_path, monkeypatch, capsys) -> None:
    run = make_finished_run(tmp_path)
    out = tmp_path / "new" / "deeper" / "config.yaml"
    monkeypatch.setattr(os, "fsync", lambda fd: (_ for _ in ()).throw(ENOSPC))
    assert cli.main(["init", str(run / "tiny.csv"), "--out", str(out)]) == 2
    _one_line(capsys.readouterr().err, str(out))
    assert not (tmp_path / "new").exists()


def test_export_on_a_full_disk_keeps_the_old_cards(tmp_path, monkeypatch, capsys) -> None:
    run = make_finished_run(tmp_path)
    assert cli.main(["export", str(run), "--format", "csv"]) == 0
    before = {p.name: p.read_bytes() for p in (run / "export" / "csv").iterdir()}
    monkeypatch.setattr(os, "fsync", lambda fd: (_ for _ in ()).throw(ENOSPC))
    capsys.readouterr()
    assert cli.main(["export", str(run), "--format", "csv", "--draws", "2", "--force"]) == 2
    _one_line(capsys.readouterr().err, str(run / "export" / "csv"))
    assert {p.name: p.read_bytes() for p in (run / "export" / "csv").iterdir()} == before
    assert _left(run) == []


def test_compare_on_a_full_disk_names_its_table(tmp_path, monkeypatch, capsys) -> None:
    run = make_finished_run(tmp_path)
    monkeypatch.setattr(os, "fsync", lambda fd: (_ for _ in ()).throw(ENOSPC))
    assert cli.main(["compare", str(run), "--out", str(tmp_path / "cmp")]) == 2
    _one_line(capsys.readouterr().err, str(tmp_path / "cmp"))
    assert not (tmp_path / "cmp").exists() or _left(tmp_path / "cmp") == []


# ---------------------------------------------------------------- slow: a real full disk

COMMANDS = {
    "init": lambda run, disk: ["init", str(run / "tiny.csv"), "--out", str(disk / "new" / "config.yaml")],
    "fit": lambda run, disk: ["fit", "--force", "--quiet", str(run / "config.yaml")],
    "sample": lambda run, disk: ["sample", "--restart", "--quiet", str(run / "config.yaml")],
    "report": lambda run, disk: ["report", "--force", str(run)],
    "export": lambda run, disk: ["export", str(run), "--format", "abaqus", "--draws", "3"],
    "compare": lambda run, disk: ["compare", str(run), "--out", str(disk / "cmp")],
}


@pytest.mark.slow
@pytest.mark.parametrize("leave", [0, 48_000], ids=["full", "almost-full"])
@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_writing_command_on_a_real_full_disk(tmp_path, command, leave) -> None:
    """The run folder on a tmpfs with ``leave`` bytes free: the command ends with exit 2 and one
    line naming a file or folder on that disk (or, when what it writes fits, exit 0), leaves no
    temporary and no folder it made, and the files it found are unchanged or replaced whole."""
    src = make_finished_run(tmp_path / "src")
    with small_tmpfs(tmp_path, "8m") as disk:
        run = Path(shutil.copytree(src, disk / "tiny"))
        before = {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()}
        fill(disk, leave)
        out = subprocess.run([sys.executable, "-m", "bayes_dnlr", *COMMANDS[command](run, disk)],
                             capture_output=True, text=True, timeout=600, cwd=REPO)
        assert "Traceback" not in out.stderr, out.stderr
        if out.returncode == 2:
            last = out.stderr.strip().splitlines()[-1]
            assert last.startswith("error: disk full") and str(disk) in last, out.stderr
        else:
            assert out.returncode == 0, out.stderr
        assert _left(disk) == []
        assert not (disk / "new").exists() and not (disk / "cmp").exists() or out.returncode == 0
        for name, data in before.items():       # unchanged, or replaced by a whole new version
            if (run / name).is_file() and (run / name).read_bytes() != data:
                assert out.returncode == 0 or name in ("fit.json", "config.resolved.yaml")
