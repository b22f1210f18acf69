"""summary.json's noise block sets each posterior beside the analysis of its own likelihood: in a
run with several tests, every test's white and generalized intervals of E are the run's (the joint
analyses the joint posterior is compared with), never the test's own single fit; a run with one
test keeps its own fit's."""

from __future__ import annotations

import copy

from support.joint import RATES, make_joint

from bayes_dnlr.config import load_config
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.runs.noise_summary import noise_summary

NAMES = ["E", "G", *(f"tau_max[{t}]" for t in RATES)]
HYPER = {"sigma0": 0.1, "amplitude": 0.5, "length": 20.0}


def _own(e: float, sd: float, gls_e: float, gls_sd: float) -> dict:
    """A test's own fit (white and GLS) with evidence of model error."""
    return {"estimate": {"E": e, "G": 2.3, "tau_max": 5.0}, "sd": {"E": sd, "G": 0.01, "tau_max": 0.05},
            "residuals": {"white": False}, "sigma0": 0.1, "sigma0_source": "config",
            "discrepancy": {"kernel": "exp", "axis": "time", "axis_unit": "s", "evidence": True,
                            "likelihood_ratio": 500.0, "hyperparameters": HYPER, "priors": {},
                            "estimate": {"E": gls_e, "G": 2.3, "tau_max": 5.0},
                            "sd": {"E": gls_sd, "G": 0.02, "tau_max": 0.1}}}


def _joint_fit() -> dict:
    """fit.json of a run with three tests: each test alone far from the run's joint estimates."""
    singles = {t: _own(3000.0 + 100 * i, 40.0, 2600.0 + 50 * i, 60.0) for i, t in enumerate(RATES)}
    return {"joint": True, "parameters": NAMES, "per_test": ["tau_max"],
            "estimate": dict.fromkeys(NAMES, 1.0) | {"E": 2854.0},
            "sd": dict.fromkeys(NAMES, 0.1) | {"E": 17.0},
            "single_fits": singles, "tests": {t: {"n_points": 150} for t in RATES},
            "discrepancy": {"tests": list(RATES), "estimate": dict.fromkeys(NAMES, 1.0) | {"E": 2790.0},
                            "sd": dict.fromkeys(NAMES, 0.1) | {"E": 31.0}}}


def _summary(names: list[str], e_mean: float) -> dict:
    post = {k: {"mean": 1.0, "sd": 0.1, "median": 1.0, "hdi_90": [0.9, 1.1]} for k in names}
    post["E"] = {"mean": e_mean, "sd": 30.0, "median": e_mean, "hdi_90": [e_mean - 50, e_mean + 50]}
    return {"posterior": post}


def test_each_test_of_a_joint_run_gets_the_runs_intervals(tmp_path):
    cfg = load_config(make_joint(tmp_path, discrepancy=True))
    fit = _joint_fit()
    layout = Layout.build({t: ["E", "G", "tau_max"] for t in RATES}, ["tau_max"])
    block = noise_summary(cfg, fit, _summary(layout.names, 2795.0), layout, dict.fromkeys(RATES, 0.1),
                          dict.fromkeys(RATES, "config"))
    for t in RATES:
        iv = block["tests"][t]["interval"]
        assert iv["white_linearized"]["estimate"] == 2854.0 and iv["white_linearized"]["sd"] == 17.0
        assert iv["gls_linearized"]["estimate"] == 2790.0 and iv["gls_linearized"]["sd"] == 31.0
        assert iv["posterior"]["mean"] == 2795.0
        # the posterior's shift and width against the run's white analysis, not the test's own
        assert abs(iv["shift_in_white_sd"] - (2795.0 - 2854.0) / 17.0) < 1e-12
        assert abs(iv["sd_ratio_posterior_to_white"] - 30.0 / 17.0) < 1e-12
        # the test's own noise stays its own
        assert block["tests"][t]["likelihood_ratio"] == 500.0


def test_a_run_with_one_test_keeps_its_own_fit(tmp_path):
    cfg = load_config(make_joint(tmp_path, discrepancy=True)).for_test("r5e-3")
    fit = copy.deepcopy(_own(3000.0, 40.0, 2600.0, 60.0)) | {"parameters": ["E", "G", "tau_max"]}
    layout = Layout.build({"r5e-3": ["E", "G", "tau_max"]}, [], plain=True)
    block = noise_summary(cfg, fit, _summary(layout.names, 2650.0), layout, {"r5e-3": 0.1},
                          {"r5e-3": "config"})
    iv = block["interval"]
    assert iv["white_linearized"]["estimate"] == 3000.0 and iv["white_linearized"]["sd"] == 40.0
    assert iv["gls_linearized"]["estimate"] == 2600.0 and iv["gls_linearized"]["sd"] == 60.0
