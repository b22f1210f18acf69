"""Where a test resolves E(t), the relaxation modulus of the identified model (model/modulus.py),
and at which times it is reported.

A constant-rate loading's slope at strain ε is close to E(ε/ε̇): the data measure E(t) from the time
a few sampling steps into the first loading to the end of the window. E itself, E(t → 0), lies
before that: the spectrum's fast end, which the data never see, carries it there (eq. 12-14).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

LINEAR_SHIFT = 0.5       # a_σ where the linear range ends: the stress has sped every mode up 2×
X_LINEAR = 2.177318      # x/sinh x = LINEAR_SHIFT: that stress over sigma_s
RESOLVE_STEPS = 2        # E(t) is measured from this many sampling steps into the first loading
NICE_STEPS = (1.0, 2.0, 5.0)   # default times are rounded up to 1-2-5 values, so that tests of
#                                similar sampling share them


@dataclass(frozen=True)
class ResolvedWindow:
    """The times (s after the loading began) over which a test measures E(t)."""

    shortest: float          # RESOLVE_STEPS sampling steps into the first loading
    longest: float           # the end of the window, from the loading's start
    origin: float            # the time (file clock) the loading began
    step: float              # the median sampling step at the loading's start
    how: str                 # how the shortest time was found, for a person

    def contains(self, t: float) -> bool:
        return self.shortest * (1 - 1e-9) <= t <= self.longest * (1 + 1e-9)


def nice_time(t: float) -> float:
    """The smallest 1-2-5 value (…, 0.5, 1, 2, 5, 10, …) at or above ``t`` (> 0)."""
    if not (t > 0 and math.isfinite(t)):
        raise ValueError(f"a time must be a positive number, got {t}")
    decade = 10.0 ** math.floor(math.log10(t))
    for m in (*NICE_STEPS, 10.0):
        if m * decade >= t * (1 - 1e-12):
            return float(f"{m * decade:.12g}")
    return 10.0 * decade


def resolved_window(time: np.ndarray, strain: np.ndarray, window: np.ndarray,
                    strain_rate: float, unmeasured_start: bool = False) -> ResolvedWindow:
    """Where a test resolves E(t): from RESOLVE_STEPS sampling steps into its first loading to the
    end of its window. ``time``, ``strain`` (Hencky) and ``window`` are the test's samples (the
    model-only samples of an unloaded start included, never in the window).

    The loading began where the strain started to rise: at the first sample when the test starts
    unloaded, earlier when the file starts at a strain already reached (a cropped toe): then at
    the first sample's strain over the loading's rate before it. Where that first part of the
    loading was not measured (cropped, or ``unmeasured_start``: a model-only unloaded start put
    before the first sample), what the model assumed for it still weighs on E(t) for as long
    again: the shortest resolved time is then at least twice the first sample's delay.
    """
    t = np.asarray(time, dtype=float)
    e = np.asarray(strain, dtype=float)
    rows = np.flatnonzero(np.asarray(window, dtype=bool))
    if rows.size < 2:
        raise ValueError("the window holds fewer than two samples")
    first = int(rows[0])
    steps = np.diff(t[first:first + 21])
    step = float(np.median(steps[steps > 0])) if np.any(steps > 0) else math.nan
    rate = float(strain_rate)
    how = f"{RESOLVE_STEPS} sampling steps of {step:.3g} s into the loading"
    origin = float(t[0])
    if rate > 0 and float(e[0]) > RESOLVE_STEPS * rate * step:
        # the file starts with a strain that a few steps of loading would not reach (a cropped
        # toe): the loading began before the first sample, at its rate
        origin -= float(e[0]) / rate
        unmeasured_start = True
        how += (f"; the first sample already has strain {float(e[0]):.3g}, so the loading began "
                f"{float(e[0]) / rate:.3g} s before it, at its rate {rate:.3g} 1/s")
    elif first > 0 and t[first] > origin:
        how += f", which began {float(t[first]) - origin:.3g} s before the window's first sample"
    k = min(first + RESOLVE_STEPS, int(rows[-1]))
    shortest = float(t[k]) - origin
    delay = float(t[first]) - origin
    if unmeasured_start and 2 * delay > shortest:
        shortest = 2 * delay
        how += (f"; the loading's first {delay:.3g} s were not measured, and what the model assumes "
                f"for them weighs on E(t) for as long again: from {shortest:.3g} s")
    longest = float(t[int(rows[-1])]) - origin
    return ResolvedWindow(shortest=shortest, longest=longest, origin=origin, step=step, how=how)


def default_times(w: ResolvedWindow) -> tuple[list[float], str]:
    """The default times of E(t) and why: the shortest resolved time, rounded up to 1-2-5."""
    t = nice_time(w.shortest)
    if t > w.longest:
        t = w.shortest
    return [t], (f"the shortest time the test resolves, {w.shortest:.3g} s ({w.how}), rounded up "
                 f"to {t:g} s")


def test_window(test) -> ResolvedWindow:
    """``resolved_window`` of a ``bayes_dnlr.data.TestData``."""
    return resolved_window(test.time, test.strain_input, test.window, test.strain_rate,
                           unmeasured_start=int(getattr(test, "virtual_start", 0)) > 0)


def times_for(cfg, test) -> tuple[list[float], str, ResolvedWindow]:
    """The times of E(t) for a test: ``output.modulus_at`` when the config gives it, else the
    default (``default_times``); with why, and the window the test resolves."""
    w = test_window(test)
    given = cfg.output.modulus_at
    if given:
        return list(given), "output.modulus_at", w
    times, why = default_times(w)
    return times, why, w


def linear_range(w: ResolvedWindow, time: np.ndarray, stress: np.ndarray, window: np.ndarray,
                 sigma_s: float, whose: str) -> ResolvedWindow:
    """The resolved window ended where the test leaves its linear range: where the stress first
    reaches X_LINEAR × sigma_s, at which the Eyring shift x/sinh x (x = |σ|/sigma_s) has sped every
    mode up by 1/LINEAR_SHIFT. Beyond, E(t), the σ → 0 relaxation modulus, is no longer what the
    curve measures: the model reaches it through its stress shift (an extrapolation in stress), or
    a stress-blind model reads the curve's nonlinearity as relaxation. ``whose``: where sigma_s
    comes from, for a person."""
    if not (math.isfinite(sigma_s) and sigma_s > 0):
        return w
    rows = np.flatnonzero(np.asarray(window, dtype=bool))
    t = np.asarray(time, dtype=float)[rows]
    s = np.abs(np.asarray(stress, dtype=float)[rows])
    limit = X_LINEAR * sigma_s
    past = np.flatnonzero(s >= limit)
    if not past.size:
        return w
    end = float(t[past[0]]) - w.origin
    if end >= w.longest:
        return w
    how = (f"; the linear range ends at t = {end:.3g} s, where the stress reaches {limit:.3g} MPa "
           f"({X_LINEAR:.2f} sigma_s, sigma_s = {sigma_s:.3g} MPa, {whose}): there the stress has "
           f"sped the relaxation up {1 / LINEAR_SHIFT:g}×")
    if end <= w.shortest:
        how += ", before the test resolves E(t)"
    return replace(w, longest=max(end, w.shortest), how=w.how + how)
