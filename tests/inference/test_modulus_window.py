"""Where a test resolves E(t) and its default times (inference/modulus_window.py)."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.modulus_window import default_times, nice_time, resolved_window


@pytest.mark.parametrize("t, expected", [(0.38, 0.5), (0.5, 0.5), (0.76, 1.0), (1.2, 2.0), (2.01, 5.0),
                                         (7.0, 10.0), (0.0012, 0.002), (99.0, 100.0)])
def test_nice_times_round_up_to_1_2_5(t, expected):
    assert nice_time(t) == pytest.approx(expected)


def test_a_ramp_from_rest_resolves_two_steps_in():
    t = np.linspace(0.0, 380.0, 1001)
    e = 5e-3 * t
    w = resolved_window(t, e, np.ones(t.size, bool), 5e-3)
    assert w.origin == 0.0 and w.shortest == pytest.approx(0.76) and w.longest == pytest.approx(380.0)
    times, why = default_times(w)
    assert times == [1.0] and "rounded up to 1 s" in why and "2 sampling steps of 0.38 s" in why


def test_a_file_that_starts_at_a_strain_already_reached_began_before_it():
    t = np.linspace(10.0, 20.0, 101)            # 0.1 s steps, from strain 0.005 at 1e-3 1/s
    e = 0.005 + 1e-3 * (t - 10.0)
    w = resolved_window(t, e, np.ones(t.size, bool), 1e-3)
    assert w.origin == pytest.approx(5.0)        # 0.005 / 1e-3 = 5 s before the first sample
    # the first 5 s were not measured: E(t) resolved from twice that
    assert w.shortest == pytest.approx(10.0) and "already has strain 0.005" in w.how
    assert "not measured" in w.how


def test_an_unloaded_start_before_the_first_sample_is_the_origin():
    # a model-only sample at zero strain (initial_state: ramp-from-zero), never in the window
    t = np.concatenate([[4.0], np.linspace(10.0, 20.0, 101)])
    e = np.concatenate([[0.0], 0.006 + 1e-3 * (t[1:] - 10.0)])
    window = np.ones(t.size, bool)
    window[0] = False
    w = resolved_window(t, e, window, 1e-3)
    assert w.origin == 4.0 and w.shortest == pytest.approx(10.2 - 4.0)
    w = resolved_window(t, e, window, 1e-3, unmeasured_start=True)
    assert w.shortest == pytest.approx(12.0)           # twice the 6 s before the first sample
