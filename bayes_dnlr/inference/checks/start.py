"""The start of a curve against the model: the ISO 527-1 chord of the data beside the chord of the
model's own curves, computed the same way (standards.py).

The chord is the slope of the nominal curve between 0.05 % and 0.25 % strain: on a loading from
rest, the mean of E(t) over the times the test takes to get there. It is measured on the data with
no model at all, so a model whose curves give another chord does not follow the start of this
test (a preload, a loading history the model misses), and E(t) at those times is not what the data
say.

A toe (slack, seating: the strain reads ahead of the specimen's at first) the model can fit all
the same, as a softer start: its curves follow the data's chord, and E(t) comes out low. What
gives a toe away is the curve's shape: a material that only relaxes gives a concave start under
a constant-rate loading (its slope E(t) falls), a toe a convex one (the slope rises as the slack is
taken up). So the start check also runs the toe test (toe.py): the largest rise of the start's
slope over its first one, beside the same rise of the model's curve (a loading that speeds up
stiffens both), against the point that a straight start's noise passes 0.5 % of the time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.inference.checks.toe import NO_TEST, Toe, toe_test
from bayes_dnlr.standards import ISO_STRAINS, iso527_1_modulus

START_Z = 2.576      # two-sided 1 % quantile of the standard normal: the data's chord this many sd
#                      from the model's is a start the model does not follow


@dataclass(frozen=True)
class StartCheck:
    """The data's chord, the model's (mean and sd over the posterior draws), the chord's own noise
    sd, and how far apart they are."""

    data: float
    model: float
    model_sd: float
    noise_sd: float
    z: float
    times: tuple[float, float]      # s after the loading began: where the chord's strains lie
    toe_test: Toe = NO_TEST         # the largest rise of the start's slope, and its threshold
    standard: str = "ISO 527-1"     # whose chord: ISO 527-1's, or ASTM D638's on a cropped start
    compensated: bool = False       # the toe was compensated (data.toe) before this start

    @property
    def convexity_z(self) -> float:
        """The largest rise of the start's slope, in sd of the rise (> 0: the slope rises)."""
        return self.toe_test.z

    @property
    def follows(self) -> bool:
        """The model's chord agrees with the data's."""
        return abs(self.z) <= START_Z

    @property
    def toe(self) -> bool:
        """The data's start is convex beyond its noise: a toe (toe.py)."""
        return self.toe_test.found

    @property
    def ok(self) -> bool:
        return self.follows and not self.toe

    def to_dict(self) -> dict[str, float | bool | list[float]]:
        return {"data_chord": self.data, "model_chord": self.model, "model_sd": self.model_sd,
                "noise_sd": self.noise_sd, "z": self.z, "times": list(self.times),
                "convexity_z": self.convexity_z, "toe_threshold": self.toe_test.threshold,
                "toe_p": self.toe_test.p, "toe": self.toe, "compensated": self.compensated,
                "ok": self.ok, "standard": self.standard}


@dataclass(frozen=True)
class Noise:
    """What the likelihood puts around the model at the samples: white noise σ0² and, with model
    error, the discrepancy's Gaussian process (its amplitude, length, kernel and axis values)."""

    sigma0_sq: float
    amplitude: float = 0.0
    length: float = 1.0
    kernel: str = "exp"
    axis: np.ndarray | None = None      # the discrepancy's axis at the samples (time or strain)
    start: float | None = None          # where the process is pinned to zero (None: stationary)

    def covariance(self, rows: np.ndarray) -> np.ndarray:
        cov = self.sigma0_sq * np.eye(rows.size)
        if self.amplitude > 0 and self.axis is not None:
            from bayes_dnlr.inference.discrepancy.gp import covariance

            cov = cov + covariance(self.axis[rows], self.amplitude, self.length, self.kernel,
                                   start=self.start)
        return cov


def chord_weights(nominal_strain: np.ndarray, method: str) -> tuple[np.ndarray, np.ndarray]:
    """The chord as a linear function of the stress samples: (the rows it uses, their weights),
    the least-squares slope's between the two strains or the two-point chord's (first passage,
    linear interpolation), as standards.iso527_1_modulus computes it."""
    e1, e2 = ISO_STRAINS
    e = np.asarray(nominal_strain, dtype=float)
    past = np.flatnonzero(e > 2 * e2)
    end = int(past[0]) if past.size else e.size
    if method != "chord":
        rows = np.flatnonzero((e[:end] >= e1) & (e[:end] <= e2))
        d = e[rows] - e[rows].mean()
        return rows, d / np.sum(d * d)
    weights: dict[int, float] = {}
    for level, sign in ((e1, -1.0), (e2, 1.0)):
        i = int(np.flatnonzero(e >= level)[0])
        if i == 0:
            weights[0] = weights.get(0, 0.0) + sign / (e2 - e1)
            continue
        f = (level - e[i - 1]) / (e[i] - e[i - 1])
        weights[i - 1] = weights.get(i - 1, 0.0) + sign * (1 - f) / (e2 - e1)
        weights[i] = weights.get(i, 0.0) + sign * f / (e2 - e1)
    rows = np.array(sorted(weights))
    return rows, np.array([weights[i] for i in rows])


def chord_noise_sd(nominal_strain: np.ndarray, noise: Noise, method: str) -> float:
    """The sd of the chord that the likelihood's noise (white, and the discrepancy's process) gives:
    cᵀ K c for the chord's weights c."""
    rows, c = chord_weights(nominal_strain, method)
    if rows.size == 0:
        return math.inf
    return float(math.sqrt(max(c @ noise.covariance(rows) @ c, 0.0)))


def centre_and_spread(chords: np.ndarray) -> tuple[float, float]:
    """The model's chord over the draws: median and 1.4826 × median absolute deviation, the mean
    and sd of a normal posterior, which a few draws far out do not inflate. A parameter the data do
    not pin (sigma_s of a stress shift the test does not reach), mapped onto the model-error
    covariance, piles draws at its prior box's far edges; their chords, hundreds of MPa off, made
    the mean's sd so wide that the check passed whatever the data said."""
    x = np.asarray(chords, dtype=float)
    centre = float(np.median(x))
    return centre, float(1.4826 * np.median(np.abs(x - centre)))


def start_check(nominal_strain: np.ndarray, nominal_stress: np.ndarray,
                model_nominal_stress: np.ndarray, noise: Noise, time: np.ndarray,
                origin: float, compensated: bool = False) -> StartCheck | None:
    """The check on the loading samples of a test (nominal strain and stress, the model's nominal
    stress of each posterior draw (draws, n) on the same samples, their times and the time the
    loading began); ``noise``: the likelihood's noise on those samples (the stresses the chord is
    computed from are nominal, the noise is on the observable: the two differ by a factor within
    0.25 % of 1 at these strains); ``compensated``: the test's toe was compensated (data.toe), so
    that a toe found here is what the compensation left. None where the data give no chord (the
    curve starts past 0.05 %, or never reaches 0.25 %)."""
    data = iso527_1_modulus(nominal_strain, nominal_stress)
    if data.modulus is None:
        return _astm_check(nominal_strain, nominal_stress, model_nominal_stress, noise, time, origin,
                           compensated)
    chords = np.array([iso527_1_modulus(nominal_strain, m).modulus for m in model_nominal_stress],
                      dtype=float)
    chords = chords[np.isfinite(chords)]
    if chords.size < 2:
        return None
    method = "chord" if data.method == "chord" else "regression"
    noise_sd = chord_noise_sd(nominal_strain, noise, method)
    model, spread = centre_and_spread(chords)
    z = (float(data.modulus) - model) / math.hypot(spread, noise_sd)
    return StartCheck(float(data.modulus), model, spread, noise_sd, float(z),
                      chord_times(nominal_strain, time, origin),
                      toe_test(nominal_strain, nominal_stress, np.median(model_nominal_stress, axis=0)),
                      compensated=compensated)


def _astm_check(nominal_strain: np.ndarray, nominal_stress: np.ndarray,
                model_nominal_stress: np.ndarray, noise: Noise, time: np.ndarray,
                origin: float, compensated: bool) -> StartCheck | None:
    """Where the curve starts past 0.05 % (a cropped toe), the ASTM D638 window instead: the
    least-squares slope of the data over the samples of its steepest window beside the model
    curves' over the same samples (the data's choice of window biases its slope up by about its
    noise sd, which the test's noise term holds)."""
    from bayes_dnlr.standards import astm_d638_modulus

    data = astm_d638_modulus(nominal_strain, nominal_stress)
    if data.modulus is None or data.strain_range is None:
        return None
    e = np.asarray(nominal_strain, dtype=float)
    lo, hi = data.strain_range
    rows = np.flatnonzero((e >= lo) & (e <= hi))
    if rows.size < 2:
        return None
    d = e[rows] - e[rows].mean()
    c = d / np.sum(d * d)
    models = np.asarray(model_nominal_stress, dtype=float)[:, rows] @ c
    noise_sd = float(math.sqrt(max(c @ noise.covariance(rows) @ c, 0.0)))
    model, spread = centre_and_spread(models)
    z = (float(data.modulus) - model) / math.hypot(spread, noise_sd)
    t = np.asarray(time, dtype=float)
    return StartCheck(float(data.modulus), model, spread, noise_sd, float(z),
                      (float(t[rows[0]] - origin), float(t[rows[-1]] - origin)),
                      toe_test(nominal_strain, nominal_stress, np.median(model_nominal_stress, axis=0)),
                      "ASTM D638", compensated)


def chord_times(nominal_strain: np.ndarray, time: np.ndarray, origin: float) -> tuple[float, float]:
    """When the loading passes the chord's two strains, in s after it began (first passage)."""
    e = np.asarray(nominal_strain, dtype=float)
    t = np.asarray(time, dtype=float)
    past = np.flatnonzero(e > 2 * ISO_STRAINS[1])
    end = int(past[0]) + 1 if past.size else e.size
    rising = np.maximum.accumulate(e[:end])
    return tuple(float(np.interp(level, rising, t[:end]) - origin) for level in ISO_STRAINS)

