"""Every multi-file output published whole (bayes_dnlr/fileset.py): `export --draws` killed at any
instant leaves the old card set or the new one (it left 332 cards, no cards.csv and a temporary),
a killed `batch` with reports leaves each set (the batch's table/page/figures/population, each
test's report.html and figures/) old or whole new, and the next run leaves nothing temporary.

A few instants here; benchmarks/kill_sets.py kills each at 20 instants (docs/export.md, docs/batch.md)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from support.finished_run import make_finished_run
from support.kill import batch_kills, campaign, export_kills, leftovers

from bayes_dnlr.fileset import folder_set, publishing, recover, recover_folder


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    return make_finished_run(tmp_path_factory.mktemp("runs"))


def test_killed_export_leaves_the_old_cards_or_the_new(finished_run: Path, tmp_path: Path,
                                                      zygote) -> None:
    # the timed and the killed exports are forked from the session's zygote (support/crash.py):
    # a fresh interpreter cost each 3-4 s of CPU in imports, and its instants fell in them
    tally = export_kills(finished_run, tmp_path, draws=100, instants=2,
                         points=("fileset.folder.exchanged",), zygote=zygote)
    assert tally.kills == 3 and not tally.mixed, tally.mixed
    assert tally.old >= 1 and tally.new >= 1                  # both outcomes seen
    assert tally.left_after_next_run == []


@pytest.mark.slow
def test_killed_export_at_20_instants(finished_run: Path, tmp_path: Path) -> None:
    # fewer draws than the run holds, whatever its chain's length: two seeds draw other cards
    held = json.loads((finished_run / "summary.json").read_text())["draws"]
    tally = export_kills(finished_run, tmp_path, draws=min(2000, held // 2), instants=20)
    assert tally.kills == 20 and not tally.mixed and tally.left_after_next_run == []




def test_killed_batch_leaves_every_set_old_or_new(tmp_path: Path, zygote) -> None:
    # the first and the killed batches are forked from the session's zygote, as the exports above
    folder, args, seconds = campaign(tmp_path / "campaign", 1, zygote)
    (tmp_path / "work").mkdir()
    tally = batch_kills(folder, args, tmp_path / "work", instants=1, points=("fileset.written",),
                        duration=seconds, zygote=zygote)
    assert tally.kills == 2 and not tally.mixed, tally.mixed
    assert tally.left_after_next_run == []


@pytest.mark.slow
def test_killed_batch_at_20_instants(tmp_path: Path) -> None:
    folder, args, _ = campaign(tmp_path / "campaign", 3)
    tally = batch_kills(folder, args, tmp_path / "work", instants=20)
    assert tally.kills == 20 and not tally.mixed and tally.left_after_next_run == []


# ---------------------------------------------------------------- the mechanisms themselves

def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_a_folder_parked_by_a_killed_writer_comes_back(tmp_path: Path) -> None:
    """Where the system cannot swap two folders, the old one is parked for an instant; a kill
    there leaves it parked, and the next writer or reader puts it back."""
    target = tmp_path / "cards"
    parked = tmp_path / f".cards.{_dead_pid()}.old"
    parked.mkdir()
    (parked / "a.inp").write_text("old")
    recover_folder(target)
    assert (target / "a.inp").read_text() == "old" and not parked.exists()


def test_folder_set_replaces_the_old_folder_whole(tmp_path: Path) -> None:
    target = tmp_path / "cards"
    target.mkdir()
    (target / "old.inp").write_text("old")
    with folder_set(target) as tmp:
        (tmp / "new.inp").write_text("new")
        assert (target / "old.inp").exists()                 # nothing visible before the end
    assert sorted(p.name for p in target.iterdir()) == ["new.inp"]
    with pytest.raises(RuntimeError), folder_set(target) as tmp:
        (tmp / "newer.inp").write_text("x")
        raise RuntimeError("failed halfway")
    assert sorted(p.name for p in target.iterdir()) == ["new.inp"]
    assert leftovers(tmp_path) == []


def test_an_error_while_publishing_puts_the_old_set_back(tmp_path: Path) -> None:
    (tmp_path / "figures").mkdir()
    (tmp_path / "report.html").write_text("old page")
    (tmp_path / "figures" / "a.png").write_text("old a")
    patterns = ["report.html", "figures/*.png"]
    with pytest.raises(KeyboardInterrupt), publishing(tmp_path, "report", patterns):
        (tmp_path / "figures" / "a.png").unlink()
        (tmp_path / "figures" / "b.png").write_text("new b")
        raise KeyboardInterrupt
    assert (tmp_path / "report.html").read_text() == "old page"
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == ["a.png"]
    assert leftovers(tmp_path) == []


def test_a_killed_publisher_is_rolled_back_by_the_next(tmp_path: Path) -> None:
    """A journal and kept links of a dead writer: the old set returns, the files it added go."""
    pid = _dead_pid()
    (tmp_path / "figures").mkdir()
    kept = tmp_path / f".report.{pid}.before"
    (kept / "figures").mkdir(parents=True)
    (kept / "report.html").write_text("old page")
    (kept / "figures" / "a.png").write_text("old a")
    (tmp_path / "report.html").write_text("new page")
    (tmp_path / "figures" / "b.png").write_text("new b")
    (tmp_path / f".report.{pid}.publishing").write_text(json.dumps(
        {"kept": kept.name, "files": ["figures/a.png", "report.html"],
         "patterns": ["report.html", "figures/*.png"]}))
    (tmp_path / "figures" / f".b.png.{pid}.tmp").write_text("half")
    recover(tmp_path, "report", ["report.html", "figures/*.png"])
    assert (tmp_path / "report.html").read_text() == "old page"
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == ["a.png"]
    assert leftovers(tmp_path) == []
