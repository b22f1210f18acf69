"""bayes_dnlr/runs/lock.py: one holder at a time, no lock file left behind, a killed holder blocks nobody."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bayes_dnlr.errors import RunError
from bayes_dnlr.runs.lock import run_lock

HOLD = """
import sys, time
from pathlib import Path
from bayes_dnlr.runs.lock import run_lock
with run_lock(Path(sys.argv[1]), "sample.lock", "busy"):
    print("held", flush=True)
    time.sleep(60)
"""


def _holder(folder: Path) -> subprocess.Popen:
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(folder)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    return p


def test_the_lock_file_is_removed_on_a_normal_exit(tmp_path: Path) -> None:
    with run_lock(tmp_path, "sample.lock", "busy"):
        assert (tmp_path / "sample.lock").exists()
    assert not (tmp_path / "sample.lock").exists()
    with run_lock(tmp_path, "sample.lock", "busy"):  # and can be taken again
        pass


def test_a_second_holder_is_refused_while_the_first_holds_it(tmp_path: Path) -> None:
    p = _holder(tmp_path)
    try:
        with pytest.raises(RunError, match="busy"), run_lock(tmp_path, "sample.lock", "busy"):
            pass
    finally:
        p.terminate()
        p.wait()


def test_a_killed_holder_blocks_nobody(tmp_path: Path) -> None:
    p = _holder(tmp_path)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    assert (tmp_path / "sample.lock").exists()  # SIGKILL leaves the file, but not the lock
    t0 = time.monotonic()
    with run_lock(tmp_path, "sample.lock", "busy"):
        pass
    assert time.monotonic() - t0 < 5
    assert not (tmp_path / "sample.lock").exists()
