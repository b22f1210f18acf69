"""A sampling process killed with SIGKILL (or stopped with Ctrl-C) resumes from its last checkpoint
and continues the very chain an uninterrupted run with the same seed gives."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from support.crash import child_running
from support.sampling import write_case

from bayes_dnlr.runs.chains import read_run

# never converges (target_ess huge): stops at max_steps; checkpoints every 50 steps. The signal is
# sent once 150 steps are committed and must arrive mid-run: the compiled all-walker likelihood
# did 1000 steps of 2000 points in under a second, so the interrupted run is paced (PACE after
# each of the two evaluations of a step: at least 1.7 s from step 150 to the end, in sleep, not
# CPU). The reference and the resumed run go at full speed; 4000 unpaced steps cost 10-13 s of CPU
# per run here. 16 walkers on 250 points: what is compared (the resumed chain against the
# uninterrupted one, bit for bit) does not depend on the size, which costs CPU in every run.
SAMPLER = {"max_steps": 1000, "target_ess": 1.0e9, "checkpoint_every": 50, "walkers": 16}
POINTS = 250
PACE = 0.001


@pytest.fixture(scope="module")
def reference(tmp_path_factory, zygote):
    """The uninterrupted run, made by the same compiled code as the interrupted and resumed runs.
    Every run here is a `sample` forked from the session's zygote (tests/support/crash.py), which
    loaded numba's kernels once: a process that compiles the kernel itself (a cold cache) runs its
    in-memory machine code, which can differ from the cached object code in the last bit of a sum
    (LLVM vectorizes the mode sums differently for the two; docs/sampling.md, 'Reproducibility')."""
    path = write_case(tmp_path_factory.mktemp("ref"), n=POINTS, sampler=SAMPLER)
    assert zygote.sample(path, log=path.parent / "sample.log") == 0
    return read_run(path.parent / "chains.h5")


def _wait_for_steps(pid: int, chains: Path, at_least: int, timeout: float = 120.0) -> int:
    """Poll the file (a concurrent SWMR reader) until the writer has committed ``at_least`` steps."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert child_running(pid), "the sampler ended before the signal"
        if chains.exists():
            try:
                n = read_run(chains).steps
            except OSError:       # the file is being created
                n = 0
            if n >= at_least:
                return n
        time.sleep(0.01)
    os.kill(pid, signal.SIGKILL)
    raise AssertionError("the sampler did not reach the expected step in time")


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT])
def test_interrupted_run_resumes_the_same_chain(tmp_path: Path, reference, zygote, sig) -> None:
    path = write_case(tmp_path, n=POINTS, sampler=SAMPLER)
    chains = path.parent / "chains.h5"
    log = path.parent / "interrupted.log"
    pid = zygote.start(path, log=log, pace=PACE)
    seen = _wait_for_steps(pid, chains, 150)
    os.kill(pid, sig)
    code = zygote.wait()
    err = log.read_text()
    if sig == signal.SIGKILL:
        assert code == -signal.SIGKILL
    else:
        assert code == 130, err
        # one line (taken at a step boundary, outside emcee: no traceback, no walker dump)
        assert err.startswith("interrupted: stopped at step ") and err.count("\n") == 1, err
        assert "chains.h5: run `sample` again to continue" in err
        assert not (path.parent / "sample.lock").exists()     # no lock file left behind
    cut = read_run(chains)
    assert seen <= cut.steps < SAMPLER["max_steps"]       # killed mid-run, committed work kept
    if sig == signal.SIGKILL:
        assert cut.steps % SAMPLER["checkpoint_every"] == 0   # only whole checkpoints survive
    assert not cut.finished
    # what was committed is exactly the uninterrupted chain's beginning
    np.testing.assert_array_equal(cut.chain, reference.chain[: cut.steps])

    resumed = path.parent / "resumed.log"
    assert zygote.sample(path, log=resumed) == 0, resumed.read_text()    # resume: a plain `sample`
    run = read_run(chains)
    assert run.finished and run.steps == reference.steps == SAMPLER["max_steps"]
    # no lost or duplicated steps: the resumed chain is the uninterrupted one, bit for bit
    np.testing.assert_array_equal(run.chain, reference.chain)
    np.testing.assert_array_equal(run.log_prob, reference.log_prob)
    np.testing.assert_array_equal(run.accepted, reference.accepted)
    np.testing.assert_array_equal(run.chain[: cut.steps], cut.chain)
    assert json.loads((path.parent / "summary.json").read_text())["steps"] == SAMPLER["max_steps"]
    assert np.all(np.diff(run.checkpoint_steps) > 0)
