"""The parts of fit.json's and summary.json's ``modulus_at`` (runs/modulus_block.py) on small
synthetic tests, without sampling: which bounds a fit's E(t) is refitted across, the fit's and the
posterior's sources, the linear range's end, the stored local fits, the trust."""

from __future__ import annotations

import pytest
from support.runs import make_run, ramp_truth

from bayes_dnlr.config import load_config
from bayes_dnlr.runs import modulus_block
from bayes_dnlr.runs.testset import load_tests

HDPE_30 = ramp_truth(0.2, n_points=30)          # the paper's HDPE, 30 samples to strain 0.2


@pytest.fixture(scope="module")
def boxed(tmp_path_factory):
    """A ramp whose tau_max (5.79 s) lies beyond its prior box's upper end, 3 s."""
    path = make_run(tmp_path_factory.mktemp("boxed"), "boxed", HDPE_30,
                    parameters={"tau_max": {"prior": "log-uniform", "low": 0.01, "high": 3.0}})
    cfg = load_config(path)
    return cfg, load_tests(cfg).tests[cfg.name]


def test_a_fit_on_a_bound_is_refitted_with_that_bound_widened_and_a_physical_limit_is_not(boxed):
    """tau_max on its box's upper end: refitted with that end ×10, where it finds the truth; G on 0,
    a modulus's physical limit: left alone (the bound check's rule, runs/checks.py)."""
    cfg, data = boxed
    refits = modulus_block._fit_refits(cfg, data, {}, {"E": 2854.0, "G": 0.0, "tau_max": 3.0})
    assert [r.parameter for r in refits] == ["tau_max"]
    [r] = refits
    assert r.before == {"E": 2854.0, "G": 0.0, "tau_max": 3.0}
    assert r.after["tau_max"] == pytest.approx(5.79, rel=0.05)
