"""A run of one material tested at several temperatures, made the way a user makes it: a config with
``tests:`` at their ``data.temperature``, each with a truth of the same parameters and shift law,
then ``simulate``."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import yaml

from bayes_dnlr.config import load_config
from bayes_dnlr.workflows.simulate import simulate_tests

TRUTH = {"E": 1800.0, "G": 5.0, "tau_max": 200.0, "Ea": 250.0, "sigma_s": 2.0}
SHIFT = {"temperature": "arrhenius", "reference_temperature": 20, "stress": "eyring"}


def make_temperatures(folder: Path, name: str, temperatures: tuple[float, ...] = (0.0, 20.0, 40.0), *,
                      truth_shift: dict[str, Any] | None = None, params: dict[str, float] | None = None,
                      n_points: int = 150, sampler: dict | None = None) -> Path:
    """``folder/name/config.yaml``: ramps at 1e-3 1/s to 3 % at each temperature, 0.05 MPa noise,
    the model's shift SHIFT, the data's ``truth_shift`` (SHIFT by default) and ``params``."""
    run = folder / name
    run.mkdir(parents=True, exist_ok=True)
    tests = []
    for i, T in enumerate(temperatures):
        tag = f"T{T:g}"
        tests.append({
            "name": tag,
            "data": {"file": f"{tag}.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
                     "observable": "stress", "temperature": T},
            "noise": {"sigma0": 0.05},
            "truth": {"params": copy.deepcopy(params or TRUTH), "shift": dict(truth_shift or SHIFT),
                      "temperature": T, "strain_rate": 1e-3, "strain_max": 0.03,
                      "n_points": n_points, "layout": "plain",
                      "noise": {"strain_sd": 0.0, "stress_sd": 0.05}, "seed": 11 + i}})
    raw = {"name": name, "model": {"shift": dict(SHIFT)}, "tests": tests,
           "sampler": {"walkers": 32, "max_steps": 600, "target_ess": 100, "seed": 3,
                       **(sampler or {})}}
    path = run / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    simulate_tests(load_config(path), overwrite=True)
    return path
