"""A test's 90 % predictive band against its data, and the check of one quantity on it: does the
band hold the samples that carry that quantity's information as a calibrated band would?

The band comes from parameter draws of either source of E(t) (the posterior's, or the linearized
fit's Laplace draws, inference/modulus_estimate.py) pushed through the model (runs/bands.py makes
it). A quantity gᵀβ of the parameters draws its least-squares information from the samples by
the squared row of gᵀ(XᵀX)⁻¹Xᵀ (eq. 22): ``information_weights``. The band fails a quantity when
the weighted share it holds falls below ``predictive.band_floor`` (a one-sided 1 % binomial bound
over the weights' effective number of samples).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from bayes_dnlr.data.cycles import NO_TURNS, Turns
from bayes_dnlr.inference.checks.predictive import band_floor
from bayes_dnlr.inference.checks.start import StartCheck

INFORMATION_SHARE = 0.9      # the samples holding this share of a quantity's weight: where it is measured


@dataclass(frozen=True)
class Band:
    """One test's 90 % predictive band against its data on the window."""

    inside: np.ndarray          # which compared samples lie inside the band
    time: np.ndarray            # their times, s
    strain: np.ndarray          # the strain that drives the model there
    relaxation_start: float | None
    X: np.ndarray | None        # the Jacobian (eq. 22) at the draws' median, rows = samples
    free: list[str]             # its columns
    point: dict[str, float]     # the draws' median (fixed parameters at their values)
    start: StartCheck | None = None   # the data's ISO chord against the model curves'
    first_turn: float | None = None   # the time of the test's first peak in the window (cycles)
    turns: Turns = NO_TURNS           # the test's turning points (data/cycles.py) among the samples


def information_weights(X: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Each sample's share of the least-squares variance of the linear combination gᵀβ of the
    parameters (the columns of the Jacobian X, eq. 22): h = gᵀ(XᵀX)⁻¹Xᵀ, h_i² / Σ h². For g a unit
    vector this is one parameter's share (inference/checks/predictive.py ``weights``)."""
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    h = (np.asarray(g, dtype=float) / scale) @ np.linalg.pinv(X / scale)
    h2 = h**2
    total = h2.sum()
    return h2 / total if total > 0 else np.full(X.shape[0], 1.0 / X.shape[0])


def band_check(band: Band | None, g: np.ndarray, origin: float) -> dict[str, Any] | None:
    """The band's share of the samples that carry the information of gᵀβ (g: its gradient over
    ``band.free``), against the floor a calibrated band holds; with the times (from ``origin``)
    where that information lies, the test's first turning point and its hold, for the words. None
    without a Jacobian, or for a quantity the free parameters do not move."""
    if band is None or band.X is None or not np.any(g):
        return None
    w = information_weights(band.X, g)
    share = float(np.sum(w * band.inside))
    n_eff = float(1.0 / np.sum(w**2))
    floor = band_floor(n_eff)
    order = np.argsort(w)[::-1]
    top = order[: int(np.searchsorted(np.cumsum(w[order]), INFORMATION_SHARE)) + 1]
    return {"share": share, "n_eff": n_eff, "floor": floor, "ok": share >= floor,
            "information_times": [float(band.time[top].min()) - origin,
                                  float(band.time[top].max()) - origin],
            "first_turn": band.first_turn, "relaxation_start": band.relaxation_start,
            "window": [float(band.time[0]), float(band.time[-1])]}
