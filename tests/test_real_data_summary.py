"""The real-data tests say in pytest's summary whether they ran: a clone without the real curves must
not run fewer tests silently."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def absent(tmp_path_factory) -> tuple[Path, str]:
    """A folder named by BAYES_DNLR_REAL_DATA that holds no curves, and what pytest printed for the
    real-data tests with it (one pytest for both tests: ``-rs`` adds nothing to the project's -ra)."""
    folder = tmp_path_factory.mktemp("real") / "elsewhere"
    env = {**os.environ, "BAYES_DNLR_REAL_DATA": str(folder)}
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-rs",
                           "tests/runs/test_real_data.py"],
                          cwd=TESTS.parent, env=env, capture_output=True, text=True, timeout=300)
    return folder, done.stdout


def test_absent_real_curves_are_counted_in_the_summary_line(absent):
    _, out = absent
    last = out.strip().splitlines()[-1]
    assert "real-data tests skipped (curves absent)" in last, out
    [line] = [x for x in out.splitlines() if x.startswith("real data: absent")]
    assert "BAYES_DNLR_REAL_DATA" in line, out


def test_the_folder_comes_from_the_environment(absent):
    """BAYES_DNLR_REAL_DATA names the folder (a copy elsewhere): the skip reason names it."""
    folder, out = absent
    assert str(folder) in out
