"""``sample`` with the white likelihood runs the Laplace move under `de`, says so, continues the same
chain bit-exactly when a stopped run is taken further, and goes on with DEMove alone on a chain
begun without it (by an earlier version). Where the linearization cannot be trusted (a sampled
spectrum exponent, an estimate on a bound) `de` makes the complement move instead, which continues
bit-exactly too, and DEMove alone with too few walkers for it."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
from support.sampling import taken_further_and_in_one_go, with_sampler, write_case

from bayes_dnlr.config import load_config
from bayes_dnlr.inference.mcmc import ensemble
from bayes_dnlr.runs.chains import read_run
from bayes_dnlr.runs.sample import sample

LAPLACE = "DEMove (0.3) + the Laplace move (0.7)"
COMPLEMENT = "DEMove (0.3) + the complement move (0.7)"


def _white(tmp_path: Path, name: str, **sampler) -> Path:
    return write_case(tmp_path, name, n=300, seed=5,
                      sampler={"max_steps": 40, "target_ess": 1e9, "checkpoint_every": 20, **sampler})


def test_the_laplace_move_runs_and_a_longer_run_continues_the_same_chain(tmp_path: Path) -> None:
    cfg = _white(tmp_path, "a")
    post = sample(load_config(cfg), progress=False)
    assert post.summary["moves"].startswith(LAPLACE), post.summary["moves"]
    a, b = taken_further_and_in_one_go(cfg, 70)
    assert a.chain.shape == b.chain.shape == (70, 32, 3)
    assert np.array_equal(a.chain, b.chain)


def test_a_chain_begun_with_demove_alone_goes_on_with_it(tmp_path: Path, monkeypatch) -> None:
    cfg = _white(tmp_path, "old")
    sample(load_config(cfg), progress=False)
    with h5py.File(cfg.parent / "chains.h5", "r+") as f:    # as an earlier version wrote it
        f.attrs["moves_detail"] = "DEMove"
    given = []
    make = ensemble.make_moves
    monkeypatch.setattr(ensemble, "make_moves", lambda kind, mapper=None, laplace=None, complement=False: (
        given.append(laplace or complement or None), make(kind, mapper, laplace, complement))[1])
    post = sample(load_config(with_sampler(cfg, max_steps=60)), progress=False)
    assert given == [None]
    assert post.summary["moves"] == "DEMove"
    assert read_run(cfg.parent / "chains.h5").steps == 60


def test_de_plain_keeps_demove_alone_on_a_white_chain(tmp_path: Path) -> None:
    post = sample(load_config(_white(tmp_path, "p", moves="de-plain", max_steps=20)), progress=False)
    assert post.summary["moves"].startswith("DEMove") and "Laplace" not in post.summary["moves"]


ALPHA = {"E": {"prior": "uniform", "low": 100, "high": 20000},
         "G": {"prior": "uniform", "low": 0, "high": 50},
         "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 10000},
         "alpha": {"prior": "normal", "mean": 0.5, "sd": 0.05, "low": 0, "high": 1}}


def test_a_sampled_spectrum_exponent_makes_the_complement_move(tmp_path: Path) -> None:
    """Where the posterior is far from its linearization (the spectrum's exponent sampled) the
    Laplace move was accepted less often than DEMove: `de` makes the complement move there, and a
    run taken further continues the same chain."""
    cfg = write_case(tmp_path, "alpha", n=300, seed=5, parameters=ALPHA,
                     sampler={"max_steps": 20, "target_ess": 1e9, "checkpoint_every": 10})
    post = sample(load_config(cfg), progress=False)
    assert "alpha" in post.summary["parameters"]
    assert post.summary["moves"].startswith(COMPLEMENT), post.summary["moves"]
    a, b = taken_further_and_in_one_go(cfg, 35)
    assert a.chain.shape == b.chain.shape == (35, 32, 4)
    assert np.array_equal(a.chain, b.chain)


def test_too_few_walkers_for_the_complement_move_keep_demove_alone(tmp_path: Path) -> None:
    """Half of 12 walkers cannot give the complement move a covariance of 4 parameters."""
    cfg = write_case(tmp_path, "few", n=300, seed=5, parameters=ALPHA,
                     sampler={"max_steps": 20, "target_ess": 1e9, "walkers": 12})
    assert sample(load_config(cfg), progress=False).summary["moves"] == "DEMove"


def test_an_estimate_held_on_a_bound_makes_the_complement_move(tmp_path: Path) -> None:
    """G = 0 in the data: the fit puts G within 1 sd of its prior's bound, where the posterior is
    cut and the linearization is not; `de` makes the complement move (the white and the
    discrepancy likelihood alike)."""
    for name, extra in (("white", {}), ("disc", {"noise": "residuals", "discrepancy": "default",
                                                 "error": ("exp", 0.5, 20.0)})):
        cfg = write_case(tmp_path, name, n=300, seed=5, params={"E": 2854.0, "G": 0.0, "tau_max": 5.79},
                         sampler={"max_steps": 20, "target_ess": 1e9}, **extra)
        post = sample(load_config(cfg), progress=False)
        gn = post.summary["gauss_newton"]
        assert gn["estimate"]["G"] < gn["sd"]["G"], (name, gn["estimate"]["G"], gn["sd"]["G"])
        assert post.summary["moves"].startswith(COMPLEMENT), (name, post.summary["moves"])
        assert ("disc_amplitude" in post.summary["parameters"]) == (name == "disc")
