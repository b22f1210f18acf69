"""The physical checks and the prior-bound check at their limits (inference/checks/physical.py,
bounds.py): each rule on both sides of its threshold, with the numbers it reports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayes_dnlr.inference.checks import bounds, physical


def test_e_at_the_chord_is_plausible_and_below_it_is_not() -> None:
    assert physical.chord_check(np.full(50, 1000.0), 1000.0) == {"ok": True, "E_q95": 1000.0, "chord": 1000.0}
    assert not physical.chord_check(np.full(50, 999.0), 1000.0)["ok"]


def test_sigma_inf_at_the_last_stress_of_a_falling_hold_is_plausible() -> None:
    assert physical.sigma_inf_check(np.full(9, 7.5), 7.5, True) == {
        "ok": True, "sigma_inf_median": 7.5, "last_stress": 7.5, "hold_falling": True}
    assert not physical.sigma_inf_check(np.full(9, 7.6), 7.5, True)["ok"]
    assert physical.sigma_inf_check(np.full(9, 7.6), 7.5, False)["ok"]       # a hold that has settled


def test_a_time_constant_up_to_ten_test_durations_is_measured() -> None:
    assert physical.time_constant_check(np.full(5, 1000.0), 100.0) == {
        "ok": True, "median": 1000.0, "test_duration": 100.0}
    assert not physical.time_constant_check(np.full(5, 1001.0), 100.0)["ok"]


def _hold(n: int, drop_in_noise: float, start: float = 1000.0) -> tuple[np.ndarray, np.ndarray]:
    """A hold of n samples from ``start`` whose last tenth falls by ``drop_in_noise`` times the sd
    of an alternating ±0.01 MPa noise."""
    t = start + np.arange(n, dtype=float)
    tail = int(n * (1 - physical.FALLING_SAMPLES))
    noise = 0.01 * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    s = 50.0 + noise
    span = t[-1] - t[tail]
    s[tail:] -= drop_in_noise * 0.01 * (t[tail:] - t[tail]) / span
    return t, s


def test_a_hold_still_falls_when_its_last_tenth_drops_by_more_than_twice_its_noise() -> None:
    t, s = _hold(100, 1.5)
    falling, last = physical.hold_still_falling(t, s, 1000.0)
    assert falling
    assert last == pytest.approx(float(np.median(s[-3:])), rel=1e-12)   # the last 3 samples
    assert not physical.hold_still_falling(*_hold(100, 1.0), 1000.0)[0]
    # a noiseless hold that falls at all still falls
    t = 1000.0 + np.arange(100.0)
    s = 50.0 - 1e-6 * (t - 1000.0)
    assert physical.hold_still_falling(t, s, 1000.0)[0]


def test_a_hold_of_fewer_than_ten_samples_is_not_judged_and_one_of_ten_is() -> None:
    t = 990.0 + np.arange(20.0)
    s = 60.0 - 0.5 * (t - 990.0)                     # falls fast: judged when 10 samples hold it
    assert physical.hold_still_falling(t, s, 1000.0) == (True, 51.0)   # the median of the last 3
    falling, last = physical.hold_still_falling(t, s, 1001.0)     # 9 samples from 1001 s on
    assert not falling and last == s[-1]
    assert math.isnan(physical.hold_still_falling(t, s, 2000.0)[1])


def test_a_bound_is_a_physical_limit_only_at_zero_from_below() -> None:
    assert bounds.physical_limit("low", 0.0)
    assert not bounds.physical_limit("high", 0.0) and not bounds.physical_limit("low", 1.0)


def test_draws_piled_against_a_bound_within_one_percent_of_the_prior_width() -> None:
    assert bounds.piled_side(np.full(100, 198.0), 100.0, 200.0, False) is None   # 2 % from the top
    assert bounds.piled_side(np.full(100, 199.5), 100.0, 200.0, False) == "high"
    assert bounds.piled_side(np.full(100, 100.5), 100.0, 200.0, False) == "low"
    assert bounds.piled_side(np.full(100, 5.0), -math.inf, 10.0, False) is None  # no finite box
    # in log space: within 1 % of the log width (here log(1e4) = 9.21: 0.092)
    assert bounds.piled_side(np.full(100, 0.5), 0.01, 100.0, True) is None
    assert bounds.piled_side(np.full(100, 0.0105), 0.01, 100.0, True) == "low"
    assert bounds.piled_side(np.full(100, 99.0), 0.01, 100.0, True) == "high"
    assert bounds.piled_side(np.full(100, 0.5), 0.0, 100.0, True) is None       # no log width
    assert bounds.piled_side(np.full(100, 0.5), 0.01, math.inf, True) is None


def test_a_bound_is_widened_ten_times_on_its_own_side() -> None:
    assert bounds.widened(1.0, 100.0, "high", True) == (1.0, 1000.0)
    assert bounds.widened(1.0, 100.0, "low", True) == (0.1, 100.0)
    assert bounds.widened(0.0, 5.0, "high", False) == (0.0, 50.0)
    assert bounds.widened(0.0, 5.0, "low", False) == (-45.0, 5.0)
