"""The real-data tests say in pytest's summary whether they ran: a clone without the real curves must
not run fewer tests silently."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parent


def _pytest(env_folder: str, *args: str) -> str:
    env = {**os.environ, "BAYES_DNLR_REAL_DATA": env_folder}
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *args],
                          cwd=TESTS.parent, env=env, capture_output=True, text=True, timeout=300)
    return done.stdout


def test_absent_real_curves_are_counted_in_the_summary_line(tmp_path):
    out = _pytest(str(tmp_path / "nowhere"), "tests/runs/test_real_data.py")
    last = out.strip().splitlines()[-1]
    assert "real-data tests skipped (curves absent)" in last, out
    assert "real data: absent" in out and "BAYES_DNLR_REAL_DATA" in out


def test_the_folder_comes_from_the_environment(tmp_path):
    """BAYES_DNLR_REAL_DATA names the folder (a copy elsewhere): the skip reason names it."""
    out = _pytest(str(tmp_path / "elsewhere"), "-rs", "tests/runs/test_real_data.py")
    assert str(tmp_path / "elsewhere") in out
