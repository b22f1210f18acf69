"""``sample`` with the discrepancy's hyperparameters sampled runs the conditional move under `de`,
says so, and continues the same chain bit-exactly when a stopped run is taken further."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import yaml
from support.sampling import write_case

from bayes_dnlr.config import load_config
from bayes_dnlr.runs.chains import read_run
from bayes_dnlr.runs.sample import sample


def _with(cfg: Path, **sampler) -> Path:
    raw = yaml.safe_load(cfg.read_text())
    raw["name"] = cfg.parent.name
    raw["sampler"].update(sampler)
    cfg.write_text(yaml.safe_dump(raw, sort_keys=False))
    return cfg


def test_the_conditional_move_runs_and_a_longer_run_continues_the_same_chain(tmp_path: Path) -> None:
    cfg = write_case(tmp_path, "a", n=600, noise="residuals", discrepancy="default",
                     error=("exp", 0.5, 20.0), seed=7,
                     sampler={"max_steps": 60, "target_ess": 1e9, "checkpoint_every": 20})
    post = sample(load_config(cfg), progress=False)
    names = post.summary["parameters"]
    assert names[-2:] == ["disc_amplitude", "disc_length"], names
    assert post.summary["moves"].startswith("DEMove (0.3) + the conditional move (0.7)")
    # the same run in one go, to 90 steps, against 60 steps then 30 more
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    one = _with(tmp_path / "b" / "config.yaml", max_steps=90)
    for name in ("chains.h5", "posterior.nc", "summary.json"):
        (one.parent / name).unlink()
    sample(load_config(one), progress=False)
    sample(load_config(_with(cfg, max_steps=90)), progress=False)
    a, b = read_run(cfg.parent / "chains.h5"), read_run(one.parent / "chains.h5")
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
