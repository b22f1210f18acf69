"""The range checks of a validated config (config/limits.py): each rule at its limit, on both
sides, with the message that names the key, the value and what was expected."""

from __future__ import annotations

import pytest

from bayes_dnlr.config import ConfigError, parse_config

BASE = {"name": "x", "data": {"file": "d.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                              "observable": "stress"}}


def _error(**sections) -> str | None:
    try:
        parse_config(BASE | sections)
    except ConfigError as err:
        return str(err).removeprefix("config: ")
    return None


def _uniform(low: float, high: float, prior: str = "uniform") -> dict:
    return {"prior": prior, "low": low, "high": high}


@pytest.mark.parametrize(("sections", "message"), [
    ({"parameters": {"E": {"value": 2e7}}},
     "parameters.E.value: 2e+07 is beyond what the model can compute with; expected |value| <= 1e+07 MPa"),
    ({"parameters": {"alpha": {"value": 11}}},     # a dimensionless exponent: no unit
     "parameters.alpha.value: 11 is beyond what the model can compute with; expected |value| <= 10"),
    ({"parameters": {"E": {"value": 0}}}, "parameters.E.value: must be > 0 MPa, got 0"),
    ({"parameters": {"tau_max": _uniform(-1, 10)}},
     "parameters.tau_max: the prior reaches -1 s, but tau_max must be > 0 (the spectrum takes its "
     "logarithm, eq. 12): give low >= 0 (log-uniform with low > 0 is the usual choice)"),
    ({"noise": {"sigma0": 2e7}}, "noise.sigma0: 2e+07 is beyond any stress noise; expected <= 1e+07 MPa"),
    ({"noise": {"sigma0": _uniform(-1, 1)}}, "noise.sigma0.low: a noise sd is >= 0 MPa, got -1"),
    ({"noise": {"sigma0": _uniform(0, 1, "log-uniform")}}, "noise.sigma0.low: a noise sd is > 0 MPa, got 0"),
    ({"noise": {"sigma0": _uniform(0, 2e7)}},
     "noise.sigma0.high: 2e+07 is beyond what the model can compute with; expected |high| <= 1e+07 MPa"),
    ({"noise": {"sigma0": 0.3, "discrepancy": {"amplitude": {"value": 2e7}}}},
     "noise.discrepancy.amplitude.value: 2e+07 is beyond what the model can compute with; expected "
     "|value| <= 1e+07 MPa"),
    ({"noise": {"sigma0": 0.3, "discrepancy": {"length": {"value": 2e12}}}},
     "noise.discrepancy.length.value: 2e+12 is beyond what the model can compute with; expected "
     "|value| <= 1e+12 s"),
    ({"sampler": {"walkers": 4}},
     "sampler.walkers: 4 walkers for 3 sampled parameters (E, G, tau_max); the ensemble moves need at "
     "least 2 × 3 = 6 (32 is a good choice)"),
])
def test_a_value_beyond_a_limit_is_one_line_naming_the_key(sections: dict, message: str) -> None:
    assert _error(**sections) == message


@pytest.mark.parametrize("sections", [
    {"parameters": {"E": {"value": 1e7}}},                       # at the limit
    {"parameters": {"alpha": {"value": -10}}},
    {"parameters": {"E": {"value": 0.5}}},                       # small, but a modulus
    {"parameters": {"G": {"value": 0}}},                         # G may be 0 (no hardening)
    {"parameters": {"tau_max": _uniform(0, 10)}},                # low = 0: the posterior is -inf there only
    {"noise": {"sigma0": 1e7}},
    {"noise": {"sigma0": _uniform(0, 1)}},                       # a uniform noise sd from 0
    {"noise": {"sigma0": _uniform(0.01, 1, "log-uniform")}},
    {"sampler": {"walkers": 6}},                                 # exactly 2 × 3
])
def test_a_value_at_or_inside_a_limit_is_accepted(sections: dict) -> None:
    assert _error(**sections) is None


def test_a_chain_beyond_half_the_memory_is_refused_before_any_work() -> None:
    message = _error(sampler={"walkers": 1000, "max_steps": 10**9})
    assert message.startswith("sampler.walkers x sampler.max_steps: 1000 walkers x 1000000000 steps x 5 "
                              "sampled parameters need about 9.6e+04 GB of memory for the chain")
    assert message.endswith("lower walkers or max_steps (32 walkers are usual)")
    assert _error(sampler={"walkers": 32, "max_steps": 20000}) is None
