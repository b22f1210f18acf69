"""Blocks of walker states for the chain file's tests (chains.h5: round trip, crashes, full disk)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bayes_dnlr.inference.mcmc.state import SamplerState
from bayes_dnlr.runs.chains import ChainWriter

W, D = 8, 3


def phys(z: np.ndarray) -> np.ndarray:
    """Sampler space to physical: the third parameter is sampled as its log."""
    out = np.array(z, dtype=float, copy=True)
    out[..., 2] = np.exp(out[..., 2])
    return out


def walker_state(rs: np.random.RandomState, coords: np.ndarray) -> SamplerState:
    return SamplerState(coords.copy(), -coords.sum(axis=1), rs.get_state())


def make_blocks(seed: int, n_blocks: int, m: int = 10):
    """``n_blocks`` blocks of ``m`` steps: (chain, log_prob, accepted, state at the block's end)."""
    rng = np.random.default_rng(seed)
    rs = np.random.RandomState(seed)
    for _ in range(n_blocks):
        z = rng.normal(size=(m, W, D))
        rs.standard_normal(7)              # the sampler's RNG moves on
        yield z, -np.abs(z).sum(axis=2), rng.uniform(size=(m, W)) < 0.3, walker_state(rs, z[-1])


def create_writer(path: Path, seed: int = 0) -> ChainWriter:
    """A new chain file of W walkers in D dimensions, checkpoints every 10 steps."""
    rs = np.random.RandomState(seed)
    z0 = np.random.default_rng(seed + 100).normal(size=(W, D))
    meta = {"names": ["E", "G", "tau_max"], "log_space": [False, False, True], "walkers": W,
            "fingerprint": "abc", "fingerprint_parts": '{"data": "x"}', "config": "name: t\n"}
    return ChainWriter.create(path, meta, W, D, walker_state(rs, z0), phys, chunk_steps=10)
