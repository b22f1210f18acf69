"""``sample`` with the discrepancy's hyperparameters sampled runs the conditional move under `de`,
says so, and continues the same chain bit-exactly when a stopped run is taken further."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from support.sampling import taken_further_and_in_one_go, write_case

from bayes_dnlr.config import load_config
from bayes_dnlr.runs.sample import sample


def test_the_conditional_move_runs_and_a_longer_run_continues_the_same_chain(tmp_path: Path) -> None:
    cfg = write_case(tmp_path, "a", n=600, noise="residuals", discrepancy="default",
                     error=("exp", 0.5, 20.0), seed=7,
                     sampler={"max_steps": 60, "target_ess": 1e9, "checkpoint_every": 20})
    post = sample(load_config(cfg), progress=False)
    names = post.summary["parameters"]
    assert names[-2:] == ["disc_amplitude", "disc_length"], names
    assert post.summary["moves"].startswith("DEMove (0.3) + the conditional move (0.7)")
    # the same run in one go, to 90 steps, against 60 steps then 30 more
    a, b = taken_further_and_in_one_go(cfg, 90)
    assert a.chain.shape == b.chain.shape == (90, 32, len(names))
    assert np.array_equal(a.chain, b.chain)
    # and the hyperparameters move: every walker visits several values in 90 steps
    moved = [len(np.unique(a.chain[:, w, -1])) for w in range(32)]
    assert min(moved) >= 5, moved


def test_de_plain_keeps_demove_alone(tmp_path: Path) -> None:
    cfg = write_case(tmp_path, "p", n=600, noise="residuals", discrepancy="default",
                     error=("exp", 0.5, 20.0), seed=7,
                     sampler={"max_steps": 30, "target_ess": 1e9, "moves": "de-plain"})
    post = sample(load_config(cfg), progress=False)
    assert post.summary["moves"] == "DEMove (also with the discrepancy's hyperparameters sampled)"
