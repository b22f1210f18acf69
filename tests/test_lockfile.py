"""bayes_dnlr/lockfile.py: one holder at a time, no lock file left behind, a killed holder blocks nobody."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bayes_dnlr.lockfile import LockBusy, exclusive_lock

HOLD = """
import sys, time
from pathlib import Path
from bayes_dnlr.lockfile import exclusive_lock
with exclusive_lock(Path(sys.argv[1])):
    print("held", flush=True)
    time.sleep(60)
"""


def _holder(path: Path) -> subprocess.Popen:
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(path)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    return p


def test_the_lock_file_is_removed_on_a_normal_exit(tmp_path: Path) -> None:
    path = tmp_path / "run" / "sample.lock"
    with exclusive_lock(path):
        assert path.exists()
    assert not path.exists()
    with exclusive_lock(path):  # and can be taken again
        pass


def test_a_second_holder_is_refused_while_the_first_holds_it(tmp_path: Path) -> None:
    path = tmp_path / "sample.lock"
    p = _holder(path)
    try:
        with pytest.raises(LockBusy), exclusive_lock(path):
            pass
    finally:
        p.terminate()
        p.wait()


def test_a_killed_holder_blocks_nobody(tmp_path: Path) -> None:
    path = tmp_path / "sample.lock"
    p = _holder(path)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    assert path.exists()  # SIGKILL leaves the file, but not the lock
    t0 = time.monotonic()
    with exclusive_lock(path):
        pass
    assert time.monotonic() - t0 < 5
    assert not path.exists()
