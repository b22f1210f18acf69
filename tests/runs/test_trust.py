"""A run's trust in flat fields (runs/trust.py): the checks that fired, by name, from summary.json's
checks block of a one-test run and of a run with several tests; the verdict's first sentence; E(t)
at its first time in either form of ``modulus_at``; nothing invented for a run without them."""

from __future__ import annotations

from support.drawn_runs import NOT_TRUSTED, TRUSTED, checks, modulus_entry

from bayes_dnlr.runs.modulus_view import entries as modulus_entries
from bayes_dnlr.runs.trust import fired, first_modulus, run_trust, verdict_head


def test_every_kind_of_failed_check_is_named():
    c = checks(True)
    assert fired(c, True) == []
    c["predictive_coverage"]["segments"]["time block 2"] = {"share": 0.3, "points": 40}
    c["plausibility"]["E_chord"] = {"ok": False, "E_q95": 900.0, "chord": 1000.0}
    c["noise_model"]["ok"] = False
    c["model_form"]["ok"] = False
    c["bound_limited"] = [{"parameter": "G", "side": "lower", "bound": 0.0, "E_shift_sd": {"E": 1.4}},
                          {"parameter": "tau_max", "side": "upper", "bound": 1e4, "E_shift_sd": {"E": 0.2}}]
    c["prior_sensitivity"]["E"] = 0.08
    c["modulus_trust"] = {"ok": False}          # a check this reader does not know: its ok flag
    assert fired(c, False) == ["coverage", "E_chord", "noise_model", "model_form", "bound:G",
                               "prior_sensitivity", "modulus_trust", "not_converged"]
    c = checks(True)
    c["predictive_coverage"]["overall"] = 0.7
    c["predictive_coverage"]["segments"]["time block 2"] = {"share": 0.3, "points": 10}   # too few
    assert fired(c, True) == ["coverage"]


def test_a_run_with_several_tests_names_the_test():
    one = checks(True)
    c = {**one, "predictive_coverage": {"r1": one["predictive_coverage"],
                                        "r2": {**one["predictive_coverage"], "overall": 0.5}},
         "plausibility": {"r1": one["plausibility"], "r2": {"tau_max": {"ok": False, "median": 1e5}}},
         "noise_model": {"r1": one["noise_model"], "r2": one["noise_model"]},
         "model_form": {"r1": None, "r2": {"ok": False, "z": 3.0}}}
    assert fired(c, True) == ["coverage[r2]", "tau_max[r2]", "model_form[r2]"]


def test_the_verdicts_first_sentence():
    assert verdict_head(checks(True)) == TRUSTED
    assert verdict_head(checks(False)) == NOT_TRUSTED
    old = {"verdict": "Use E's interval as it is. The band holds 91 % of the points."}   # no points
    assert verdict_head(old) == "Use E's interval as it is."
    assert verdict_head({}) is None and verdict_head(None) is None


def test_modulus_at_in_both_forms():
    entries = [modulus_entry(1.0, 1800.0, 40.0, trust=False), modulus_entry(10.0, 1500.0, 30.0)]
    assert modulus_entries({"modulus_at": entries}) == {"": entries}
    assert modulus_entries({"modulus_at": {"tests": {"a": entries, "b": entries[1:]}}}) == {
        "a": entries, "b": entries[1:]}
    assert modulus_entries({}) == {}
    first = first_modulus(entries)
    assert first == {"t_s": 1.0, "mean": 1800.0, "sd": 40.0, "hdi_lo": 1800.0 - 1.645 * 40.0,
                     "hdi_hi": 1800.0 + 1.645 * 40.0, "trust": False}
    t = run_trust({"checks": checks(False), "converged": True, "modulus_at": {"tests": {"a": entries}}})
    assert t["Et[a]"]["mean"] == 1800.0 and "Et" not in t
    assert t["trust_interval"] is False and t["checks_fired"] == ["model_form"]


def test_a_run_without_checks_gives_none_not_a_guess():
    t = run_trust({"posterior": {"E": {"mean": 1.0, "sd": 1.0}}})
    assert t == {"trust_interval": None, "adequate": None, "verdict": None, "checks_fired": None}


def test_a_stress_shift_that_moves_e_is_named_among_the_checks_that_fired():
    from bayes_dnlr.runs.trust import fired

    assert fired({"stress_shift": {"z": 5.0, "E_shift_sd": -4.0, "ok": False}}) == ["stress_shift"]
    several = {"stress_shift": {"a": {"z": 5.0, "ok": False}, "b": {"z": 0.3, "ok": True}}}
    assert fired(several) == ["stress_shift[a]"]
