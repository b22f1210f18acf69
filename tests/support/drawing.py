"""Stand-ins for figure functions in the figure-session tests: picklable (module level), so the
session's worker process can draw them; each records which process drew it."""

from __future__ import annotations

import os
import time
from pathlib import Path


def busy_until(path: Path, timeout: float = 30.0) -> None:
    """The worker's first task: it keeps the worker busy until ``path`` exists (a figure the
    session's process draws at its end), so that the worker cannot take the figures handed over
    after the first ones, however slowly the test runs."""
    deadline = time.monotonic() + timeout
    while not path.exists() and time.monotonic() < deadline:
        time.sleep(0.005)


def pid_figure(path: Path) -> Path:
    """A 'figure' that writes the id of the process that drew it."""
    path.write_text(str(os.getpid()))
    return path


def logged_figure(path: Path, log: Path) -> Path:
    """``pid_figure``, and the figure's name appended to ``log``: the order the figures were drawn."""
    with open(log, "a") as f:
        f.write(f"{path.name}\n")
    return pid_figure(path)
