"""The verdict's words on E(t) (runs/verdict.py ``modulus_reasons``, ``band_remedy``,
``shift_law_words``): each failed check gives one sentence with its numbers, at the precision the
user reads them, and the remedy that fits what was found; a passed check, or one at its threshold,
gives none."""

from __future__ import annotations

import pytest

from bayes_dnlr.runs.verdict import band_remedy, modulus_reasons, shift_law_words


def _row(t: float = 1.23456, resolved=(0.812345, 381.2345), source: str = "posterior",
         **checks) -> dict:
    """An E(t) row whose checks all pass, but those given."""
    base = {"inside_window": True, "width": {"half_width": 0.05, "ok": True}, "shape": None,
            "stress": None, "local": None, "band": None, "start": None, "bounds": {}, "prior": None,
            "noise_model": True, "converged": True}
    return {"t": t, "resolved": list(resolved), "source": source, "checks": {**base, **checks}}


BAND = {"share": 0.6234, "n_eff": 30.0, "floor": 0.8345, "ok": False,
        "information_times": [0.51234, 20.1234], "first_turn": 19.87654, "relaxation_start": None,
        "window": [0.0, 60.0]}

SENTENCES = {
    "outside": (
        {"inside_window": False},
        "E(1.23 s) lies outside the times the test resolves (0.812-381.2 s): an extrapolation "
        "through the model's spectrum, not a measurement"),
    "width": (
        {"width": {"half_width": 0.3456, "ok": False}},
        "E(1.23 s)'s 90 % interval spans ±35 % of its value: it says little about the material at "
        "this time; a test that resolves it (a denser record, a slower rate) or a time inside the "
        "well-measured part would"),
    "shape": (
        {"shape": {"alpha_pulled": 0.6234, "move": -12.3456, "z": -3.456, "ok": False,
                   "followed": False}},
        "the data pull the spectrum's exponent to 0.62 (eq. 12 holds it at ½), which moves "
        "E(1.23 s) by -12.3 MPa, 3.5 of its sd: the assumed spectrum's shape, not the data, "
        "decides it; sample the exponent (parameters.alpha, docs/model-form.md)"),
    "shift_law": (
        {"shift_law": {"temperature": 40.0, "ok": False}},
        "the temperature law does not carry the tests at 40 °C from the others (its held-out "
        "check): E(1.23 s) at the reference temperature from them is the law's, not the data's"),
    "stress": (
        {"stress": {"score_z": 4.567, "sigma_s": 2.34567, "shifted": 1000.0, "move": 15.678,
                    "z": 3.21, "ok": False}},
        "the data ask for a stress shift (its score test, z = 4.6; sigma_s about 2.35 MPa), and "
        "admitting it moves E(1.23 s) by 15.7 MPa, 3.2 of its sd: the stress-blind model reads "
        "the curve's nonlinearity as relaxation; set model.shift.stress: eyring (docs/theory.md)"),
    "stress without sigma_s": (
        {"stress": {"score_z": 4.567, "sigma_s": None, "shifted": 1000.0, "move": 15.678,
                    "z": -3.21, "ok": False}},
        "the data ask for a stress shift (its score test, z = 4.6), and admitting it moves "
        "E(1.23 s) by 15.7 MPa, 3.2 of its sd: the stress-blind model reads the curve's "
        "nonlinearity as relaxation; set model.shift.stress: eyring (docs/theory.md)"),
    "local": (
        {"local": {"local_mean": 1234.567, "local_sd": 12.345, "window_end": 12.3456,
                   "time_max": 112.34567, "z": -4.56, "ok": False}},
        "fitted on its first 12.3 s alone, where E(1.23 s) is measured, the model gives 1235 ± 12 "
        "MPa, 4.6 of that sd from the whole window's: what follows (a slower process, yield read "
        "as relaxation, a hold one spectrum does not describe) moves E(1.23 s); identify on "
        "data.window: {time_max: 112.3}, or give the model the form it lacks "
        "(docs/model-form.md)"),
    "local, after the exponent's pull": (
        {"local": {"local_mean": 1234.567, "local_sd": 12.345, "window_end": 12.3456,
                   "time_max": 112.34567, "z": -1.0, "z_reported": -3.21, "ok": False}},
        "fitted on its first 12.3 s alone, where E(1.23 s) is measured, the model gives 1235 ± 12 "
        "MPa, 3.2 of that sd from the value reported, after the exponent's pull: what follows (a "
        "slower process, yield read as relaxation, a hold one spectrum does not describe) moves "
        "E(1.23 s); identify on data.window: {time_max: 112.3}, or give the model the form it lacks "
        "(docs/model-form.md)"),
    "band": (
        {"band": BAND},
        "the 90 % band holds 62 % of the samples that carry E(1.23 s)'s information "
        "(t = 0.512-20.1 s; at least 83 % expected of a calibrated band): the model misses the "
        "data where this modulus is measured; the model does not follow unloading: identify on "
        "the first loading, data.window: {time_max: 19.8765} (its peak), where E(t) is measured"),
    "toe": (
        {"start": {"ok": False, "toe": True, "convexity_z": 7.01, "z": 0.3}},
        "the curve's slope rises over its start (+7.0 sd): a toe (slack, seating), which no "
        "relaxing material gives and the model fits as a softer start, so E(1.23 s) comes out "
        "low; compensate it (data.toe: compensate) or fix the start (docs/data-input.md)"),
    "toe compensated": (
        {"start": {"ok": False, "toe": True, "convexity_z": 7.01, "z": 0.3, "compensated": True}},
        "the curve's slope rises over its start (+7.0 sd): a toe (slack, seating), which no "
        "relaxing material gives and the model fits as a softer start, so E(1.23 s) comes out "
        "low; it remains after the toe's compensation (data.toe: compensate): fix the start of "
        "the test (docs/data-input.md)"),
    "start, ASTM": (
        {"start": {"ok": False, "toe": False, "convexity_z": 0.5, "z": -4.04,
                   "data_chord": 912.345, "model_chord": 1100.2, "times": [0.1234, 0.5678],
                   "standard": "ASTM D638"}},
        "the data's ASTM D638 chord (912.3 MPa, measured 0.12-0.57 s into the loading) is 4.0 sd "
        "from the model's (1100 MPa): the model does not follow the start of this curve (a "
        "preload, a loading it misses)"),
    "start, ISO by default": (
        {"start": {"ok": False, "toe": False, "convexity_z": 0.5, "z": 4.04,
                   "data_chord": 912.345, "model_chord": 1100.2, "times": [0.1234, 0.5678]}},
        "the data's ISO 527-1 chord (912.3 MPa, measured 0.12-0.57 s into the loading) is 4.0 sd "
        "from the model's (1100 MPa): the model does not follow the start of this curve (a "
        "preload, a loading it misses)"),
    "bounds": (
        # a move of exactly SHIFT_SD (G) does not decide E(t)
        {"bounds": {"tau_max": 1.5, "G": 1.0, "E": -2.26}},
        "the prior box decides E(1.23 s): widening the bound of tau_max moves it by +1.5 sd, "
        "E moves it by -2.3 sd"),
    "prior": (
        {"prior": 0.2},
        "the prior shapes E(1.23 s) (power-scaling sensitivity 0.20)"),
    "noise model": (
        {"noise_model": False},
        "a white likelihood on residuals that are not white: E(1.23 s)'s interval ignores the "
        "model error"),
    "converged": (
        {"converged": False},
        "the chain has not converged"),
}


@pytest.mark.parametrize("case", SENTENCES)
def test_each_failed_check_gives_its_sentence_with_its_numbers(case):
    failed, words = SENTENCES[case]
    assert modulus_reasons(_row(**failed)) == [words]
    assert modulus_reasons(_row(**failed), "r1: ") == ["r1: " + words]


def test_passed_checks_and_checks_at_their_threshold_give_no_sentence():
    from bayes_dnlr.inference.checks.power_scaling import SENSITIVE

    passed = {"width": {"half_width": 0.25, "ok": True},
              "shape": {"alpha_pulled": 0.55, "move": 1.0, "z": 0.5, "ok": True, "followed": True},
              "shift_law": {"temperature": 40.0, "ok": True},
              "stress": {"score_z": 4.0, "sigma_s": 2.0, "shifted": 1.0, "move": 1.0, "z": 1.0,
                         "ok": True},
              "local": {"local_mean": 1.0, "local_sd": 1.0, "window_end": 1.0, "time_max": 1.0,
                        "z": 1.0, "ok": True},
              "band": {**BAND, "ok": True},
              "start": {"ok": True, "toe": False, "convexity_z": 0.1, "z": 0.1},
              "bounds": {"tau_max": -1.0, "G": 0.99}, "prior": SENSITIVE}
    assert modulus_reasons(_row(**passed)) == []


def test_a_fit_that_has_not_converged_is_named_a_fit():
    assert modulus_reasons(_row(source="fit", converged=False)) == ["the fit has not converged"]


def test_beyond_the_linear_range_the_remedy_depends_on_whether_the_model_has_a_stress_shift():
    linear = {"time": 12.3456, "stress": 4.35678, "sigma_s": 2.00123, "model_shift": False}
    row = {**_row(t=500.0, resolved=(0.812345, 12.3456), inside_window=False),
           "linear_range": linear}
    head = ("E(500 s) lies beyond the test's linear range (it ends at t = 12.3 s, where the stress "
            "reaches 4.36 MPa, 2.00 MPa sigma_s): ")
    assert modulus_reasons(row) == [
        head + "the stress-blind model reads the curve's nonlinearity there as relaxation; set "
               "model.shift.stress: eyring (docs/theory.md)"]
    row["linear_range"] = {**linear, "model_shift": True}
    assert modulus_reasons(row, "r1: ") == [
        "r1: " + head + "the model reaches it through its stress shift, an extrapolation in stress"]
    # before the resolved times (not beyond the linear range's end) it is an extrapolation in time
    early = {**_row(t=0.5, resolved=(0.812345, 12.3456), inside_window=False),
             "linear_range": linear}
    assert modulus_reasons(early) == [
        "E(0.500 s) lies outside the times the test resolves (0.812-12.35 s): an extrapolation "
        "through the model's spectrum, not a measurement"]


def test_several_failed_checks_are_said_in_the_order_of_the_checks():
    failed = {k: SENTENCES[k][0] for k in ("converged", "prior", "band", "width", "outside")}
    merged = {k: v for f in failed.values() for k, v in f.items()}
    assert modulus_reasons(_row(**merged)) == [SENTENCES[k][1] for k in
                                               ("outside", "width", "band", "prior", "converged")]


def test_a_band_below_a_negative_floor_says_at_least_0_percent():
    band = {**BAND, "share": 0.04, "floor": -0.12, "first_turn": None, "window": [0.0, 60.0]}
    [words] = modulus_reasons(_row(band=band))
    assert "holds 4 % of the samples" in words and "at least 0 % expected" in words


def test_the_band_s_remedy_for_a_hold_points_ten_loadings_into_it():
    # the loading runs 2-8 s: ten loadings more end the window at 68 s
    hold = band_remedy({"first_turn": None, "relaxation_start": 8.0, "window": [2.0, 100.0]})
    assert hold == ("one spectrum does not describe the whole hold: identify on the loading and "
                    "the start of the hold, e.g. data.window: {time_max: 68} (ten times the "
                    "loading's length), and compare")
    generic = ("the model's form does not describe the curve where E(t) is measured "
               "(docs/model-form.md): read the residuals there")
    # a window that ends there already, or before, has no shorter window to offer
    assert band_remedy({"first_turn": None, "relaxation_start": 8.0, "window": [2.0, 68.0]}) == generic
    assert band_remedy({"first_turn": None, "relaxation_start": None, "window": [2.0, 68.0]}) == generic
    assert band_remedy({"first_turn": 19.87654}) == (
        "the model does not follow unloading: identify on the first loading, data.window: "
        "{time_max: 19.8765} (its peak), where E(t) is measured")


def _held_out(*entries):
    return {"ok": all(x["ok"] for _, tests, _ in entries for x in tests.values()),
            "held_out": [{"temperature": T, "tests": tests, **({"note": note} if note else {})}
                         for T, tests, note in entries]}


def _test(coverage, ok=True, chi2=140.2, points=150, p=0.52):
    return {"coverage": coverage, "chi2": chi2, "points": points, "p": p, "ok": ok}


def test_the_temperature_law_s_words_when_it_carries_each_temperature():
    block = _held_out((0.0, {"T0": _test(0.884)}, None), (20.0, {"T20": _test(0.912)}, None),
                      (40.0, {}, "the tests at 40 °C have their own tau_max: nothing to predict"))
    assert shift_law_words(block) == (
        "The temperature law predicts the tests at 0, 20 °C from the others, each held out in turn "
        "(88 %-91 % of their points in the 90 % band); not held out: the tests at 40 °C have their "
        "own tau_max: nothing to predict.")
    one = _held_out((0.0, {"T0": _test(0.9)}, None), (20.0, {"T20": _test(0.904)}, None),
                    (40.0, {}, None))
    assert shift_law_words(one) == (
        "The temperature law predicts the tests at 0, 20 °C from the others, each held out in turn "
        "(90 % of their points in the 90 % band); not held out: 40 °C.")


def test_the_temperature_law_s_words_name_the_first_temperature_it_does_not_carry():
    block = _held_out((0.0, {"T0": _test(0.884)}, None),
                      (20.0, {"T20a": _test(0.9), "T20b": _test(0.412, False, 612.4, 150, 3.2e-9)},
                       None),
                      (40.0, {"T40": _test(0.2, False, 900.0, 120, 1e-12)}, None))
    assert shift_law_words(block) == (
        "The temperature law does not predict the tests at 20 °C from the others: T20b lies beyond "
        "the prediction of the fit without them (χ² 612 on 150 points, p = 3.2e-09; 41 % of its "
        "points in the 90 % band): the law fits every temperature but does not carry one to "
        "another; E(t) at the reference temperature from those tests is the law's, not the data's. "
        "Try the other law (model.shift.temperature), or tests at more temperatures.")


def test_no_words_on_a_law_that_was_not_checked():
    assert shift_law_words(None) is None and shift_law_words({}) is None
    assert shift_law_words({"ok": None, "held_out": [], "note": "3 are needed"}) is None
