"""A sampling process killed with SIGKILL (or stopped with Ctrl-C) resumes from its last checkpoint
and continues the very chain an uninterrupted run with the same seed gives."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from support.sampling import write_case

from bayes_dnlr.runs.chains import read_run

# never converges (target_ess huge): stops at max_steps; checkpoints every 50 steps. Long enough
# that the signal, sent once 150 steps are committed, arrives mid-run: the compiled all-walker
# likelihood (issue 14) did 1000 steps in under a second, before the signal.
SAMPLER = {"max_steps": 4000, "target_ess": 1.0e9, "checkpoint_every": 50, "walkers": 32}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run, made by the same compiled code as the interrupted and resumed runs:
    numba's on-disk cache. A process that compiles the kernel itself (a cold cache) runs its
    in-memory machine code, which can differ from the cached object code in the last bit of a sum
    (LLVM vectorizes the mode sums differently for the two; docs/sampling.md, 'Reproducibility').
    So the cache is filled by a throwaway run first, and the reference runs in its own process."""
    warm = write_case(tmp_path_factory.mktemp("warm"), sampler=SAMPLER | {"max_steps": 100})
    subprocess.run([sys.executable, "-m", "bayes_dnlr", "sample", str(warm), "--quiet"], check=True,
                   capture_output=True)
    path = write_case(tmp_path_factory.mktemp("ref"), sampler=SAMPLER)
    subprocess.run([sys.executable, "-m", "bayes_dnlr", "sample", str(path), "--quiet"], check=True,
                   capture_output=True)
    return read_run(path.parent / "chains.h5")


def _start(path: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "bayes_dnlr", "sample", str(path), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for_steps(proc: subprocess.Popen, chains: Path, at_least: int, timeout: float = 120.0) -> int:
    """Poll the file (a concurrent SWMR reader) until the writer has committed ``at_least`` steps."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert proc.poll() is None, proc.communicate()
        if chains.exists():
            try:
                n = read_run(chains).steps
            except OSError:       # the file is being created
                n = 0
            if n >= at_least:
                return n
        time.sleep(0.01)
    proc.kill()
    raise AssertionError("the sampler did not reach the expected step in time")


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT])
def test_interrupted_run_resumes_the_same_chain(tmp_path: Path, reference, sig) -> None:
    path = write_case(tmp_path, sampler=SAMPLER)
    chains = path.parent / "chains.h5"
    proc = _start(path)
    seen = _wait_for_steps(proc, chains, 150)
    os.kill(proc.pid, sig)
    _, err = proc.communicate(timeout=60)
    if sig == signal.SIGKILL:
        assert proc.returncode == -signal.SIGKILL
    else:
        assert proc.returncode == 130, err
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

    resumed = subprocess.run([sys.executable, "-m", "bayes_dnlr", "sample", str(path), "--quiet"],
                             capture_output=True, text=True)       # resume: a plain `sample`
    assert resumed.returncode == 0, resumed.stderr
    run = read_run(chains)
    assert run.finished and run.steps == reference.steps == SAMPLER["max_steps"]
    # no lost or duplicated steps: the resumed chain is the uninterrupted one, bit for bit
    np.testing.assert_array_equal(run.chain, reference.chain)
    np.testing.assert_array_equal(run.log_prob, reference.log_prob)
    np.testing.assert_array_equal(run.accepted, reference.accepted)
    np.testing.assert_array_equal(run.chain[: cut.steps], cut.chain)
    assert json.loads((path.parent / "summary.json").read_text())["steps"] == SAMPLER["max_steps"]
    assert np.all(np.diff(run.checkpoint_steps) > 0)
