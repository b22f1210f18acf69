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


# the report's figure functions (report/figures.py), which the sections call through the module
FIGURE_FUNCTIONS = ("corner_plot", "trace_plot", "rank_plot", "fit_plot", "sensitivity_plot",
                    "sensitivity_xy_plot", "acf_plot")


def blank_figure(*args, **kwargs) -> Path:
    """A figure function's stand-in: an empty file where the figure goes, nothing drawn."""
    path = Path(kwargs.get("path") or next(a for a in args if isinstance(a, Path)))
    path.write_bytes(b"")
    return path


def figures_not_drawn(monkeypatch, keep: tuple[str, ...] = ()) -> None:
    """The report's figure functions (all but ``keep``) write an empty file instead of drawing.

    For the tests that read the page's text (and which figures it names): the page is built whole,
    by the same sections, and names the same figure files; drawing costs 0.2-1.7 s a figure (a
    report 2.5-5 s). Drawing every figure of a report is checked where the figures are the point
    (tests/report/test_windows.py, test_html.py, test_figure_cache.py, tests/runs/test_joint.py)."""
    from bayes_dnlr.report import figures as figs

    for name in FIGURE_FUNCTIONS:
        if name not in keep:
            monkeypatch.setattr(figs, name, blank_figure)
