"""E(t) across runs (runs/modulus_across.py): compared at the shortest time every run has an entry
at and resolves; none when a run lacks it or does not resolve it, with the reason."""

from __future__ import annotations

from support.drawn_runs import modulus_entry

from bayes_dnlr.runs.modulus_across import at_common_time, run_entries


def test_the_shortest_time_every_run_resolves():
    a = [modulus_entry(0.5, 1300.0, 3.0, resolved=(0.2, 50)), modulus_entry(2.0, 1200.0, 3.0,
                                                                             resolved=(0.2, 50))]
    b = [modulus_entry(0.5, 1310.0, 4.0, resolved=(1.0, 50)), modulus_entry(2.0, 1205.0, 4.0,
                                                                             resolved=(1.0, 50))]
    at = at_common_time({"a": a, "b": b})
    assert at.t == 2.0 and at.quantity == "E(2.00 s)" and at.why == ""
    assert at.values() == {"a": 1200.0, "b": 1205.0} and at.sds() == {"a": 3.0, "b": 4.0}
    both = at_common_time({"a": a, "b": [modulus_entry(0.5, 1310.0, 4.0, resolved=(0.4, 50)), b[1]]})
    assert both.t == 0.5


def test_no_common_time_falls_back_with_the_reason():
    at = at_common_time({"a": [modulus_entry(0.5, 1300.0, 3.0)], "b": [modulus_entry(2.0, 900.0, 9.0)]})
    assert at.t is None and at.quantity == "E" and at.entries == {}
    assert at.why == ("no time at which every test has E(t) and resolves it (at 0.500 s: a; "
                      "at 2.00 s: b)")
    edge = at_common_time({"a": [modulus_entry(0.5, 1300.0, 3.0)],
                           "b": [modulus_entry(0.5, 1300.0, 3.0, resolved=(0.6, 9.0))]})
    assert edge.t is None and "at 0.500 s: a, b, not resolved by b" in edge.why
    old = {k: v for k, v in modulus_entry(0.5, 1300.0, 3.0).items() if k != "resolved"}
    assert at_common_time({"a": [modulus_entry(0.5, 1.0, 1.0)], "b": [old]}).t is None   # unknown
    none = at_common_time({"a": [modulus_entry(0.5, 1.0, 1.0)], **{k: [] for k in "bcdef"}})
    assert none.why == "no E(t) in 5 tests (b, c, d and 2 more) (summary.json without modulus_at)"


def test_run_entries_of_one_test_runs_only():
    e = modulus_entry(0.5, 1300.0, 3.0)
    assert run_entries({"modulus_at": [e]}) == [{k: e[k] for k in
                                                 ("t", "mean", "sd", "hdi_90", "trust", "resolved")}]
    assert run_entries({"modulus_at": {"tests": {"x": [e], "y": [e]}}}) is None
    assert run_entries({}) is None
