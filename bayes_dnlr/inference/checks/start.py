"""The start of a curve against the model: the ISO 527-1 chord of the data beside the chord of the
model's own curves, computed the same way (standards.py).

The chord is the slope of the nominal curve between 0.05 % and 0.25 % strain: on a loading from
rest, the mean of E(t) over the times the test takes to get there. It is measured on the data with
no model at all, so a model whose curves give another chord does not follow the start of this
test (a toe, a preload, a loading history the model misses), and E(t) at those times is not what
the data say.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

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

    @property
    def ok(self) -> bool:
        return abs(self.z) <= START_Z

    def to_dict(self) -> dict[str, float | bool | list[float]]:
        return {"data_chord": self.data, "model_chord": self.model, "model_sd": self.model_sd,
                "noise_sd": self.noise_sd, "z": self.z, "times": list(self.times), "ok": self.ok}


def chord_noise_sd(nominal_strain: np.ndarray, noise_var: float, method: str) -> float:
    """The sd of the chord that white noise of variance ``noise_var`` on the stress gives: the
    least-squares slope's over the samples between the two strains, or the two-point chord's."""
    e1, e2 = ISO_STRAINS
    e = np.asarray(nominal_strain, dtype=float)
    if method == "chord":
        return math.sqrt(2.0 * noise_var) / (e2 - e1)
    inside = e[(e >= e1) & (e <= e2)]
    spread = float(np.sum((inside - inside.mean()) ** 2)) if inside.size > 1 else 0.0
    return math.sqrt(noise_var / spread) if spread > 0 else math.inf


def start_check(nominal_strain: np.ndarray, nominal_stress: np.ndarray,
                model_nominal_stress: np.ndarray, noise_var: float, time: np.ndarray,
                origin: float) -> StartCheck | None:
    """The check on the loading samples of a test (nominal strain and stress, the model's nominal
    stress of each posterior draw (draws, n) on the same samples, their times and the time the
    loading began). None where the data give no chord (the curve starts past 0.05 %, or never
    reaches 0.25 %)."""
    data = iso527_1_modulus(nominal_strain, nominal_stress)
    if data.modulus is None:
        return None
    chords = np.array([iso527_1_modulus(nominal_strain, m).modulus for m in model_nominal_stress],
                      dtype=float)
    chords = chords[np.isfinite(chords)]
    if chords.size < 2:
        return None
    method = "chord" if data.method == "chord" else "regression"
    noise = chord_noise_sd(nominal_strain, noise_var, method)
    model, spread = float(chords.mean()), float(chords.std(ddof=1))
    z = (float(data.modulus) - model) / math.hypot(spread, noise)
    return StartCheck(float(data.modulus), model, spread, noise, float(z),
                      chord_times(nominal_strain, time, origin))


def chord_times(nominal_strain: np.ndarray, time: np.ndarray, origin: float) -> tuple[float, float]:
    """When the loading passes the chord's two strains, in s after it began (first passage)."""
    e = np.asarray(nominal_strain, dtype=float)
    t = np.asarray(time, dtype=float)
    past = np.flatnonzero(e > 2 * ISO_STRAINS[1])
    end = int(past[0]) + 1 if past.size else e.size
    rising = np.maximum.accumulate(e[:end])
    return tuple(float(np.interp(level, rising, t[:end]) - origin) for level in ISO_STRAINS)
