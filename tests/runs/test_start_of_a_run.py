"""The start check of a sampled run (runs/bands.py, inference/checks/start.py): it says whether
the test's toe was compensated, so that advice never repeats a remedy already set."""

from __future__ import annotations

from support.runs import make_run

from bayes_dnlr.config import load_config
from bayes_dnlr.runs.sample import sample

TOE = {"params": {"E": 1500.0, "G": 5.0, "tau_max": 30.0}, "strain_rate": 1e-3, "strain_max": 0.05,
       "sample_rate": 10, "model_form": {"kind": "strain-toe", "strength": 1e-3},
       "noise": {"strain_sd": 0.0, "stress_sd": 0.01}, "seed": 4}


def test_a_toe_left_after_its_compensation_is_said_to_be_compensated(tmp_path):
    """ASTM D638 X1 leaves out the samples before point B only: a slack of 1e-3 bends the curve
    past B, so the slope still rises after data.toe: compensate. The check says the compensation is
    set (``compensated``), which the words read instead of advising it again."""
    path = make_run(tmp_path, "toe-compensated", TOE, sigma0=0.01,
                    data={"strain_input": "measured", "toe": "compensate"},
                    sampler={"max_steps": 300, "target_ess": 100})
    [row] = sample(load_config(path), progress=False).summary["modulus_at"]
    start = row["checks"]["start"]
    assert start["compensated"] is True
    assert start["toe"] and start["convexity_z"] > start["toe_threshold"] > 3.0
    assert 0.0 <= start["toe_p"] < 0.005
    # the words say what is left, and never advise the remedy already set
    said = [r for r in row["trust_reasons"] if "a toe" in r]
    assert said and "remains after the toe's compensation" in said[0]
    assert not any("compensate it" in r for r in row["trust_reasons"])
