"""Which of some paths the clone's .gitignore leaves visible to ``git status``."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def not_ignored(paths: list[str]) -> list[str]:
    """The paths (relative to the clone) that git would list as untracked; skips the test where git
    or the clone's .git is missing (a copy of the sources without its history)."""
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("not a git clone: .gitignore cannot be asked")
    done = subprocess.run(["git", "check-ignore", "--no-index", "--stdin", "-z"], cwd=REPO,
                          input="\0".join(paths) + "\0", capture_output=True, text=True)
    assert done.returncode in (0, 1), done.stderr          # 1: none of them is ignored
    ignored = set(filter(None, done.stdout.split("\0")))
    return [p for p in paths if p not in ignored]
