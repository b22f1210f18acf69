"""Small finished runs of a shifted model (``model.shift``) for the tests of the commands that start
from one (export): a ramp at 1e-3 1/s to 5 % strain on 300 samples at 40 °C, the model's reference
temperature 20 °C, made by ``simulate`` from its ``truth`` (with the same shift), fitted and sampled.

A test at one temperature cannot identify the temperature law's parameters (docs/config.md), so they
are fixed at their true values: Ea = 100 kJ/mol (Arrhenius: a_T(40 °C) = 0.073) or the WLF
constants C1 = 8.86, C2 = 101.6 K (a_T(40 °C) = 0.035). ``eyring`` adds the stress shift, sigma_s =
10 MPa free: the test reaches about 6 MPa.
"""

from __future__ import annotations

from pathlib import Path

import yaml

LAWS = {"arrhenius": {"Ea": 100.0}, "wlf": {"C1": 8.86, "C2": 101.6}}
TENSILE = {"E": 2854.0, "G": 2.32, "tau_max": 70.0}


def make_shifted_run(folder: Path, temperature: str, stress: str = "none") -> Path:
    """``folder/<temperature>-<stress>``: a finished run of a model with these shift laws."""
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.sample import sample
    from bayes_dnlr.workflows.simulate import simulate_test

    name = f"{temperature}-{stress}"
    d = folder / name
    d.mkdir(parents=True)
    shift = {"temperature": temperature, "reference_temperature": 20.0, "stress": stress}
    fixed = LAWS[temperature]
    params = {**TENSILE, **fixed, **({"sigma_s": 10.0} if stress == "eyring" else {})}
    config = {
        "name": name,
        "data": {"file": f"{name}.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
                 "observable": "stress", "temperature": "T_C"},
        "model": {"shift": shift},
        "parameters": {k: {"value": v} for k, v in fixed.items()},
        "noise": {"sigma0": 0.3, "discrepancy": "none"},
        "fit": {"multistart": 2},
        "sampler": {"walkers": 12, "max_steps": 200, "target_ess": 100, "seed": 1, "checkpoint_every": 100},
        "truth": {"params": params, "shift": shift, "temperature": 40.0, "strain_rate": 1e-3,
                  "strain_max": 0.05, "n_points": 300, "noise": {"strain_sd": 0.0, "stress_sd": 0.3},
                  "seed": 3},
    }
    (d / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    cfg = load_config(d / "config.yaml")
    simulate_test(cfg)
    fit(cfg)
    sample(cfg, progress=False)
    return d
