"""The sampling progress bar: one measure (the ESS the stopping rule credits) toward a fixed total
(target_ess); monotone; 100 % exactly when the rule says converged."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from support.sampling import write_case

import bayes_dnlr.inference.mcmc.ensemble as mcmc
from bayes_dnlr.config import load_config
from bayes_dnlr.inference.mcmc.progress import EssProgress, credited_ess
from bayes_dnlr.inference.mcmc.stopping import Convergence
from bayes_dnlr.runs.sample import sample


def _conv(ess, tau=5.0, kept=400, converged=False, arviz=None) -> Convergence:
    ess = np.atleast_1d(np.asarray(ess, float))
    return Convergence(np.full(ess.size, tau), 20, kept, ess, converged, 1000, arviz)


def test_credited_ess_is_the_least_of_the_rules_conditions():
    assert credited_ess(None, 1000, 50) == 0
    assert credited_ess(_conv([800, 650]), 1000, 50) == 650            # the worst parameter
    assert credited_ess(_conv([1500], arviz=900), 1000, 50) == 900      # ArviZ's ESS when evaluated
    # kept 100 steps < 50 τ = 250: the length condition is 40 % met
    assert credited_ess(_conv([5000], kept=100), 1000, 50) == pytest.approx(400)
    assert credited_ess(_conv([5000], tau=np.inf), 1000, 50) == 0


def test_position_is_monotone_fixed_total_and_full_only_when_converged():
    meter = EssProgress(1000, 50)
    seq = [None, _conv(300), _conv(250), _conv(1200, arviz=980), _conv(1300, arviz=1100),
           _conv(1400, arviz=1200, converged=True)]
    pos = [meter.check(c) for c in seq]
    assert pos == [0, 300, 300, 980, 999, 1000]       # a drop is held; 999 until the rule says yes
    assert meter.total == 1000


class _Recorder:
    """A stand-in for tqdm that records what the bar would show."""

    runs: list[_Recorder] = []

    def __init__(self, total: int) -> None:
        self.total, self.n, self.history, self.totals = total, 0, [], []
        _Recorder.runs.append(self)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        pass

    def update(self, k: int) -> None:
        self.n += k
        self.history.append(self.n)
        self.totals.append(self.total)

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        self.postfix = text


@pytest.mark.parametrize(("target", "max_steps", "converges"), [(300, 2000, True), (1e6, 150, False)])
def test_bar_of_a_real_run(tmp_path: Path, monkeypatch, target, max_steps, converges):
    _Recorder.runs.clear()
    monkeypatch.setattr(mcmc, "_progress_bar", lambda progress, total: _Recorder(total))
    path = write_case(tmp_path, sampler={"max_steps": max_steps, "target_ess": target,
                                         "checkpoint_every": 50})
    post = sample(load_config(path), progress=True)
    bar = _Recorder.runs[-1]
    assert set(bar.totals) == {int(target)}                              # the total never jumps
    assert all(b >= a for a, b in zip(bar.history, bar.history[1:], strict=False))   # monotone
    finished = post.summary["stop_reason"] == "converged"
    assert finished is converges
    if converges:
        assert bar.n == bar.total                                        # ends at 100 %
        assert min(p["ess_bulk"] for p in post.summary["posterior"].values()) >= target
    else:
        assert 0 < bar.n < bar.total and bar.postfix.startswith(f"step {max_steps}/{max_steps}")


def test_the_bar_starts_no_thread():
    """tqdm's monitor thread stays off: a thread left in the process would keep `sample
    --report` from forking the report's figure worker. A fresh process: another test's bar may
    have started the monitor here already."""
    import subprocess
    import sys

    code = ("import threading\n"
            "from bayes_dnlr.inference.mcmc import ensemble\n"
            "bar = ensemble._progress_bar(True, 10)\n"
            "bar.update(3)\n"
            "print(threading.active_count())\n"
            "bar.close()\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "1"
