"""A small finished run (fit and sample) for the tests of the commands that start from one
(export, design with from_run): 300 samples at 1e-2 1/s to strain 1, white noise 0.3 MPa, and a
transverse strain of ν = 0.45 (column e22; e22_half holds ν = 0.5).

The run is made once per test session (a fit and a sample) and every caller gets its own copy of
the folder, file times included, so that one file's tests never see another file's outputs."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

CONFIG = """name: tiny
data:
  file: tiny.csv
  columns: {time: t_s, strain: eps, stress: s, eps22: e22}
  observable: stress
noise: {sigma0: 0.3, discrepancy: none}
sampler: {walkers: 12, max_steps: 300, target_ess: 100, seed: 1, checkpoint_every: 100}
"""
TRUTH = {"E": 2854.0, "G": 2.32, "tau_max": 3.15}
RATE, N = 1e-2, 300


_MADE: list[Path] = []      # the session's pristine run, never handed out
_REPORTED: list[Path] = []  # a copy of it with its report, never handed out


def make_finished_run(folder: Path, name: str = "tiny", *, figures: bool = False,
                      page: bool = False) -> Path:
    """``folder/<name>``: a copy of the session's finished run (a run of another name is made anew:
    the name is inside its outputs).

    ``figures``: the copy also holds the figures of the run's report (figures/, drawn once per
    session, in this process: no figure worker), so that a report of it draws only the figures
    whose inputs the test changed (the others hold the same key: report/figure_cache.py), not all
    of them (2.5-3 s). For the tests that read the page; the tests of the drawing itself start
    without figures. ``page``: with ``figures``, that report's report.html too (the page as first
    built, which a rebuild and the worker's page are compared with)."""
    if name != "tiny":
        return _make(folder, name)
    if not _MADE or not _MADE[0].is_dir():
        _MADE[:] = [_make(folder.parent / "finished-run-made-once")]
    run = Path(shutil.copytree(_MADE[0], folder / "tiny"))
    if figures:
        if not _REPORTED or not _REPORTED[0].is_dir():
            import pytest

            from bayes_dnlr.report import build_report, figure_cache

            reported = Path(shutil.copytree(_MADE[0], folder.parent / "reported-run-made-once" / "tiny"))
            with pytest.MonkeyPatch.context() as mp:
                mp.setattr(figure_cache, "_free_core", lambda: False)     # whatever the machine's load
                build_report(reported)
            _REPORTED[:] = [reported]
        shutil.copytree(_REPORTED[0] / "figures", run / "figures")
        if page:
            shutil.copy2(_REPORTED[0] / "report.html", run / "report.html")
    return run


def _make(folder: Path, name: str = "tiny") -> Path:
    from bayes_dnlr.config import load_config
    from bayes_dnlr.model import simulate
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.sample import sample

    d = folder / name
    d.mkdir(parents=True)
    t = np.linspace(0.0, 1.0 / RATE, N)
    eps = RATE * t
    s = simulate(t, eps, TRUTH)
    rng = np.random.default_rng(0)
    data = np.column_stack([t, eps, s + rng.normal(0, 0.3, N), -0.45 * eps + rng.normal(0, 1e-5, N),
                            -0.5 * eps])
    np.savetxt(d / "tiny.csv", data, delimiter=",", header="t_s,eps,s,e22,e22_half", comments="")
    (d / "config.yaml").write_text(CONFIG.replace("name: tiny", f"name: {name}"))
    cfg = load_config(d / "config.yaml")
    fit(cfg)
    sample(cfg, progress=False)
    return d
