"""The toe test: does the slope of a curve's start rise beyond its noise?

A material that only relaxes gives a concave start under a constant-rate loading (its slope E(t)
falls); a toe (slack, seating: the strain reads ahead of the specimen's at first) a convex one, the
slope rising as the slack is taken up. The test cuts the start, up to TOE_STRAIN, into windows of
k consecutive samples (k = n/8, half overlapping), fits each a least-squares slope against the
measured nominal strain, and compares every window's slope with the first one's:

    z_j = (b_j - b_0 - max(m_j - m_0, 0)) / (s ‖c_j - c_0‖),    T = max_j z_j,

with m the same slopes of the model's curve (driven by the same strain: a loading that speeds up
stiffens both), c_j the window's slope weights (b_j = c_j·y) and s the scatter of the stress about
parabolas on consecutive blocks of k samples, pooled. That scatter holds the stress's noise and
the strain's (a DIC strain scatters the points along the curve as much as the force does), so the
test needs no noise model; the likelihood's σ0 holds only the first.

T is the largest of about 14 correlated rises, not one normal deviate. On a straight start with
white noise the vector z is, to the precision that the pooled scatter is independent of the
slopes, multivariate t with ν = Σ(block size − 3) degrees of freedom and the correlation
R = (c_i − c_0)·(c_j − c_0) / (‖c_i − c_0‖ ‖c_j − c_0‖), which depend on the samples' strains
only. The threshold is the 1 − TOE_ALPHA point of max z under that law, computed for the test's own
samples by NULL_DRAWS seeded draws; docs/thresholds.md ("The toe test") gives the measured false
alarms on clean starts (simulated in full, not through this law) and the power on toes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

TOE_STRAIN = 0.01      # the test looks at the start up to this nominal strain (four times the
#                        chord's upper strain: a seating slack of a few 0.1 %)
TOE_ALPHA = 0.005      # the share of clean straight starts called a toe (one-sided, the half of
#                        the two-sided 1 % the start check's chord uses)
MIN_SAMPLES = 8        # fewer samples up to TOE_STRAIN: no test
RESOLUTION = 1e-9      # the scatter is at least this share of the largest stress (rounding)
NULL_DRAWS = 50_000    # draws of the null law per design: the threshold's Monte Carlo sd is about
#                        0.02, which moves the false-alarm rate by 0.03 % (docs/thresholds.md)
NULL_SEED = 20261202


@dataclass(frozen=True)
class Toe:
    """The toe test of a curve's start: the largest standardized rise of its slope ``z``, the
    threshold it is compared with (the 1 − TOE_ALPHA point of that largest rise on a straight start
    with white noise, for these samples), the chance ``p`` that such a start rises as far, and how
    many rises were compared. NaN throughout when the start has too few samples."""

    z: float
    threshold: float
    p: float
    rises: int

    @property
    def found(self) -> bool:
        """The slope rises beyond what the noise of a straight start gives: a toe."""
        return self.z > self.threshold


NO_TEST = Toe(math.nan, math.nan, math.nan, 0)


def _windows(e: np.ndarray) -> tuple[int, np.ndarray]:
    """(k, the slope weights (windows, n)): c·y is the least-squares slope of y against e over the
    window's k samples; windows half overlapping, those whose strain does not move left out."""
    n = e.size
    k = max(4, n // 8)
    rows = []
    for a in range(0, n - k + 1, max(1, k // 2)):
        d = e[a:a + k] - e[a:a + k].mean()
        ss = float(d @ d)
        if ss > 0:
            c = np.zeros(n)
            c[a:a + k] = d / ss
            rows.append(c)
    return k, np.array(rows).reshape(len(rows), n)


def _scatter(e: np.ndarray, y: np.ndarray, k: int) -> tuple[float, int]:
    """(the pooled sd of y about a parabola of e on consecutive blocks of about k samples, its
    degrees of freedom): the noise, without the bend of a relaxing curve or a toe, which a straight
    line would count as scatter."""
    rss, dof = 0.0, 0
    for block in np.array_split(np.arange(e.size), max(1, e.size // k)):
        u = e[block] - e[block].mean()
        X = np.column_stack((np.ones(block.size), u, u * u))
        coef, *_ = np.linalg.lstsq(X, y[block], rcond=None)
        r = y[block] - X @ coef
        rss += float(r @ r)
        dof += block.size - 3
    return (math.sqrt(rss / dof) if dof > 0 else math.nan), dof


def toe_test(nominal_strain: np.ndarray, nominal_stress: np.ndarray,
             model: np.ndarray | None = None) -> Toe:
    """The toe test (module doc) of the first passage of the nominal curve up to TOE_STRAIN;
    ``model``: the model's nominal stress on the same samples (its rise is taken off)."""
    e = np.asarray(nominal_strain, dtype=float)
    y = np.asarray(nominal_stress, dtype=float)
    past = np.flatnonzero(e > TOE_STRAIN)
    n = int(past[0]) if past.size else e.size
    if n < MIN_SAMPLES:
        return NO_TEST
    e, y = e[:n], y[:n]
    k, c = _windows(e)
    if c.shape[0] < 2:
        return NO_TEST
    d = c[1:] - c[0]
    norms = np.linalg.norm(d, axis=1)
    s, dof = _scatter(e, y, k)
    # a curve without noise (computed, not measured) scatters by its rounding only: no rise of it
    # is told from that
    s = max(s, RESOLUTION * float(np.max(np.abs(y))))
    if not (s > 0 and dof > 0):
        return NO_TEST
    rise = d @ y
    if model is not None:
        # the data's slope must rise beyond the model's where the model's rises too (a model whose
        # slope falls faster than the data's is another misfit, not a toe)
        rise = rise - np.maximum(d @ np.asarray(model, dtype=float)[:n], 0.0)
    z = float(np.max(rise / (s * norms)))
    corr = (d @ d.T) / np.outer(norms, norms)
    # the law depends on the correlations smoothly: rounded, designs that differ by a noisy
    # strain's scatter share one computation
    null = _null_maxima(tuple(np.round(corr, 2).ravel()), corr.shape[0], dof)
    threshold = float(null[int(math.ceil((1 - TOE_ALPHA) * null.size)) - 1])
    p = float(null.size - np.searchsorted(null, z, side="left")) / null.size
    return Toe(z, threshold, p, int(d.shape[0]))


@lru_cache(maxsize=16)
def _null_maxima(corr: tuple[float, ...], m: int, dof: int) -> np.ndarray:
    """NULL_DRAWS draws, sorted, of the largest of m standardized rises on a straight start with
    white noise: a multivariate t with correlation ``corr`` (flattened, m × m) and ``dof`` degrees
    of freedom (seeded: the same design gives the same threshold)."""
    r = np.asarray(corr, dtype=float).reshape(m, m)
    w, v = np.linalg.eigh(r)
    root = v * np.sqrt(np.clip(w, 0.0, None))          # r = root rootᵀ, also when r is singular
    out = (root @ _normal_draws(m)).max(axis=0) / _scale_draws(dof)
    out.sort()
    return out


@lru_cache(maxsize=4)       # 0.4 MB per rise: a run sees one or two numbers of rises
def _normal_draws(m: int) -> np.ndarray:
    """NULL_DRAWS independent standard normal m-vectors, one per column (seeded, shared by the
    designs of m rises)."""
    return np.random.default_rng([NULL_SEED, m]).standard_normal((m, NULL_DRAWS))


@lru_cache(maxsize=8)
def _scale_draws(dof: int) -> np.ndarray:
    """NULL_DRAWS draws of sqrt(χ²_dof / dof): the pooled scatter over the noise sd."""
    return np.sqrt(np.random.default_rng([NULL_SEED, 0, dof]).chisquare(dof, NULL_DRAWS) / dof)
