"""Where a test leaves its linear range (inference/modulus_window.py ``linear_range``): a
stress-blind fit's score test of the Eyring shift, its refit with it, and E(t)'s window ended where
the stress speeds the relaxation up twice (runs/modulus_block.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from support.runs import make_run

from bayes_dnlr.config import load_config
from bayes_dnlr.inference.modulus_window import X_LINEAR, ResolvedWindow, linear_range
from bayes_dnlr.model.shift import stress_shift
from bayes_dnlr.runs.fit import fit

RAMP = {"params": {"E": 1800.0, "G": 5.0, "tau_max": 200.0}, "strain_rate": 1e-3,
        "strain_max": 0.03, "n_points": 200, "noise": {"strain_sd": 0.0, "stress_sd": 0.05}, "seed": 7}


def test_x_linear_is_where_eyring_halves_the_time_scale():
    assert float(stress_shift(X_LINEAR, 1.0)) == pytest.approx(0.5, abs=1e-6)


def test_the_window_ends_where_the_stress_first_reaches_the_limit_and_says_so():
    t = np.linspace(0.0, 30.0, 301)
    stress = 1.8 * t                                   # MPa
    w = ResolvedWindow(0.2, 30.0, 0.0, 0.1, "two steps")
    ended = linear_range(w, t, stress, np.ones(t.size, bool), 2.0, "the model's")
    assert ended.longest == pytest.approx(2.5, abs=0.1)          # 2.18 × 2 MPa / 1.8 MPa/s
    assert "linear range ends at t = 2.5 s" in ended.how and "the model's" in ended.how
    assert linear_range(w, t, stress, np.ones(t.size, bool), 100.0, "x") == w     # never reached
    early = linear_range(w, t, 100 * stress, np.ones(t.size, bool), 2.0, "x")
    assert early.longest == w.shortest and "before the test resolves" in early.how


@pytest.fixture(scope="module")
def bent(tmp_path_factory):
    """Data with an Eyring shift (sigma_s 2 MPa), fitted stress-blind, E(t) asked at 0.5 and 20 s."""
    truth = {**RAMP, "params": {**RAMP["params"], "sigma_s": 2.0}, "shift": {"stress": "eyring"}}
    path = make_run(tmp_path_factory.mktemp("bent"), "bent", truth, sigma0=0.05)
    import yaml

    raw = yaml.safe_load(path.read_text())
    raw["output"] = {"modulus_at": [0.5, 20.0]}
    path.write_text(yaml.safe_dump(raw))
    fit(load_config(path))
    return json.loads((path.parent / "fit.json").read_text())


def test_a_stress_blind_fit_of_bent_data_is_asked_for_a_stress_shift(bent):
    score = (bent.get("discrepancy") or {}).get("stress_score") or bent["stress_score"]
    assert score["z"] > 2.326 and not score["ok"]
    refit = bent["stress_refit"]
    assert refit["converged"] and refit["sigma_s"] == pytest.approx(2.0, rel=0.3)


def test_e_t_beyond_the_linear_range_is_not_trusted_and_names_the_stress_shift(bent):
    early, late = bent["modulus_at"]
    assert late["linear_range"]["sigma_s"] == pytest.approx(bent["stress_refit"]["sigma_s"])
    assert late["resolved"][1] == pytest.approx(late["linear_range"]["time"])
    assert not late["checks"]["inside_window"] and not late["trust"]
    assert any("beyond the test's linear range" in r and "model.shift.stress: eyring" in r
               for r in late["trust_reasons"])
    # the stress check compares the refit's E(t) with the stress-blind one where the data ask
    assert late["checks"]["stress"] is not None and late["checks"]["stress"]["score_z"] > 2.326


def test_data_without_a_stress_shift_are_not_asked_for_one(tmp_path):
    path = make_run(tmp_path, "straight", RAMP, sigma0=0.05)
    f = fit(load_config(path)).to_dict()
    score = (f.get("discrepancy") or {}).get("stress_score") or f["stress_score"]
    assert score["ok"] and f["stress_refit"] is None
    assert "linear_range" not in f["modulus_at"][0]
