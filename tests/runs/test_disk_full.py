"""A full disk gives one line (DiskFullError: `error: disk full: ...`, exit 2), never a crash or a
traceback; no temporary file stays behind; nothing committed is lost; once space is freed, `sample`
continues the very chain an uninterrupted run gives.

Simulated (ENOSPC raised inside the writers) and real (a small tmpfs, mounted when permitted).
"""

from __future__ import annotations

import errno
import hashlib
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from support.chains import create_writer, make_blocks, phys
from support.disk import fill, small_tmpfs
from support.sampling import write_case

from bayes_dnlr import cli, diskio
from bayes_dnlr.errors import DiskFullError
from bayes_dnlr.runs import chains as store
from bayes_dnlr.runs.chains import ChainWriter, read_run
from bayes_dnlr.runs.folder import write_json
from bayes_dnlr.runs.outputs import write_outputs

ENOSPC = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def _enospc_at(monkeypatch, point: str, nth: int = 1) -> None:
    """The store's write raises ENOSPC at its ``nth`` passage through kill point ``point``."""
    seen = {"n": 0}

    def fail(name: str) -> None:
        if name == point:
            seen["n"] += 1
            if seen["n"] == nth:
                raise ENOSPC

    monkeypatch.setattr(store, "kill_point", fail)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _one_line(err: Exception, path: Path) -> str:
    text = str(err)
    assert "\n" not in text and text.startswith("disk full") and str(path) in text
    return text


def _temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


# ---------------------------------------------------------------- chains.h5, simulated

def test_enospc_inside_a_commit_keeps_the_committed_chain(tmp_path: Path, monkeypatch) -> None:
    path = tmp_path / "chains.h5"
    blocks = list(make_blocks(5, 3))
    w = create_writer(path)
    for z, lp, acc, st in blocks[:2]:
        w.append(z, lp, acc, st, elapsed=1.0, n_evals=1)
    _enospc_at(monkeypatch, "append.checkpoint")
    with pytest.raises(DiskFullError) as info:
        w.append(*blocks[2], elapsed=2.0, n_evals=2)
    text = _one_line(info.value, path)
    assert "20 steps" in text and "run `sample` again" in text
    assert w.steps == 20
    w.close()                                  # the abandoned writer closes without an error
    monkeypatch.undo()
    run = read_run(path)
    assert run.steps == 20 and not run.finished
    np.testing.assert_array_equal(run.chain, phys(np.concatenate([b[0] for b in blocks[:2]])))
    # space again: continue; the chain is the uninterrupted one
    w = ChainWriter.resume(path, phys)
    w.append(*blocks[2], elapsed=2.0, n_evals=2)
    w.finish({"stop_reason": "max_steps"})
    ref = create_writer(tmp_path / "ref.h5")
    for z, lp, acc, st in blocks:
        ref.append(z, lp, acc, st, elapsed=1.0, n_evals=1)
    ref.finish({"stop_reason": "max_steps"})
    a, b = read_run(path), read_run(tmp_path / "ref.h5")
    assert a.finished and a.steps == 30
    for name in ("chain", "log_prob", "accepted", "checkpoint_steps"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert _temporaries(tmp_path) == []


def test_free_space_check_refuses_a_commit_before_writing(tmp_path: Path, monkeypatch) -> None:
    path = tmp_path / "chains.h5"
    blocks = list(make_blocks(6, 2))
    w = create_writer(path)
    w.append(*blocks[0], elapsed=1.0, n_evals=1)
    monkeypatch.setattr(diskio, "free_bytes", lambda p: 1000.0)
    with pytest.raises(DiskFullError) as info:
        w.append(*blocks[1], elapsed=2.0, n_evals=2)
    assert "0.0 MB free" in _one_line(info.value, path)
    assert read_run(path).steps == 10                 # nothing of the refused block was written
    monkeypatch.undo()
    w.append(*blocks[1], elapsed=2.0, n_evals=2)      # the same writer goes on once there is space
    w.finish({"stop_reason": "max_steps"})
    assert read_run(path).steps == 20 and read_run(path).finished


@pytest.mark.parametrize("point", ["resume.open", "resume.chain", "resume.written", "publish.swmr"])
def test_enospc_while_resuming_leaves_the_old_file_untouched(tmp_path: Path, monkeypatch,
                                                            point) -> None:
    path = tmp_path / "chains.h5"
    w = create_writer(path)
    w.append(*next(make_blocks(7, 1)), elapsed=1.0, n_evals=1)
    w.close()
    before = _sha(path)
    _enospc_at(monkeypatch, point)
    with pytest.raises(DiskFullError) as info:
        ChainWriter.resume(path, phys)
    assert "unchanged" in _one_line(info.value, path.with_name("chains.h5.tmp"))
    assert _sha(path) == before and _temporaries(tmp_path) == []
    monkeypatch.undo()
    assert ChainWriter.resume(path, phys).steps == 10


def test_enospc_while_creating_leaves_nothing(tmp_path: Path, monkeypatch) -> None:
    _enospc_at(monkeypatch, "create.checkpoint")
    with pytest.raises(DiskFullError, match="nothing was sampled yet"):
        create_writer(tmp_path / "chains.h5")
    assert list(tmp_path.iterdir()) == []


def test_enospc_while_finishing_keeps_the_run_resumable(tmp_path: Path, monkeypatch) -> None:
    path = tmp_path / "chains.h5"
    w = create_writer(path)
    w.append(*next(make_blocks(8, 1)), elapsed=1.0, n_evals=1)
    _enospc_at(monkeypatch, "finish.record")
    with pytest.raises(DiskFullError):
        w.finish({"stop_reason": "converged"})
    monkeypatch.undo()
    run = read_run(path)
    assert run.steps == 10 and not run.finished       # finishing again is a plain resume
    w = ChainWriter.resume(path, phys)
    w.finish({"stop_reason": "converged"})
    assert read_run(path).finished and read_run(path).attrs["stop_reason"] == "converged"


# ---------------------------------------------------------------- the atomic writers, simulated

def test_write_atomic_on_a_full_disk(tmp_path: Path, monkeypatch) -> None:
    target = tmp_path / "fit.json"
    write_json(target, {"a": 1})
    before = target.read_text()

    def full(fd: int) -> None:
        raise ENOSPC

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(DiskFullError) as info:
        write_json(target, {"a": 2})
    assert "unchanged" in _one_line(info.value, target)
    assert target.read_text() == before and _temporaries(tmp_path) == []


def test_write_outputs_on_a_full_disk(tmp_path: Path, monkeypatch) -> None:
    from bayes_dnlr.runs.outputs import build_datatree

    dt = build_datatree(["E"], np.ones((5, 4, 1)), np.zeros((5, 4)))
    monkeypatch.setattr(os, "fsync", lambda fd: (_ for _ in ()).throw(ENOSPC))
    with pytest.raises(DiskFullError):
        write_outputs(tmp_path, dt, {"x": 1})
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    write_outputs(tmp_path, dt, {"x": 1})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["posterior.nc", "summary.json"]


def test_temporaries_of_killed_writers_are_swept(tmp_path: Path) -> None:
    target = tmp_path / "summary.json"
    dead = tmp_path / ".summary.json.99999999.tmp"     # no such pid (pid_max <= 2**22)
    alive = tmp_path / f".summary.json.{os.getppid()}.tmp"
    other = tmp_path / ".fit.json.99999999.tmp"
    for p in (dead, alive, other):
        p.write_text("half a file")
    write_json(target, {"ok": True})
    assert not dead.exists()                         # a killed writer's: removed
    assert alive.exists() and other.exists()         # a live writer's, another file's: kept


# ---------------------------------------------------------------- `sample`, simulated

SMALL = {"walkers": 8, "max_steps": 60, "target_ess": 1.0e9, "checkpoint_every": 20}


def test_sample_on_a_full_disk_says_so_in_one_line(tmp_path: Path, monkeypatch, capsys) -> None:
    ref_cfg = write_case(tmp_path / "ref", n=300, sampler=SMALL)
    assert cli.main(["sample", str(ref_cfg), "--quiet"]) == 0
    ref = read_run(ref_cfg.parent / "chains.h5")
    cfg = write_case(tmp_path / "full", n=300, sampler=SMALL)
    capsys.readouterr()
    _enospc_at(monkeypatch, "append.data", nth=2)
    assert cli.main(["sample", str(cfg), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: disk full: cannot write ")
    assert "Traceback" not in err and "the committed chain (20 steps) is kept" in err
    assert _temporaries(cfg.parent) == []
    monkeypatch.undo()
    assert cli.main(["sample", str(cfg), "--quiet"]) == 0           # space freed: continues
    run = read_run(cfg.parent / "chains.h5")
    assert run.finished
    np.testing.assert_array_equal(run.chain, ref.chain)
    np.testing.assert_array_equal(run.log_prob, ref.log_prob)
    np.testing.assert_array_equal(run.accepted, ref.accepted)


# ---------------------------------------------------------------- a real full disk

BIG = {"walkers": 32, "max_steps": 400, "target_ess": 1.0e9, "checkpoint_every": 100}
COPIED = ("config.yaml", "data.csv", "fit.json")


@pytest.fixture
def small_disk(tmp_path: Path):
    """A 4 MB tmpfs (skipped where mounting is not permitted)."""
    with small_tmpfs(tmp_path) as mnt:
        yield mnt


@pytest.fixture(scope="module")
def big_reference(tmp_path_factory, zygote):
    path = write_case(tmp_path_factory.mktemp("full"), n=300, sampler=BIG)
    assert zygote.sample(path, log=path.parent / "log") == 0, (path.parent / "log").read_text()
    return path.parent, read_run(path.parent / "chains.h5")


@pytest.mark.parametrize("precheck", [True, False], ids=["free-space-check", "hdf5-write-fails"])
def test_sample_on_a_real_full_disk(tmp_path: Path, small_disk: Path, zygote, big_reference,
                                    precheck: bool) -> None:
    """The disk fills up while sampling: met by the free-space check before a commit, or (check
    switched off) by HDF5's own write failing with ENOSPC inside a commit."""
    folder, ref = big_reference
    run = small_disk / "syn"
    run.mkdir()
    for name in COPIED:
        shutil.copy(folder / name, run / name)
    # chains.h5 is 75 kB after its start and grows by about 40 kB per commit: room for 2 commits
    block = BIG["checkpoint_every"] * BIG["walkers"] * (8 * 3 + 9)
    filler = fill(small_disk, (store._MARGIN + 2 * block if precheck else 0) + 155_000)
    log = tmp_path / "full.log"
    code = zygote.sample(run / "config.yaml", log=log, precheck=precheck)
    text = log.read_text()
    assert code == 2, text                                   # not -11 (segfault), not 1 (traceback)
    assert text.count("\n") == 1 and text.startswith("error: disk full: ") and str(run) in text
    assert _temporaries(run) == []
    cut = read_run(run / "chains.h5")
    assert 0 < cut.steps < ref.steps and not cut.finished      # stopped mid-run, commits kept
    np.testing.assert_array_equal(cut.chain, ref.chain[: cut.steps])

    filler.unlink()                                          # space freed: `sample` continues
    code = zygote.sample(run / "config.yaml", log=log)
    assert code == 0, log.read_text()
    done = read_run(run / "chains.h5")
    assert done.finished
    np.testing.assert_array_equal(done.chain, ref.chain)
    np.testing.assert_array_equal(done.log_prob, ref.log_prob)
    np.testing.assert_array_equal(done.accepted, ref.accepted)
    assert _temporaries(run) == []
