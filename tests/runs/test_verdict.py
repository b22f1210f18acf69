"""The verdict at the thresholds it compares (runs/verdict.py): each rule exactly at its constant and
just past it, and the checks that pass leaving the verdict as it is."""

from __future__ import annotations

import pytest

from bayes_dnlr.runs.verdict import (
    COVERAGE_HIGH,
    COVERAGE_LOW,
    E_WEIGHTED_LOW,
    SEGMENT_LOW,
    SEGMENT_MIN_POINTS,
    SHIFT_SD,
    verdict,
)


def _checks(overall: float = 0.9, share: float = 0.9, points: int = 200, e_weighted: float | None = None,
            **more) -> dict:
    segs = {"time block 1": {"share": share, "points": points},
            "time block 2": {"share": 0.9, "points": 200}}
    cov = {"overall": overall, "points": 1000, "segments": segs}
    if e_weighted is not None:
        cov["E_weighted"] = e_weighted
    return {"predictive_coverage": {"t": cov}, "bound_limited": [], "prior_sensitivity": {"E": 0.0},
            "plausibility": {"t": {}}} | more


def _decided(checks: dict) -> tuple[bool, bool]:
    adequate, trust, _, _ = verdict(checks, True, False)
    return adequate, trust


def test_the_coverage_at_its_thresholds() -> None:
    assert _decided(_checks(overall=COVERAGE_LOW)) == (True, True)
    assert _decided(_checks(overall=COVERAGE_LOW - 0.001)) == (False, False)
    assert _decided(_checks(share=SEGMENT_LOW)) == (True, True)
    assert _decided(_checks(share=SEGMENT_LOW - 0.01)) == (False, False)
    # a segment too small to judge is not judged
    assert _decided(_checks(share=0.1, points=SEGMENT_MIN_POINTS - 1)) == (True, True)
    assert _decided(_checks(share=0.1, points=SEGMENT_MIN_POINTS)) == (False, False)


def test_a_band_wider_than_the_scatter_is_said_and_a_failing_segment_still_fails() -> None:
    _, _, _, words = verdict(_checks(overall=COVERAGE_HIGH), True, False)
    assert words[0] == "The 90 % predictive band holds 97 % of the points (80-97 % expected)."
    _, _, _, words = verdict(_checks(overall=0.99), True, False)
    assert words[0].endswith("(80-97 % expected): the band is wider than the data's scatter, so the "
                             "intervals lean to the safe side.")
    # nearly every point inside, but one segment of 20 holds fewer than half: not adequate
    adequate, trust, _, words = verdict(_checks(overall=0.99, share=0.45, points=20), True, False)
    assert not adequate and not trust and "45 % in the time block 1" in words[0]


def test_the_e_weighted_coverage_at_its_threshold() -> None:
    assert _decided(_checks(overall=0.5, e_weighted=E_WEIGHTED_LOW)) == (False, True)
    assert _decided(_checks(overall=0.5, e_weighted=E_WEIGHTED_LOW - 0.001)) == (False, False)


@pytest.mark.parametrize(("shift", "trusted"), [(SHIFT_SD, True), (-SHIFT_SD, True),
                                                (SHIFT_SD + 0.01, False), (-SHIFT_SD - 0.01, False)])
def test_a_bound_moves_e_by_at_most_shift_sd(shift: float, trusted: bool) -> None:
    bound = [{"parameter": "G", "side": "high", "bound": 5.0, "widened": [0.0, 50.0],
              "E_shift_sd": {"E": shift}}]
    assert _decided(_checks(bound_limited=bound)) == (True, trusted)


def test_checks_that_pass_leave_the_verdict_as_it_is() -> None:
    passing = _checks(model_form={"t": {"ok": True, "z": 0.3}},
                      noise_model={"t": {"ok": True, "likelihood": "white", "residuals_white": True}})
    adequate, trust, head, words = verdict(passing, True, False)
    assert adequate and trust and head == "Use E's interval as it is." and len(words) == 1


def test_a_time_constant_beyond_the_test_withdraws_trust_in_words() -> None:
    for k in ("tau_max", "tau_max_R"):
        checks = _checks(plausibility={"t": {k: {"ok": False, "median": 2.0e4, "test_duration": 400.0}}})
        adequate, trust, head, words = verdict(checks, True, False)
        assert adequate and not trust
        assert words[1] == (f"{k[0].upper() + k[1:]} = 20000 s is more than 10× the test's duration (400 s): "
                            "the test does not measure it, and what trades off with it comes from the "
                            "prior box.")
