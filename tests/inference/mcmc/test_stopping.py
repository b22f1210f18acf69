"""The stopping rule is checked often enough to stop within 5 % of the target ESS, and a
run that stops between checkpoints resumes and stops exactly like an uninterrupted one."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.sampling import write_case

from bayes_dnlr.config import load_config
from bayes_dnlr.inference.mcmc.ensemble import CHECK_FRACTION, next_check
from bayes_dnlr.inference.mcmc.stopping import Convergence
from bayes_dnlr.runs.chains import read_run
from bayes_dnlr.runs.sample import sample


def _conv(needed: int, stuck: bool = False) -> Convergence:
    return Convergence(np.ones(1), 0, 0, np.ones(1), False, needed, stuck={0: [1]} if stuck else {})


def test_check_schedule() -> None:
    assert next_check(0, None, 100) == 20                 # no τ before 20 steps
    for n in (20, 150, 700, 3000):
        step = next_check(n, None, 100) - n
        assert 1 <= step <= max(1, math.ceil(CHECK_FRACTION * n)) and step <= 100
    assert next_check(300, _conv(360), 100) == 360        # jump to the step τ says is needed
    assert next_check(300, _conv(900), 100) == 400        # but check at least once per block
    assert next_check(300, _conv(900, stuck=True), 100) == 306


@pytest.fixture(scope="module")
def ess_bound_run(tmp_path_factory):
    """ESS is what binds: a short min_tau_multiple, checkpoints far apart. The target is high enough
    that the run goes well past its first checkpoint (about 300 steps), which the resume test
    interrupts."""
    path = write_case(tmp_path_factory.mktemp("stop"), n=400, seed=3,
                      sampler={"max_steps": 3000, "target_ess": 4000, "checkpoint_every": 100,
                               "min_tau_multiple": 10})
    post = sample(load_config(path), progress=False)
    return path, post


def test_stops_within_five_percent_of_the_target_ess(ess_bound_run) -> None:
    path, post = ess_bound_run
    s = post.summary
    assert s["stop_reason"] == "converged"
    steps = s["steps"]
    assert steps % 100 != 0                                # it stopped between two checkpoints
    kept_ess = [s["ess_autocorr"][k] for k in s["parameters"]]
    arviz = [min(s["posterior"][k]["ess_bulk"], s["posterior"][k]["ess_tail"]) for k in s["parameters"]]
    binding = min(min(kept_ess), min(arviz))
    assert 4000 <= binding <= 1.05 * 4000
    assert read_run(path.parent / "chains.h5").steps == steps   # the partial block is committed


def test_resume_after_an_early_stop_gives_the_same_chain(tmp_path, ess_bound_run) -> None:
    path, post = ess_bound_run
    ref = read_run(path.parent / "chains.h5")
    assert ref.steps > 200              # the uninterrupted run went past the checkpoint stopped at
    # the same run interrupted at its second checkpoint (max_steps 200), then continued
    other = write_case(tmp_path, n=400, seed=3,
                       sampler={"max_steps": 200, "target_ess": 4000, "checkpoint_every": 100,
                                "min_tau_multiple": 10})
    first = sample(load_config(other), progress=False)
    assert first.summary["stop_reason"] == "max_steps"
    text = other.read_text().replace("max_steps: 200", "max_steps: 3000")
    other.write_text(text)
    again = sample(load_config(other), progress=False)
    run = read_run(other.parent / "chains.h5")
    assert again.summary["steps"] == post.summary["steps"] == run.steps
    np.testing.assert_array_equal(run.chain, ref.chain)


def test_tau_equals_emcee() -> None:
    from emcee.autocorr import integrated_time

    from bayes_dnlr.inference.mcmc.stopping import _tau

    rng = np.random.default_rng(0)
    for n in (20, 57, 401):
        x = np.cumsum(rng.normal(size=(n, 16, 3)), axis=0) * 0.1 + rng.normal(size=(n, 16, 3))
        x[:, 3, 2] = 1.0                                   # a stuck walker is left out
        x[:, :, 1] = x[:1, :, 1]                           # no walker moves: tau = inf
        ours = _tau(x)
        for j in (0, 2):
            moving = np.ptp(x[:, :, j], axis=0) > 0
            ref = integrated_time(x[:, moving, j][:, :, None], c=5, tol=0, quiet=True)[0]
            assert ours[j] == pytest.approx(ref, rel=1e-12)
        assert ours[1] == np.inf


def test_a_short_arviz_ess_puts_the_next_check_half_way_to_the_target(monkeypatch) -> None:
    """emcee's criteria hold, ArviZ's ESS is half the target: the next check is half-way to the
    step where ESS in proportion to the kept steps reaches it (kept / 2 steps on), not one step on."""
    from bayes_dnlr.inference.mcmc import ess, stopping

    chain = np.random.default_rng(0).standard_normal((400, 32, 2))      # white: τ ≈ 1
    monkeypatch.setattr(ess, "diagnostics", lambda x: {"ess_bulk": 500.0, "ess_tail": 900.0,
                                                       "r_hat": 1.0})
    conv = stopping.convergence(chain, 5.0, 50.0, 1000.0)
    assert not conv.converged and conv.arviz_ess == 500.0
    assert conv.needed_steps == 400 + int(0.5 * conv.kept)
    monkeypatch.setattr(ess, "diagnostics", lambda x: {"ess_bulk": 2000.0, "ess_tail": 2000.0,
                                                       "r_hat": 1.02})
    conv = stopping.convergence(chain, 5.0, 50.0, 1000.0)     # R-hat alone: the next step
    assert not conv.converged and conv.needed_steps == 401
