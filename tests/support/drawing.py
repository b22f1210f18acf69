"""Stand-ins for figure functions in the figure-session tests: picklable (module level), so the
session's worker process can draw them; each records which process drew it."""

from __future__ import annotations

import os
import time
from pathlib import Path


def busy_worker() -> None:
    """The worker's first task: it keeps the worker busy while the test hands figures over."""
    time.sleep(0.5)


def pid_figure(path: Path) -> Path:
    """A 'figure' that writes the id of the process that drew it."""
    path.write_text(str(os.getpid()))
    return path
