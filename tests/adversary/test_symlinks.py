"""Symbolic links in and around a run folder: no command writes through one out of the folder the
user named (docs/cli.md, "Symbolic links"). A linked output file is replaced by the new file; a
linked output folder the package makes (figures/, export/, .cache/, a batch's figures/ and rows/)
is replaced by a real one; the link's target is never written, removed or made. The run folder
itself, and a folder given with --out, may be links: they are the user's choice and are followed."""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from support.batch import FEW, tiny_campaign
from support.chains import create_writer, make_blocks
from support.drawing import figures_not_drawn
from support.finished_run import make_finished_run

from bayes_dnlr import cli
from bayes_dnlr.diskio import keep_cache_arrays, own_dir
from bayes_dnlr.fileset import publishing
from bayes_dnlr.runs.chain_flags import release_stale_writer, write_flags
from bayes_dnlr.runs.folder import write_atomic
from bayes_dnlr.runs.lock import run_lock

REPO = Path(__file__).resolve().parents[2]


def snapshot(folder: Path) -> dict[str, tuple[str, int]]:
    """Every entry below ``folder``: its bytes' digest (or 'dir'/'link') and mtime."""
    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        kind = ("link" if p.is_symlink() else "dir" if p.is_dir()
                else hashlib.sha256(p.read_bytes()).hexdigest())
        out[str(p.relative_to(folder))] = (kind, st.st_mtime_ns)
    return out


@pytest.fixture
def outside(tmp_path) -> Path:
    """A folder elsewhere, holding a file a link may point at, and a folder."""
    d = tmp_path / "elsewhere"
    (d / "folder").mkdir(parents=True)
    (d / "folder" / "keep.png").write_bytes(b"not ours")
    (d / "file.txt").write_text("not ours either")
    return d


def _link(path: Path, target: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()
    path.symlink_to(target)


# ---------------------------------------------------------------- the writers

def test_a_linked_output_file_is_replaced_not_written_through(tmp_path, outside) -> None:
    before = snapshot(outside)
    path = tmp_path / "fit.json"
    _link(path, outside / "file.txt")
    write_atomic(path, "{}\n")
    assert not path.is_symlink() and path.read_text() == "{}\n"
    assert snapshot(outside) == before


def test_a_link_planted_at_the_temporary_is_not_followed(tmp_path, outside) -> None:
    before = snapshot(outside)
    path = tmp_path / "summary.json"
    (tmp_path / f".summary.json.{os.getpid()}.tmp").symlink_to(outside / "file.txt")
    write_atomic(path, "{}\n")
    assert path.read_text() == "{}\n" and snapshot(outside) == before


def test_a_linked_package_folder_is_replaced(tmp_path, outside) -> None:
    before = snapshot(outside)
    cache = tmp_path / ".cache"
    _link(cache, outside / "folder")
    assert keep_cache_arrays(cache / "x.npz", a=[1.0])
    assert cache.is_dir() and not cache.is_symlink() and (cache / "x.npz").is_file()
    _link(tmp_path / "figures", outside / "folder")
    assert own_dir(tmp_path / "figures").is_dir() and not (tmp_path / "figures").is_symlink()
    assert snapshot(outside) == before


def test_a_published_set_does_not_follow_a_linked_subfolder(tmp_path, outside) -> None:
    before = snapshot(outside)
    _link(tmp_path / "figures", outside / "folder")
    with publishing(tmp_path, "batch", ["batch.html", "figures/*.png"]):
        (tmp_path / "figures").mkdir(exist_ok=True)
        write_atomic(tmp_path / "figures" / "batch_E.png", b"png")
        write_atomic(tmp_path / "batch.html", "<p>")
    assert (tmp_path / "figures" / "batch_E.png").read_bytes() == b"png"
    assert snapshot(outside) == before


def test_a_linked_lock_is_replaced_and_its_target_never_made(tmp_path, outside) -> None:
    target = outside / "made-by-the-lock"
    (tmp_path / "sample.lock").symlink_to(target)
    with run_lock(tmp_path, "sample.lock", "busy"):
        assert (tmp_path / "sample.lock").is_file() and not (tmp_path / "sample.lock").is_symlink()
    assert not target.exists() and not (tmp_path / "sample.lock").exists()


def test_a_linked_chain_of_a_killed_writer_is_read_not_changed(tmp_path, outside) -> None:
    src = outside / "chains.h5"
    pid = os.fork()
    if pid == 0:                        # a writer killed after its first commit: flags left
        w = create_writer(src)
        for z, lp, acc, s in make_blocks(2, 1):
            w.append(z, lp, acc, s, elapsed=1.0, n_evals=1)
        os.kill(os.getpid(), signal.SIGKILL)
    assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == -signal.SIGKILL
    assert write_flags(src)
    data = src.read_bytes()
    (tmp_path / "chains.h5").symlink_to(src)
    assert not release_stale_writer(tmp_path / "chains.h5")
    assert src.read_bytes() == data


# ---------------------------------------------------------------- the commands

@pytest.fixture
def run(tmp_path) -> Path:
    return make_finished_run(tmp_path, figures=True)


@pytest.mark.parametrize("output", ["figures", "report.html"])
def test_report_writes_nothing_through_a_linked_output(run, outside, output, monkeypatch) -> None:
    figures_not_drawn(monkeypatch)
    _link(run / output, outside / ("folder" if output == "figures" else "file.txt"))
    before = snapshot(outside)
    assert cli.main(["report", str(run), "--force"]) == 0
    assert not (run / output).is_symlink() and (run / output).exists()
    assert snapshot(outside) == before


@pytest.mark.parametrize("output", ["export", "export/csv"])
def test_export_writes_nothing_through_a_linked_output(run, outside, output) -> None:
    (run / "export").mkdir(exist_ok=True)
    _link(run / output, outside / "folder")
    before = snapshot(outside)
    assert cli.main(["export", str(run), "--format", "csv"]) == 0
    assert (run / "export" / "csv" / "cards.csv").is_file()
    assert not (run / "export").is_symlink() and not (run / "export" / "csv").is_symlink()
    assert snapshot(outside) == before


def test_a_linked_run_folder_is_the_users_choice_and_followed(run, tmp_path, monkeypatch) -> None:
    figures_not_drawn(monkeypatch)
    alias = tmp_path / "alias"
    alias.symlink_to(run)
    assert cli.main(["export", str(alias), "--format", "csv"]) == 0
    assert (run / "export" / "csv" / "cards.csv").is_file()


# ---------------------------------------------------------------- slow: every output, every command

RUN_OUTPUTS = {   # what each command writes into a run folder: files, and folders (trailing /)
    "fit": ["fit.json", "config.resolved.yaml", ".cache/"],
    "sample": ["chains.h5", "posterior.nc", "summary.json", "fit.json", "config.resolved.yaml",
               "sample.lock", ".cache/"],
    "report": ["report.html", "figures/", ".cache/"],
    "export": ["export/", "export/abaqus/"],
}


def _command(name: str, run: Path) -> list[str]:
    return {"fit": ["fit", "--force", "--quiet", str(run / "config.yaml")],
            "sample": ["sample", "--restart", "--quiet", str(run / "config.yaml")],
            "report": ["report", "--force", str(run)],
            "export": ["export", str(run), "--format", "abaqus", "--force"]}[name]


@pytest.mark.slow
@pytest.mark.parametrize("case", [(c, o) for c, outs in RUN_OUTPUTS.items() for o in outs],
                         ids=lambda case: f"{case[0]}-{case[1]}")
def test_no_command_writes_through_any_linked_output(tmp_path, outside, case) -> None:
    """Each command in its own process, each of its outputs linked out in turn (to a copy of the
    file, or to a folder elsewhere): the command ends (0, or 2 with one line), and nothing outside
    the run folder changed."""
    command, output = case
    run = make_finished_run(tmp_path)
    if output.startswith("export/abaqus"):
        (run / "export").mkdir(exist_ok=True)
    name = output.rstrip("/")
    if output.endswith("/"):
        target = outside / "folder"
    else:
        target = outside / f"copy-{Path(name).name}"
        if (run / name).is_file():
            shutil.copy2(run / name, target)
        else:
            target = outside / "never-made"
    _link(run / name, target)
    before = snapshot(outside)
    out = subprocess.run([sys.executable, "-m", "bayes_dnlr", *_command(command, run)],
                         capture_output=True, text=True, timeout=600, cwd=REPO)
    assert out.returncode in (0, 2) and "Traceback" not in out.stderr, out.stderr
    assert snapshot(outside) == before
    if (command, name) not in NOT_REWRITTEN:       # written anew: the link is gone
        assert not (run / name).is_symlink()


# outputs a command may leave as they are (and so their link): a current fit.json that `sample
# --restart` reads, a cache whose entry is there already
NOT_REWRITTEN = {("sample", "fit.json"), ("sample", ".cache"), ("fit", ".cache"), ("report", ".cache")}


@pytest.mark.slow
@pytest.mark.parametrize("output", ["figures/", "rows/", "results.csv", "batch.html"])
def test_batch_writes_nothing_through_a_linked_output(tmp_path, outside, output) -> None:
    template, manifest = tiny_campaign(tmp_path / "c", 1, sampler=FEW)
    out = tmp_path / "c" / "batch"
    out.mkdir()
    name = output.rstrip("/")
    _link(out / name, outside / "folder" if output.endswith("/") else outside / "file.txt")
    before = snapshot(outside)
    res = subprocess.run([sys.executable, "-m", "bayes_dnlr", "batch", str(template), "--manifest",
                          str(manifest), "--out", str(out), "--jobs", "1", "--quiet",
                          "--no-report"], capture_output=True, text=True, timeout=900, cwd=REPO)
    assert res.returncode in (0, 1, 2) and "Traceback" not in res.stderr, res.stderr
    assert snapshot(outside) == before
    assert not (out / name).is_symlink()
