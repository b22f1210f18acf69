"""A small run with references, made as a user makes it: a config with a truth: and
reference_moduli, then ``simulate`` writes the test and the sweeps."""

from __future__ import annotations

from pathlib import Path

import yaml

from bayes_dnlr.config import load_config
from bayes_dnlr.workflows.simulate import simulate_test
from bayes_dnlr.workflows.sweeps import simulate_references
from tests.support.runs import TINY_SAMPLER, ramp_truth

TRUE_E = 2854.0
PULSE_ECHO = {"method": "pulse-echo", "value": TRUE_E, "sd": 40.0, "frequency": 5.0e6, "note": "OPBOX"}
SWEEP = {"method": "dma", "file": "sweep.csv", "relative_sd": 0.01, "use": "data",
         "truth": {"relative_sd": 0.01, "seed": 4, "layout": "netzsch"}}


def run_with_references(folder: Path, refs: list[dict], name: str = "r", sampler: dict | None = None,
                        truth: dict | None = None) -> Path:
    """``folder/name/config.yaml``: a 300-point ramp to 0.13 (the paper's HDPE, white likelihood) with
    ``refs`` under reference_moduli; its data and sweeps simulated. Returns the config's path."""
    d = folder / name
    d.mkdir(parents=True)
    raw = {"name": name,
           "data": {"file": "data.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
                    "observable": "stress", "strain_input": "measured"},
           "noise": {"sigma0": 0.1, "discrepancy": "none"},
           "sampler": {**TINY_SAMPLER, "max_steps": 400, **(sampler or {})},
           "truth": truth or ramp_truth(0.13, n_points=300), "reference_moduli": refs}
    path = d / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    cfg = load_config(path)
    simulate_test(cfg)
    simulate_references(cfg)
    return path
