"""Damaged files of every kind the package reads back (chains.h5, posterior.nc, fit.json,
summary.json, the .npz caches): each read ends, with the right content or a DamagedFileError that
names the file, says what is damaged and what can still be read; the commands end with exit 2 and
one line, or a correct result. No read hangs: HDF5's reads run in a child with a deadline
(bayes_dnlr/readback.py); the deadline is 1 s here (BAYES_DNLR_READ_SECONDS), the slow part runs
the commands with the package's own."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support.chains import create_writer, make_blocks, phys
from support.damage import CHAIN_DAMAGES, cut, damage_file, flipped, heap_zeroed
from support.drawing import figures_not_drawn
from support.finished_run import make_finished_run

from bayes_dnlr import cli
from bayes_dnlr.errors import DamagedFileError
from bayes_dnlr.readback import DEADLINE_ENV, read_json, read_npz, within_deadline
from bayes_dnlr.runs.chains import read_attrs, read_run
from bayes_dnlr.runs.results import load_run, read_draws

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def short_deadline(monkeypatch) -> None:
    monkeypatch.setenv(DEADLINE_ENV, "1")


@pytest.fixture(scope="module")
def small_chain(tmp_path_factory) -> tuple[Path, np.ndarray]:
    """A finished chain file of 20 steps, and its chain."""
    path = tmp_path_factory.mktemp("chain") / "chains.h5"
    blocks = list(make_blocks(1, 2))
    w = create_writer(path)
    for z, lp, acc, s in blocks:
        w.append(z, lp, acc, s, elapsed=1.0, n_evals=1)
    w.finish({"stop_reason": "max_steps"})
    return path, phys(np.concatenate([b[0] for b in blocks]))


def _damaged_copy(src: Path, folder: Path, damage) -> Path:
    path = folder / src.name
    shutil.copy2(src, path)
    damage_file(path, damage)
    return path


def _check_refused(err: DamagedFileError, path: Path) -> str:
    text = str(err)
    assert text.startswith(str(path)) and "\n" not in text
    assert ("Still readable" in text or "Nothing in it can be read" in text
            or "not a bayes_dnlr chain file" in text)
    assert "sample --restart" in text
    return text


# ---------------------------------------------------------------- chains.h5

@pytest.mark.parametrize("name", sorted(CHAIN_DAMAGES))
def test_a_damaged_chain_is_read_right_or_refused_with_what_is_left(small_chain, tmp_path, name) -> None:
    src, chain = small_chain
    path = _damaged_copy(src, tmp_path, CHAIN_DAMAGES[name])
    try:
        run = read_run(path)
    except DamagedFileError as err:
        _check_refused(err, path)
    else:                       # the damage missed every byte read: the very chain
        np.testing.assert_array_equal(run.chain, chain)
        assert run.finished
    try:
        attrs = read_attrs(path)
    except DamagedFileError as err:
        _check_refused(err, path)
    else:
        assert attrs["names"] == ["E", "G", "tau_max"]


def test_a_looping_read_is_stopped_at_its_deadline_and_says_what_was_read(small_chain, tmp_path) -> None:
    path = _damaged_copy(small_chain[0], tmp_path, heap_zeroed)
    with pytest.raises(DamagedFileError) as info:
        read_run(path)
    text = _check_refused(info.value, path)
    assert "did not end within 1 s" in text and "its attributes" in text
    assert "Still readable" in text and "20 steps of the chain (8 walkers x 3 parameters)" in text


def test_ctrl_c_stops_a_read_that_hangs(small_chain, tmp_path, monkeypatch) -> None:
    path = _damaged_copy(small_chain[0], tmp_path, heap_zeroed)
    monkeypatch.setenv(DEADLINE_ENV, "60")

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, 0.5)
    try:
        with pytest.raises(KeyboardInterrupt):
            read_run(path)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def test_with_other_threads_the_read_runs_here_and_still_names_the_damage(small_chain, tmp_path) -> None:
    path = _damaged_copy(small_chain[0], tmp_path, flipped(997, 2048))
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        assert len(read_run(small_chain[0]).chain) == 20
        with pytest.raises(DamagedFileError):
            read_run(path)
    finally:
        stop.set()
        other.join()


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(stride=st.integers(40, 20_000), offset=st.integers(0, 8000), xor=st.integers(1, 255))
def test_any_flipped_bytes_give_the_chain_or_a_damage_error(small_chain, tmp_path, stride, offset,
                                                           xor) -> None:
    src, chain = small_chain
    data = bytearray(src.read_bytes())
    for i in range(offset, len(data), stride):
        data[i] ^= xor
    path = tmp_path / "chains.h5"
    path.write_bytes(bytes(data))
    try:
        run = read_run(path)
    except DamagedFileError as err:
        _check_refused(err, path)
    else:
        np.testing.assert_array_equal(run.chain, chain)


# ---------------------------------------------------------------- the reading child

def test_a_crash_of_the_reader_is_a_failure_not_a_crash_here() -> None:
    import os

    got = within_deadline(lambda emit: (emit("a", 1), os.kill(os.getpid(), signal.SIGSEGV)),
                          Path("x"))
    assert got == {"a": 1} and "crashed" in got.failure and "SIGSEGV" in got.failure


def test_a_failing_read_keeps_what_it_sent() -> None:
    def read(emit):
        emit("a", np.arange(3))
        raise KeyError("b")

    got = within_deadline(read, Path("x"))
    assert list(got) == ["a"] and got.failure == "b"


def test_a_large_result_crosses_the_pipe_whole() -> None:
    big = np.random.default_rng(0).normal(size=(400, 64, 12))       # 2.5 MB, many pipe buffers
    got = within_deadline(lambda emit: emit("chain", big), Path("x"))
    assert got.failure is None
    np.testing.assert_array_equal(got["chain"], big)


# ---------------------------------------------------------------- JSON and caches

JSON_DAMAGES = {
    "cut": lambda b: b[: len(b) // 2],
    "flipped": flipped(7, 3),
    "a list": lambda b: b"[1, 2]",
    "binary": lambda b: bytes(range(256)) * 4,
    "deep": lambda b: b"[" * 100_000 + b"]" * 100_000,
    "empty": lambda b: b"",
}


@pytest.mark.parametrize("name", sorted(JSON_DAMAGES))
def test_damaged_json_is_named(tmp_path, name) -> None:
    path = tmp_path / "summary.json"
    path.write_bytes(JSON_DAMAGES[name](json.dumps({"parameters": ["E"], "x": 1.5}).encode()))
    with pytest.raises(DamagedFileError, match=f"^{path}: damaged"):
        read_json(path, "summary.json")


@settings(max_examples=60, deadline=None)
@given(st.binary(max_size=300))
def test_read_json_takes_any_bytes(tmp_path_factory, data) -> None:
    path = tmp_path_factory.mktemp("j") / "fit.json"
    path.write_bytes(data)
    try:
        value = read_json(path)
    except DamagedFileError as err:
        assert str(err).startswith(str(path))
    else:
        assert isinstance(value, dict)


@pytest.mark.parametrize("damage", [flipped(50, 30), cut(0.5), cut(0.0)], ids=["flipped", "cut", "empty"])
def test_a_damaged_cache_is_a_missing_one(tmp_path, damage) -> None:
    from bayes_dnlr.diskio import keep_cache_arrays

    path = tmp_path / ".cache" / "x.npz"
    assert keep_cache_arrays(path, strain=np.arange(500.0), lams=np.ones(3))
    assert read_npz(path)["strain"].shape == (500,)
    damage_file(path, damage)
    assert read_npz(path) is None


# ---------------------------------------------------------------- the commands

@pytest.fixture
def run(tmp_path) -> Path:
    return make_finished_run(tmp_path)


def test_sample_refuses_a_damaged_chain_at_once_and_says_what_is_kept(run, capsys) -> None:
    damage_file(run / "chains.h5", flipped(997, 2048))
    assert cli.main(["sample", str(run / "config.yaml"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {run / 'chains.h5'} is damaged")
    assert "posterior.nc, summary.json" in err and "`report` and `export` read them" in err


def test_report_of_a_run_with_a_damaged_chain_is_built_and_says_so(run, monkeypatch, capsys) -> None:
    figures_not_drawn(monkeypatch)
    damage_file(run / "chains.h5", heap_zeroed)
    assert cli.main(["report", str(run), "--force"]) == 0
    page = (run / "report.html").read_text()
    assert "chains.h5 is damaged" in page and "did not end within 1 s" in page


@pytest.mark.parametrize("damage", [flipped(997, 2048), cut(0.6)], ids=["flipped", "cut"])
def test_a_damaged_posterior_is_named_by_report_and_export(run, damage, capsys) -> None:
    nc = run / "posterior.nc"
    damage_file(nc, damage)
    with pytest.raises(DamagedFileError, match="remove it and run `sample`"):
        read_draws(nc)
    assert any(p.startswith("posterior.nc could not be read") for p in load_run(run).problems)
    assert cli.main(["export", str(run), "--format", "csv"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {nc}: not a readable posterior") and err.count("\n") == 1


def test_a_removed_posterior_is_written_again_from_the_chain(run) -> None:
    before = read_draws(run / "posterior.nc")
    (run / "posterior.nc").unlink()
    assert cli.main(["sample", str(run / "config.yaml"), "--quiet"]) == 0
    after = read_draws(run / "posterior.nc")
    np.testing.assert_array_equal(after["E"], before["E"])


@pytest.mark.parametrize("name", ["summary.json", "fit.json"])
def test_export_names_damaged_json(run, name, capsys) -> None:
    damage_file(run / name, cut(0.5))
    assert cli.main(["export", str(run), "--format", "csv"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {run / name}: damaged") and err.count("\n") == 1


# ---------------------------------------------------------------- slow: every damage, every command

@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CHAIN_DAMAGES))
def test_commands_end_cleanly_on_every_damaged_chain(tmp_path, name, monkeypatch) -> None:
    """sample, report --force and export, each in its own process with the package's deadline:
    exit 0 (a correct result: report and export read posterior.nc) or 2 with one line naming
    chains.h5, never a traceback. benchmarks/damaged_chains.py times them."""
    monkeypatch.delenv(DEADLINE_ENV)
    run = make_finished_run(tmp_path)
    damage_file(run / "chains.h5", CHAIN_DAMAGES[name])
    for args in (["sample", str(run / "config.yaml"), "--quiet"], ["report", str(run), "--force"],
                 ["export", str(run), "--format", "abaqus", "--force"]):
        out = subprocess.run([sys.executable, "-m", "bayes_dnlr", *args], capture_output=True,
                             text=True, timeout=120, cwd=REPO)
        assert out.returncode in (0, 2), out.stderr
        assert "Traceback" not in out.stderr
        if out.returncode == 2:
            assert out.stderr.startswith(f"error: {run / 'chains.h5'}") and out.stderr.count("\n") == 1
        elif args[0] == "export":
            assert (run / "export" / "abaqus").is_dir()
