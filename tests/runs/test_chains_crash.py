"""chains.h5 survives a SIGKILL at every instant of every write (store.KILL_POINTS): right after each
write-mode open and inside each commit (checkpoint 0, every appended block, the generation switch of
a start or a resume, the finish). After each kill the file opens, holds a prefix of the
uninterrupted chain with every step committed before the kill, and a plain `sample` (no
--restart) finishes the very chain an uninterrupted run gives, bit for bit.

The kills happen in `sample` processes forked from a zygote (support/crash.py: the CLI's main, with
BAYES_DNLR_KILL_AT naming the instant); one case runs `python -m bayes_dnlr sample` itself.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from support.sampling import write_case

from bayes_dnlr.diskio import KILL_ENV
from bayes_dnlr.runs import chains as store
from bayes_dnlr.runs.chains import KILL_POINTS, read_run

# 8 walkers, 3 checkpoints of 20 steps, never converges: stops at max_steps
SAMPLER = {"walkers": 8, "max_steps": 60, "target_ess": 1.0e9, "checkpoint_every": 20}
COPIED = ("config.yaml", "data.csv", "fit.json")

# (kill before, kill) per case: a fresh run killed at ``kill``, or a run first killed after its
# second commit (40 steps committed) and then killed at ``kill`` while it resumes
_PARTIAL = "append.flushed@2"
CASES = ([(None, p) for p in KILL_POINTS if not p.startswith(("resume.", "append."))]
         + [(None, f"{p}@2") for p in KILL_POINTS if p.startswith("append.")]
         + [(_PARTIAL, p) for p in KILL_POINTS if p.startswith(("resume.", "publish."))])
# before the first rename there is no chains.h5 yet
NO_FILE_YET = {"create.open", "create.checkpoint", "create.written", "publish.swmr", "publish.synced"}


def _case_id(case: tuple[str | None, str]) -> str:
    before, kill = case
    return f"{kill}" if before is None else f"resumed-{kill}"


@pytest.fixture(scope="module")
def template(tmp_path_factory, zygote) -> tuple[Path, store.StoredRun]:
    """A run directory with fit.json, and its uninterrupted chain (a `sample` forked from the
    zygote, as the killed runs are; the last test's real `python -m bayes_dnlr sample` finishes
    this very chain too). A fresh interpreter cost the reference 4-5 s of CPU in imports."""
    path = write_case(tmp_path_factory.mktemp("crash"), n=300, sampler=SAMPLER)
    log = path.parent / "reference.log"
    assert zygote.sample(path, log=log) == 0, log.read_text()
    ref = read_run(path.parent / "chains.h5")
    assert ref.finished and ref.steps == SAMPLER["max_steps"]
    return path.parent, ref


def _fresh(template: Path, folder: Path) -> Path:
    folder.mkdir(parents=True)
    for name in COPIED:
        shutil.copy(template / name, folder / name)
    return folder / "config.yaml"


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory, template, zygote) -> Path:
    """A run folder of the template killed after its second commit (``_PARTIAL``: 40 steps
    committed), as each resumed case starts: the chain is the same to the bit at every run (one
    seed, one kill instant), so one kill serves them all and each case resumes a copy of it (a kill
    of its own before each cost a forked `sample`, 0.4 s of CPU)."""
    folder, ref = template
    config = _fresh(folder, tmp_path_factory.mktemp("interrupted") / "syn")
    log = config.parent.parent / "before.log"
    assert zygote.sample(config, kill=_PARTIAL, log=log) == -9, log.read_text()
    _assert_prefix(read_run(config.parent / "chains.h5"), ref, 40)
    return config.parent


def _resumable(interrupted: Path, folder: Path) -> tuple[Path, int]:
    """A copy of the interrupted run in ``folder``; its config and the steps committed (40)."""
    shutil.copytree(interrupted, folder, symlinks=True)
    committed = read_run(folder / "chains.h5").steps
    assert committed == 40
    return folder / "config.yaml", committed


def _assert_prefix(run: store.StoredRun, ref: store.StoredRun, at_least: int) -> None:
    """The committed chain is the uninterrupted one's beginning, and nothing committed was lost."""
    assert at_least <= run.steps <= ref.steps
    np.testing.assert_array_equal(run.chain, ref.chain[: run.steps])
    np.testing.assert_array_equal(run.log_prob, ref.log_prob[: run.steps])
    np.testing.assert_array_equal(run.accepted, ref.accepted[: run.steps])
    np.testing.assert_array_equal(run.checkpoint_steps, ref.checkpoint_steps[: run.checkpoint_steps.size])


def _assert_same_as_reference(run: store.StoredRun, ref: store.StoredRun) -> None:
    assert run.finished and run.attrs["stop_reason"] == "max_steps"
    np.testing.assert_array_equal(run.chain, ref.chain)
    np.testing.assert_array_equal(run.log_prob, ref.log_prob)
    np.testing.assert_array_equal(run.accepted, ref.accepted)
    np.testing.assert_array_equal(run.checkpoint_steps, ref.checkpoint_steps)
    np.testing.assert_array_equal(run.state.coords, ref.state.coords)
    np.testing.assert_array_equal(run.state.rng[1], ref.state.rng[1])


def _no_temporaries(folder: Path) -> None:
    stray = [p.name for p in folder.iterdir() if p.name.endswith(".tmp")]
    assert not stray, stray


def test_every_kill_point_is_tested() -> None:
    """KILL_POINTS lists every kill point in the store's code, and every one is a case here."""
    code = Path(store.__file__).read_text()
    in_code = set(re.findall(r'kill_point\("([a-z.]+)"\)', code))
    in_code |= {f"{kind}.open" for kind in re.findall(r'_publish\(\w+, fill, "(\w+)"', code)}
    in_code |= set(re.findall(r'commit_point="([a-z.]+)"', code))
    in_code |= set(re.findall(r'"(append\.checkpoint)"\)', code))
    assert in_code == set(KILL_POINTS)
    assert {kill.split("@")[0] for _, kill in CASES} == set(KILL_POINTS)
    assert len(KILL_POINTS) == 16 and len(CASES) == 19


@pytest.mark.parametrize("case", CASES, ids=_case_id)
def test_sigkill_at_every_instant_loses_nothing(tmp_path: Path, template, interrupted, zygote,
                                               case) -> None:
    before, kill = case
    folder, ref = template
    chains = tmp_path / "syn" / "chains.h5"
    if before is None:
        config, committed = _fresh(folder, tmp_path / "syn"), 0
    else:
        assert before == _PARTIAL
        config, committed = _resumable(interrupted, tmp_path / "syn")

    code = zygote.sample(config, kill=kill, log=tmp_path / "killed.log")
    assert code == -9, (tmp_path / "killed.log").read_text()
    if chains.exists():
        _assert_prefix(read_run(chains), ref, committed)    # opens; nothing committed lost
    else:
        assert before is None and kill in NO_FILE_YET

    code = zygote.sample(config, log=tmp_path / "plain.log")            # plain `sample`
    assert code == 0, (tmp_path / "plain.log").read_text()
    _assert_same_as_reference(read_run(chains), ref)
    assert (tmp_path / "syn" / "summary.json").is_file() and (tmp_path / "syn" / "posterior.nc").is_file()
    _no_temporaries(tmp_path / "syn")


def test_python_m_sample_killed_where_hdf5_used_to_poison_the_file(tmp_path: Path, template,
                                                                   interrupted) -> None:
    """A real `python -m bayes_dnlr sample` killed as it resumes, between opening the new generation
    for writing and its SWMR switch (where a resume used to leave an unopenable chains.h5)."""
    _, ref = template
    config, _ = _resumable(interrupted, tmp_path / "syn")
    chains = tmp_path / "syn" / "chains.h5"
    out = subprocess.run([sys.executable, "-m", "bayes_dnlr", "sample", str(config), "--quiet"],
                         capture_output=True, text=True, timeout=300,
                         env={**os.environ, KILL_ENV: "resume.written"})
    assert out.returncode == -9, out.stderr
    _assert_prefix(read_run(chains), ref, 40)
    assert (tmp_path / "syn" / "chains.h5.tmp").exists()     # the abandoned generation, not the file
    out = subprocess.run([sys.executable, "-m", "bayes_dnlr", "sample", str(config), "--quiet"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    _assert_same_as_reference(read_run(chains), ref)
    _no_temporaries(tmp_path / "syn")


def test_the_zygote_keeps_each_childs_pid_and_code_apart(zygote, tmp_path: Path) -> None:
    # the zygote is shared by the session: a test that fails between a start and its wait leaves
    # its child's exit code unread, and the next test must not take that code for its child's pid
    from support.crash import child_running

    zygote.start_command(["--version"], log=tmp_path / "left.log")        # never waited for
    pid = zygote.start_command(["--version"], log=tmp_path / "next.log")
    assert pid > 1
    assert zygote.wait() == 0
    assert (tmp_path / "next.log").read_text().startswith("bayes_dnlr ")
    assert not child_running(pid)                   # reaped: gone from /proc
