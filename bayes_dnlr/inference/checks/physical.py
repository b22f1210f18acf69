"""Checks of a posterior against the physics of the test (never against the model itself):

- a relaxation hold whose stress still falls at its end relaxes towards σ∞ below its last stress,
  so σ∞ above the last stress of a falling hold is impossible;
- a time constant far beyond the test's duration is not measured by it: its value (and what it
  trades off with) comes from the prior box. With a shift factor the modes relax in reduced time
  (dψ = dt/a, docs/theory.md): the duration that counts is the test's in reduced time, which a
  stress shift makes far longer than the clock's where the stress flows;
- the instantaneous modulus E is the slope of the stress at an infinite rate: the standards' chord
  at a finite rate (ISO 527-1, ASTM D638) is a lower bound of it. The chord is measured on noisy
  data: E lies below it only when E's 95 % quantile lies more than CHORD_Z of the chord's own
  noise sd below it (on a slow spectrum the true chord is within a few % of E, and a chord read
  through 0.3 MPa of noise over 0.2 % of strain has an sd of about 13 % of E).
"""

from __future__ import annotations

import numpy as np

SPAN_FACTOR = 10.0        # a time constant beyond this many test durations is not measured
FALLING_SAMPLES = 0.1     # the last tenth of the hold decides whether it still falls
CHORD_Z = 1.645           # one-sided 5 %: the chord's noise allowed for before E is below it


def hold_still_falling(time: np.ndarray, stress: np.ndarray, start: float) -> tuple[bool, float]:
    """(does the stress still fall over the last tenth of the hold, its last value)."""
    t, s = np.asarray(time, dtype=float), np.asarray(stress, dtype=float)
    hold = t >= start
    th, sh = t[hold], s[hold]
    if th.size < 10:
        return False, float(sh[-1]) if sh.size else float("nan")
    # the last tenth, and at least 3 samples: a line through 1 or 2 says nothing of the noise (a hold
    # of 10 samples left 1, and the fit failed)
    tail = slice(min(int(th.size * (1 - FALLING_SAMPLES)), th.size - 3), None)
    tt, st = th[tail], sh[tail]
    slope = np.polyfit(tt - tt.mean(), st, 1)[0]
    resid = st - np.polyval(np.polyfit(tt - tt.mean(), st, 1), tt - tt.mean())
    noise = float(np.std(resid)) or 1e-300
    falling = slope * float(tt[-1] - tt[0]) < -2.0 * noise
    return bool(falling), float(np.median(sh[-max(3, tt.size // 10):]))


def sigma_inf_check(draws: np.ndarray, last_stress: float, falling: bool) -> dict:
    """σ∞ against the last stress of a hold that still falls."""
    median = float(np.median(draws))
    ok = not falling or median <= last_stress
    return {"ok": ok, "sigma_inf_median": median, "last_stress": last_stress, "hold_falling": falling}


def reduced_duration(time: np.ndarray, log_shift: np.ndarray) -> float:
    """The duration of a test in reduced time, ∫ dt / a: ``log_shift`` is ln a at each sample, and
    a step takes the mean of its ends' logarithms (the kernel takes a at the step's middle)."""
    t, la = np.asarray(time, dtype=float), np.asarray(log_shift, dtype=float)
    return float(np.sum(np.diff(t) * np.exp(-0.5 * (la[1:] + la[:-1]))))


def time_constant_check(draws: np.ndarray, span: float, reduced: float | None = None) -> dict:
    """A time constant against the duration of the test: its duration in reduced time
    (``reduced``, where the model has a shift factor), else the clock's."""
    median = float(np.median(draws))
    limit = span if reduced is None else reduced
    out = {"ok": median <= SPAN_FACTOR * limit, "median": median, "test_duration": span}
    return out if reduced is None else out | {"reduced_duration": reduced}


def chord_check(draws: np.ndarray, chord: float, noise_sd: float = 0.0) -> dict:
    """E against the standards' chord modulus (a lower bound of E), measured with the noise sd
    ``noise_sd`` (the likelihood's noise through the chord's weights, inference/checks/start.py)."""
    q95 = float(np.quantile(draws, 0.95))
    out = {"ok": q95 >= chord - CHORD_Z * noise_sd, "E_q95": q95, "chord": chord}
    return out | {"chord_sd": noise_sd} if noise_sd > 0 else out
