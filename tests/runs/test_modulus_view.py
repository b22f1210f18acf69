"""E(t) as summary.json and fit.json give it back (runs/modulus_view.py): the entries per test in
each form of ``modulus_at``, the master curve's reference block, the curves, and the console's
lines."""

from __future__ import annotations

from bayes_dnlr.runs.modulus_view import console_lines, curves, entries, reference

ROW = {"t": 1.23456, "mean": 1234.567, "sd": 12.345, "median": 1234.0, "hdi_90": [1214.2, 1254.9],
       "source": "posterior", "trust": True, "trust_reasons": []}
UNTRUSTED = {**ROW, "t": 20.0, "mean": 901.23, "sd": 3.21, "hdi_90": [896.0, 906.5], "source": "fit",
             "trust": False, "trust_reasons": ["the fit has not converged", "the prior shapes it"],
             "lacks": {"prior": "a least-squares fit has no prior"}}
TAIL = " (the modulus the data determine; E is its extrapolation to t → 0)"


def test_entries_per_test_in_each_form():
    assert entries({"modulus_at": [ROW]}) == {"": [ROW]}
    assert entries({"modulus_at": []}) == {} and entries({}) == {}
    assert entries({"modulus_at": {"tests": {"a": [ROW], "b": [UNTRUSTED]}}}) == {
        "a": [ROW], "b": [UNTRUSTED]}
    # fit.json of a joint run: each test's in its single fit, a test without E(t) left out
    fit = {"single_fits": {"a": {"modulus_at": [ROW]}, "b": {"modulus_at": []}, "c": {}}}
    assert entries(fit) == {"a": [ROW]}


def test_the_master_curve_s_block_from_summary_or_fit():
    block = {"temperature": 20.0, "rows": [ROW]}
    assert reference({"modulus_at": {"tests": {"a": [ROW]}, "reference": block}}) == block
    assert reference({"modulus_reference": block}) == block
    assert reference({"modulus_at": {"tests": {"a": [ROW]}}}) is None
    assert reference({"modulus_at": [ROW]}) is None and reference({}) is None
    assert reference({"modulus_reference": {}}) is None


def test_curves_per_test():
    one = {"t": [1.0, 2.0], "q50": [1000.0, 900.0]}
    assert curves({"modulus_curve": one}) == {"": one}
    assert curves({"modulus_curve": {"a": one, "b": one}}) == {"a": one, "b": one}
    assert curves({}) == {} and curves({"modulus_curve": None}) == {}


def test_the_console_says_each_value_its_interval_and_its_trust_with_the_reasons():
    summary = {"modulus_at": {"tests": {"r1": [ROW], "r2": [UNTRUSTED]},
                              "reference": {"temperature": 20.0,
                                            "rows": [{**ROW, "test": "T0"},
                                                     {**UNTRUSTED, "test": "T40"}]}},
               "consistency": {"words": "the tests agree"}}
    assert console_lines(summary) == [
        "E(t): r1: E(1.23 s) = 1235 ± 12 MPa, 90 % HDI [1214, 1255]: trusted" + TAIL,
        "E(t): r2: E(20.0 s) = 901.2 ± 3.2 MPa, 90 % HDI [896.0, 906.5] (fit, linearized): NOT "
        "trusted" + TAIL,
        "  - the fit has not converged",
        "  - the prior shapes it",
        "  - not checked: prior (a least-squares fit has no prior)",
        "E(t) at 20 °C (the master curve): E(1.23 s) = 1235 ± 12 MPa, 90 % HDI [1214, 1255], from "
        "T0: trusted",
        "E(t) at 20 °C (the master curve): E(20.0 s) = 901.2 ± 3.2 MPa, 90 % HDI [896.0, 906.5], "
        "from T40: NOT trusted",
        "  - the fit has not converged",
        "  - the prior shapes it",
        "tests: the tests agree",
    ]
    assert console_lines({"modulus_at": [ROW]}) == [
        "E(t): E(1.23 s) = 1235 ± 12 MPa, 90 % HDI [1214, 1255]: trusted" + TAIL]
    assert console_lines({}) == []
