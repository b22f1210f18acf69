"""After a SIGKILL, chains.h5 carries HDF5's "open for write" flags and plain ``h5py.File(path)`` refuses
it ("already open for write ... h5clear"). The next bayes_dnlr open clears them when no `sample`
holds the run (``chains.release_stale_writer``): the package's reader, `sample` (also when it then
refuses a changed config), and the commands that take a run folder. A live writer's flags stay."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from support.sampling import write_case

from bayes_dnlr import cli
from bayes_dnlr.runs.chains import read_run, release_stale_writer, write_flags
from bayes_dnlr.runs.lock import run_lock

SAMPLER = {"walkers": 8, "max_steps": 60, "target_ess": 1.0e9, "checkpoint_every": 20}


@pytest.fixture(scope="module")
def killed_once(tmp_path_factory, zygote) -> Path:
    """A run whose `sample` was killed after its second commit (40 steps): chains.h5 flagged. The
    `sample` is forked from the session's zygote (support/crash.py), as the crash tests' are: a
    fresh interpreter cost it 3-4 s of CPU in imports."""
    config = write_case(tmp_path_factory.mktemp("killed"), "syn", n=200, sampler=SAMPLER)
    log = config.parent.parent / "sample.log"
    assert zygote.sample(config, kill="append.flushed@2", log=log) == -9, log.read_text()
    return config.parent


@pytest.fixture
def killed(killed_once: Path, tmp_path: Path) -> Path:
    """A copy of the killed run for each test (the bytes of chains.h5, flags included): one killed
    `sample` for the module."""
    config = Path(shutil.copytree(killed_once, tmp_path / "syn")) / "config.yaml"
    chains = config.parent / "chains.h5"
    assert write_flags(chains), "the killed writer left no flags: nothing to test"
    with pytest.raises(OSError, match="already open for write"):
        h5py.File(chains, "r")
    return config


def _plain_read(chains: Path) -> np.ndarray:
    with h5py.File(chains, "r") as f:              # what a user's own script does
        n = int(f["checkpoints/step"][-1])
        return f["chain"][:n]


def test_the_package_reader_clears_a_dead_writers_flags(killed: Path) -> None:
    chains = killed.parent / "chains.h5"
    run = read_run(chains)
    assert run.steps == 40
    assert write_flags(chains) == 0
    np.testing.assert_array_equal(_plain_read(chains), run.chain)


def test_sample_clears_them_even_when_it_refuses(killed: Path, capsys) -> None:
    raw = yaml.safe_load(killed.read_text())
    raw["sampler"]["seed"] = 99                                  # another chain: refused
    killed.write_text(yaml.safe_dump(raw))
    assert cli.main(["sample", "--quiet", str(killed)]) == 2
    assert "--restart" in capsys.readouterr().err
    assert _plain_read(killed.parent / "chains.h5").shape[0] == 40


def test_a_command_on_the_run_folder_clears_them(killed: Path, capsys) -> None:
    cli.main(["report", str(killed.parent)])                     # no posterior yet: any outcome
    capsys.readouterr()
    assert _plain_read(killed.parent / "chains.h5").shape[0] == 40


def test_a_live_writers_flags_are_left_alone(killed: Path) -> None:
    chains = killed.parent / "chains.h5"
    with run_lock(killed.parent, "sample.lock", "held by the test"):
        assert release_stale_writer(chains) is False
        assert write_flags(chains)
    assert release_stale_writer(chains) is True and write_flags(chains) == 0


def test_clearing_changes_only_the_flags(killed: Path) -> None:
    chains = killed.parent / "chains.h5"
    before = chains.read_bytes()
    assert release_stale_writer(chains)
    after = chains.read_bytes()
    assert len(after) == len(before)
    diff = [i for i in range(len(before)) if before[i] != after[i]]
    assert diff and max(diff) < 48 and 11 in diff            # the flags byte and the checksum
    assert release_stale_writer(chains) is False              # nothing left to clear
