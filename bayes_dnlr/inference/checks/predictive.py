"""Posterior predictive coverage: the share of the data inside the 90 % posterior predictive band,
overall and per segment of the test (the loading, the hold, five blocks of time).

The band at each sample is the model's posterior mean ± z90 sqrt(var_model + var_noise), with
var_model the spread of the model curve over the posterior draws and var_noise what the likelihood
puts around it (σ0², plus the model discrepancy's variance when there is one). A model that
describes the test, with its noise model, holds about 90 % of the points in every segment; a test
whose misfit the likelihood does not describe holds fewer, most visibly in the segment where the
model is wrong.

A misfit moves a parameter only through the samples that inform it: ``weights`` gives each sample's
share of E's least-squares variance (the squared row of (XᵀX)⁻¹Xᵀ, eq. 22), and ``weighted_share``
the coverage with those weights, so that a misfit where E has no weight (the large strains, say) is
told apart from one where it has.
"""

from __future__ import annotations

import math

import numpy as np

from bayes_dnlr.data.cycles import NO_TURNS, Turns
from bayes_dnlr.vocabulary import Z90

TIME_BLOCKS = 5
BAND_Z = 2.326      # one-sided 1 % quantile of the standard normal
CALIBRATED = 0.90   # the share of the data a calibrated 90 % band holds


def inside_band(y: np.ndarray, curves: np.ndarray, noise_var: np.ndarray | float) -> np.ndarray:
    """Which samples of ``y`` (n,) lie inside the 90 % predictive band of the model curves
    (draws, n) with the noise variance (n,) or scalar around them."""
    mean = curves.mean(axis=0)
    half = Z90 * np.sqrt(curves.var(axis=0) + noise_var)
    return np.abs(np.asarray(y, dtype=float) - mean) <= half


def branches(turns: Turns, size: int) -> dict[str, np.ndarray]:
    """Masks of the loading and unloading branches of a cyclic test ("loading 1", "unloading 1",
    ...) on its ``size`` compared samples, cut at its turning points (``turns``: the test's one
    rule, data/cycles.py, as positions among those samples; each turning point belongs to the
    branch it ends: a peak ends a loading, a valley an unloading); empty when the test never
    turns."""
    ends = sorted([(k, True) for k in turns.peaks] + [(k, False) for k in turns.valleys])
    if not ends:
        return {}
    # the branch after the last turning point runs the other way
    ends.append((size - 1, not ends[-1][1]))
    out: dict[str, np.ndarray] = {}
    count = {True: 0, False: 0}
    a = 0
    for k, rising in ends:
        if k + 1 <= a:
            continue
        count[rising] += 1
        mask = np.zeros(size, dtype=bool)
        mask[a:k + 1] = True
        out[f"{'loading' if rising else 'unloading'} {count[rising]}"] = mask
        a = k + 1
    return out


def segments(time: np.ndarray, relaxation_start: float | None,
             blocks: int = TIME_BLOCKS, turns: Turns = NO_TURNS) -> dict[str, np.ndarray]:
    """Masks of the test's segments on its compared samples: the loading and the hold (when there
    is one), the loading and unloading branches of cycles (``turns``: the positions of the test's
    turning points among the samples, see ``branches``), and ``blocks`` blocks of equal time."""
    t = np.asarray(time, dtype=float)
    out: dict[str, np.ndarray] = {}
    if relaxation_start is not None:
        out["loading"] = t < relaxation_start
        out["hold"] = t >= relaxation_start
    else:
        out.update(branches(turns, t.size))
    edges = np.linspace(t.min(), t.max(), blocks + 1)
    for b in range(blocks):
        hi = t <= edges[b + 1] if b == blocks - 1 else t < edges[b + 1]
        out[f"time block {b + 1}"] = (t >= edges[b]) & hi
    return out


def coverage(inside: np.ndarray, masks: dict[str, np.ndarray]) -> dict:
    """The shares inside the band: overall and per segment (with its number of points)."""
    seg = {name: {"share": float(inside[m].mean()) if m.any() else None, "points": int(m.sum())}
           for name, m in masks.items()}
    return {"overall": float(inside.mean()), "points": int(inside.size), "segments": seg}


def weights(X: np.ndarray, column: int) -> np.ndarray:
    """Each sample's share of the least-squares variance of the parameter in ``column`` of the
    Jacobian X (n, p): h = the row of (XᵀX)⁻¹Xᵀ, h_i² / Σ h². Columns are scaled first (E and the
    time constants differ by orders of magnitude)."""
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    pinv = np.linalg.pinv(X / scale)
    h2 = pinv[column] ** 2
    total = h2.sum()
    return h2 / total if total > 0 else np.full(X.shape[0], 1.0 / X.shape[0])


def weighted_share(inside: np.ndarray, w: np.ndarray) -> float:
    """The share of the points inside the band, each counted with its weight."""
    return float(np.sum(w * inside) / np.sum(w))


def band_floor(n_eff: float) -> float:
    """The weighted share below which a 90 % band is too narrow where the weights lie: a one-sided
    1 % binomial test of the share a calibrated band holds, over ``n_eff`` samples (the weights'
    effective number, 1/Σw²)."""
    return CALIBRATED - BAND_Z * math.sqrt(CALIBRATED * (1 - CALIBRATED) / max(n_eff, 1e-12))
