"""The block moves of ``sampler.moves: de-blocks`` keep the target distribution: known Gaussians
and a funnel (the spread of the model block grows with a hyperparameter) sampled to their moments."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.mcmc.blocks import BlockDEMove, BlockIndependenceMove, block_moves
from bayes_dnlr.inference.mcmc.emcee_import import load_emcee
from bayes_dnlr.inference.mcmc.ensemble import make_moves
from bayes_dnlr.inference.mcmc.stopping import _tau

NAMES = ["E", "G", "disc_amplitude", "disc_length"]


def _run(log_prob, start: np.ndarray, steps: int, seed: int = 3) -> np.ndarray:
    emcee = load_emcee()
    sampler = emcee.EnsembleSampler(start.shape[0], start.shape[1], log_prob, vectorize=True,
                                    moves=block_moves(NAMES))
    sampler._random.seed(seed)
    sampler.run_mcmc(start, steps, progress=False)
    return sampler.get_chain()


def _check_moments(chain: np.ndarray, mean: np.ndarray, cov: np.ndarray, burn: int = 200) -> None:
    kept = chain[burn:]
    flat = kept.reshape(-1, kept.shape[-1])
    ess = kept.shape[0] * kept.shape[1] / _tau(kept)
    se = np.sqrt(np.diag(cov) / ess)
    assert np.all(np.abs(flat.mean(axis=0) - mean) < 4.5 * se), (flat.mean(axis=0), mean, se)
    sd = np.sqrt(np.diag(cov))
    # the sd of a sample sd is about sd / sqrt(2 ess) (Gaussian), more in heavy tails
    assert np.all(np.abs(flat.std(axis=0) / sd - 1) < 6 / np.sqrt(2 * ess)), flat.std(axis=0) / sd
    corr = np.corrcoef(flat.T)
    assert np.all(np.abs(corr - cov / np.outer(sd, sd)) < 0.08)


def test_block_moves_keep_a_correlated_gaussian() -> None:
    rng = np.random.default_rng(0)
    a = rng.standard_normal((4, 4))
    cov = a @ a.T + 0.5 * np.eye(4)            # correlated within and across the two blocks
    mean = np.array([1.0, -2.0, 0.5, 3.0])
    prec = np.linalg.inv(cov)

    def log_prob(x):
        d = x - mean
        return -0.5 * np.einsum("ij,jk,ik->i", d, prec, d)

    start = mean + rng.standard_normal((32, 4)) @ np.linalg.cholesky(cov).T
    _check_moments(_run(log_prob, start, 3000), mean, cov)


def test_block_moves_keep_a_funnel() -> None:
    """h = (h1, h2) ~ N(0, I); the model block θ | h ~ N(0, exp(h1) I): E[θ] = 0,
    Var θ = E exp(h1) = exp(1/2); the carried scaling of the model block is exercised."""
    def log_prob(x):
        h1 = x[:, 2]
        th = x[:, :2]
        return -0.5 * np.sum(x[:, 2:] ** 2, axis=1) - 0.5 * np.sum(th**2, axis=1) * np.exp(-h1) - h1

    rng = np.random.default_rng(1)
    h = rng.standard_normal((32, 2))
    start = np.column_stack([np.exp(h[:, :1] / 2) * rng.standard_normal((32, 2)), h])
    chain = _run(log_prob, start, 4000)
    mean = np.zeros(4)
    cov = np.diag([np.exp(0.5), np.exp(0.5), 1.0, 1.0])
    kept = chain[200:]
    flat = kept.reshape(-1, 4)
    ess = kept.shape[0] * kept.shape[1] / _tau(kept)
    assert np.all(np.abs(flat.mean(axis=0) - mean) < 4.5 * np.sqrt(np.diag(cov) / ess))
    assert np.all(np.abs(flat.var(axis=0) / np.diag(cov) - 1) < 0.12), flat.var(axis=0) / np.diag(cov)


def test_moves_touch_their_block_only() -> None:
    rng = np.random.RandomState(4)
    s = rng.randn(16, 4)
    c = [rng.randn(16, 4)]
    de = BlockDEMove([0, 1])
    de.setup(s)
    q, f = de.get_proposal(s, c, rng)
    assert np.array_equal(q[:, 2:], s[:, 2:]) and not np.allclose(q[:, :2], s[:, :2])
    assert np.all(f == 0)
    q, f = BlockIndependenceMove([2, 3]).get_proposal(s, c, rng)
    assert np.array_equal(q[:, :2], s[:, :2]) and not np.allclose(q[:, 2:], s[:, 2:])
    assert np.all(np.isfinite(f)) and np.any(f != 0)


def test_de_blocks_without_hyperparameters_is_plain_de() -> None:
    moves = make_moves("de-blocks", ["E", "G", "tau_max"])
    assert len(moves) == 1 and type(moves[0][0]).__name__ == "DEMove"
    kinds = {type(m).__name__ for m, _ in make_moves("de-blocks", ["E", "G", "sigma0",
                                                                    "disc_amplitude[t1]",
                                                                    "disc_length[t1]"])}
    assert kinds == {"BlockDEMove", "BlockIndependenceMove"}


@pytest.mark.parametrize("kind", ["de", "de-snooker", "stretch"])
def test_other_moves_ignore_the_names(kind: str) -> None:
    assert make_moves(kind, NAMES) is not None
