"""Where a test resolves E(t) (inference/modulus_window.py), at its edges: the window's ends and
their tolerance, the sampling step, a window of two samples, a file that starts late or loaded, the
linear range's end, and the words that say how each end was found."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bayes_dnlr.inference import modulus_window
from bayes_dnlr.inference.modulus_window import (
    X_LINEAR,
    ResolvedWindow,
    default_times,
    linear_range,
    nice_time,
    resolved_window,
    times_for,
)

window_of = modulus_window.test_window       # a test's window (named so that pytest does not collect it)


def test_a_window_holds_its_ends_to_a_part_in_a_billion():
    w = ResolvedWindow(0.8, 380.0, 0.0, 0.4, "")
    assert w.contains(0.8) and w.contains(380.0) and w.contains(5.0)
    assert w.contains(0.8 * (1 - 1e-9)) and w.contains(380.0 * (1 + 1e-9))
    assert not w.contains(0.8 * (1 - 3e-9)) and not w.contains(380.0 * (1 + 3e-9))
    assert not w.contains(0.5) and not w.contains(400.0)


def test_only_a_positive_finite_time_is_rounded():
    for bad in (0.0, -1.0, float("inf"), float("nan")):
        with pytest.raises(ValueError, match="a time must be a positive number, got"):
            nice_time(bad)
    assert nice_time(3e-7) == pytest.approx(5e-7) and nice_time(1000.0) == 1000.0


def test_the_step_is_the_median_of_the_first_twenty():
    # 10 steps of 0.1 s, 10 of 0.2 s, then 0.3 s: the first twenty steps' median is 0.15 s
    steps = np.r_[np.full(10, 0.1), np.full(10, 0.2), np.full(30, 0.3)]
    t = np.r_[0.0, np.cumsum(steps)]
    w = resolved_window(t, 1e-3 * t, np.ones(t.size, bool), 1e-3)
    assert w.step == pytest.approx(0.15) and w.how == "2 sampling steps of 0.15 s into the loading"
    assert w.shortest == pytest.approx(0.2) and w.longest == pytest.approx(12.0) and w.origin == 0.0


def test_repeated_time_stamps_are_not_steps():
    # a logger that writes each time twice: half the steps are 0, the step is still 0.5 s
    t = np.repeat(np.arange(0.0, 20.0, 0.5), 2)
    w = resolved_window(t, 1e-3 * t, np.ones(t.size, bool), 1e-3)
    assert w.step == pytest.approx(0.5)


def test_a_window_of_two_samples_resolves_from_its_second():
    t = np.arange(0.0, 10.0, 0.5)
    window = np.zeros(t.size, bool)
    window[[1, 2]] = True
    w = resolved_window(t, 1e-3 * t, window, 1e-3)
    assert w.shortest == pytest.approx(1.0) and w.longest == pytest.approx(1.0)
    window[2] = False
    with pytest.raises(ValueError, match="^the window holds fewer than two samples$"):
        resolved_window(t, 1e-3 * t, window, 1e-3)


def test_a_window_that_starts_late_says_when_the_loading_began():
    t = np.arange(0.0, 30.0, 0.5)
    window = np.ones(t.size, bool)
    window[:5] = False
    w = resolved_window(t, 1e-3 * t, window, 1e-3)
    assert (w.origin, w.shortest, w.longest, w.step) == (0.0, 3.5, 29.5, 0.5)
    assert w.how == ("2 sampling steps of 0.5 s into the loading, which began 2.5 s before the "
                     "window's first sample")
    window[:] = True
    window[0] = False          # one sample before the window
    assert resolved_window(t, 1e-3 * t, window, 1e-3).how == (
        "2 sampling steps of 0.5 s into the loading, which began 0.5 s before the window's first "
        "sample")


def test_a_file_that_starts_loaded_began_its_loading_before_its_first_sample():
    t = np.linspace(12.0, 22.0, 101)            # 0.1 s steps, from strain 0.005 at 1e-3 1/s
    e = 0.005 + 1e-3 * (t - 12.0)
    w = resolved_window(t, e, np.ones(t.size, bool), 1e-3)
    assert w.origin == pytest.approx(7.0) and w.longest == pytest.approx(15.0)
    assert w.shortest == pytest.approx(10.0)
    assert w.how == ("2 sampling steps of 0.1 s into the loading; the first sample already has "
                     "strain 0.005, so the loading began 5 s before it, at its rate 0.001 1/s; the "
                     "loading's first 5 s were not measured, and what the model assumes for them "
                     "weighs on E(t) for as long again: from 10 s")


def test_a_first_strain_within_two_steps_of_loading_is_the_loading_s_start():
    t = np.arange(0.0, 20.0, 0.5)
    e = 1e-3 + 1e-3 * t                  # 1e-3 = two steps of 0.5 s at 1e-3 1/s: not cropped
    w = resolved_window(t, e, np.ones(t.size, bool), 1e-3)
    assert w.origin == 0.0 and w.how == "2 sampling steps of 0.5 s into the loading"
    # a test without a loading rate (a hold) is not moved either
    assert resolved_window(t, e, np.ones(t.size, bool), 0.0).origin == 0.0


def test_an_unmeasured_start_weighs_for_as_long_again_only_when_it_is_longer():
    # the loading began at 0, the window's first sample is at 10 s, two steps later is 20 s:
    # twice the unmeasured 10 s is 20 s, no later than the two steps
    t = np.r_[0.0, np.arange(10.0, 60.0, 5.0)]
    window = np.ones(t.size, bool)
    window[0] = False
    w = resolved_window(t, 1e-3 * t, window, 1e-3, unmeasured_start=True)
    assert w.shortest == 20.0
    assert w.how == ("2 sampling steps of 5 s into the loading, which began 10 s before the "
                     "window's first sample")
    # with 8 s steps two steps end at 26 s: less than 3 x 10 s, more than 2 x 10 s
    t = np.r_[0.0, np.arange(10.0, 90.0, 8.0)]
    assert resolved_window(t, 1e-3 * t, window, 1e-3, unmeasured_start=True).shortest == 26.0


def test_the_default_time_rounds_up_unless_it_leaves_the_window():
    w = ResolvedWindow(0.76, 1.0, 0.0, 0.38, "two steps")
    assert default_times(w) == ([1.0], "the shortest time the test resolves, 0.76 s (two steps), "
                                       "rounded up to 1 s")
    short = ResolvedWindow(0.76, 0.9, 0.0, 0.38, "two steps")
    assert default_times(short)[0] == [0.76]


def _test(virtual_start=None):
    t = np.r_[0.0, np.arange(10.0, 60.0, 3.0)]
    window = np.ones(t.size, bool)
    window[0] = False
    out = SimpleNamespace(time=t, strain_input=1e-3 * t, window=window, strain_rate=1e-3)
    if virtual_start is not None:
        out.virtual_start = virtual_start
    return out


def test_a_test_s_window_knows_its_model_only_start():
    # 3 s steps from 10 s: two steps in is 16 s, but a model-only start 10 s before the first
    # sample weighs until 20 s
    measured = window_of(_test())
    assert measured.shortest == 16.0 and window_of(_test(0)) == measured
    assert window_of(_test(1)).shortest == 20.0


def test_the_times_are_the_config_s_or_the_default():
    given = SimpleNamespace(output=SimpleNamespace(modulus_at=[0.5, 2.0]))
    times, why, w = times_for(given, _test())
    assert (times, why, w) == ([0.5, 2.0], "output.modulus_at", window_of(_test()))
    default = SimpleNamespace(output=SimpleNamespace(modulus_at=None))
    times, why, w = times_for(default, _test())
    assert times == [20.0] and why.startswith("the shortest time the test resolves, 16 s (")
    assert w == window_of(_test())


def test_the_linear_range_ends_at_the_first_sample_that_reaches_it():
    t = np.linspace(5.0, 35.0, 301)                 # the loading began at 5 s
    stress = 1.8 * (t - 5.0)
    w = ResolvedWindow(0.2, 30.0, 5.0, 0.1, "two steps")
    ended = linear_range(w, t, stress, np.ones(t.size, bool), 2.0, "the model's")
    assert ended.longest == pytest.approx(2.5) and ended.shortest == 0.2 and ended.origin == 5.0
    assert ended.how == ("two steps; the linear range ends at t = 2.5 s, where the stress reaches "
                         "4.35 MPa (2.18 sigma_s, sigma_s = 2 MPa, the model's): there the stress "
                         "has sped the relaxation up 2×")
    # a sample exactly at the limit is past it; a sigma_s below 1 MPa counts as any other
    exact = np.where(np.arange(t.size) == 40, X_LINEAR * 0.5, 0.0)
    assert linear_range(w, t, exact, np.ones(t.size, bool), 0.5, "x").longest == pytest.approx(4.0)
    # compressive stress counts by its size
    assert linear_range(w, t, -stress, np.ones(t.size, bool), 2.0, "x") == ended.__class__(
        **{**ended.__dict__, "how": ended.how.replace("the model's", "x")})


def test_a_linear_range_that_ends_with_the_window_or_before_it_begins():
    t = np.linspace(5.0, 35.0, 301)
    stress = 1.8 * (t - 5.0)
    full = np.ones(t.size, bool)
    # the limit first reached at the window's last sample: the window as it was
    w = ResolvedWindow(0.2, 2.5, 5.0, 0.1, "two steps")
    assert linear_range(w, t, stress, full, 2.0, "x") is w
    # reached exactly at the shortest resolved time: ended there, and said so
    w = ResolvedWindow(2.5, 30.0, 5.0, 0.1, "two steps")
    early = linear_range(w, t, stress, full, 2.0, "x")
    assert early.longest == 2.5 and early.how.endswith(
        "there the stress has sped the relaxation up 2×, before the test resolves E(t)")
    assert early.how.startswith("two steps; the linear range ends at t = 2.5 s")
    # no limit without a positive, finite sigma_s
    for sigma_s in (0.0, -1.0, float("nan"), float("inf")):
        assert linear_range(w, t, stress, full, sigma_s, "x") is w
