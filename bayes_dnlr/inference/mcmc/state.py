"""What the sampling loop hands over and resumes from: the ensemble's state, and where its
checkpoints go (``CheckpointSink``; runs/chains.py implements it with chains.h5)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


@dataclass
class SamplerState:
    """The ensemble state emcee needs to continue exactly: positions, log-probs, RNG state."""

    coords: np.ndarray              # (walkers, ndim) sampling coordinates
    log_prob: np.ndarray            # (walkers,)
    rng: tuple                      # numpy RandomState.get_state(): ('MT19937', key, pos, has_gauss, g)

    @staticmethod
    def rng_tuple(key: np.ndarray, pos: int, has_gauss: int, gauss: float) -> tuple:
        return ("MT19937", np.asarray(key, dtype=np.uint32), int(pos), int(has_gauss), float(gauss))


class CheckpointSink(Protocol):
    """Where the loop commits each block of steps with the state after its last step."""

    def append(self, coords: np.ndarray, log_prob: np.ndarray, accepted: np.ndarray,
               state: SamplerState, elapsed: float, n_evals: int) -> float:
        """Store the block (coords (m, walkers, ndim)); return the seconds the write took."""
        ...
