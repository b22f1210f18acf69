"""The loading and unloading branches of a cyclic test (inference/checks/predictive.py), the
segments the checks report on, cut where the test's one rule (data/cycles.py) says it turns."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.data.cycles import NO_TURNS, turning_points
from bayes_dnlr.inference.checks.predictive import branches, segments

E = 1000.0      # MPa: a linear elastic material is enough for where a test turns


def zigzag(peaks, valleys, step=1e-4, noise=0.0, seed=0):
    e = [0.0]
    for p, v in zip(peaks, valleys, strict=True):
        e += list(np.arange(e[-1] + step, p + step / 2, step))
        e += list(np.arange(e[-1] - step, v - step / 2, -step))
    e = np.array(e)
    return e + np.random.default_rng(seed).normal(0, noise, e.size)


def test_cycles_split_into_numbered_branches_at_their_turning_points():
    e = zigzag([0.005, 0.01, 0.015], [0.001, 0.004, 0.006])
    turns = turning_points(e, E * e)
    np.testing.assert_allclose(e[sorted(turns.peaks + turns.valleys)], [0.005, 0.001, 0.01, 0.004, 0.015],
                               atol=1e-12)
    b = branches(turns, e.size)
    assert list(b) == ["loading 1", "unloading 1", "loading 2", "unloading 2", "loading 3",
                       "unloading 3"]
    masks = np.array(list(b.values()))
    assert np.all(masks.sum(axis=0) == 1)                   # every sample in exactly one branch
    assert np.all(np.diff(e[b["loading 2"]]) > 0) and np.all(np.diff(e[b["unloading 2"]]) < 0)


def test_a_window_that_starts_in_an_unloading_names_its_first_branch_so():
    e = zigzag([0.005, 0.01], [0.001, 0.002])
    turns = turning_points(e, E * e)
    rows = np.arange(turns.peaks[0] + 5, e.size)             # from inside the first unloading
    b = branches(turns.within(rows), rows.size)
    assert list(b) == ["unloading 1", "loading 1", "unloading 2"]
    assert np.all(np.diff(e[rows][b["loading 1"]]) > 0)


def test_noise_and_a_ramp_are_not_cycles():
    ramp = np.linspace(0, 0.02, 300) + np.random.default_rng(1).normal(0, 1e-5, 300)
    turns = turning_points(ramp, E * ramp)
    assert turns == NO_TURNS and branches(turns, ramp.size) == {}
    t = np.linspace(0, 10, 300)
    seg = segments(t, None, turns=turns)
    assert not any(k.startswith(("loading", "unloading")) for k in seg)


def test_segments_of_a_cyclic_test_hold_its_branches_and_time_blocks():
    e = zigzag([0.005, 0.01], [0.001, 0.004], noise=2e-6)
    t = np.arange(e.size) * 0.1
    turns = turning_points(e, E * e)
    seg = segments(t, None, turns=turns)
    assert {"loading 1", "unloading 1", "loading 2", "unloading 2"} <= set(seg)
    assert "time block 1" in seg
    # a hold keeps its loading and hold segments, never branches
    seg = segments(t, 5.0, turns=turns)
    assert "hold" in seg and "unloading 1" not in seg
