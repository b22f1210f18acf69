"""Synthetic run directories made the way a user makes them: a config with a truth: section, then
``simulate`` writes the data file it describes."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from bayes_dnlr.config import load_config
from bayes_dnlr.workflows.simulate import simulate_test

HDPE = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
TINY_SAMPLER = {"walkers": 16, "max_steps": 100, "target_ess": 50, "seed": 1, "checkpoint_every": 50}
WIDE_RELAXATION_PRIORS = {
    "E": {"prior": "uniform", "low": 100, "high": 20000},
    "G": {"prior": "uniform", "low": 0, "high": 5000},
    "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 10000},
    "sigma_inf": {"prior": "uniform", "low": 0, "high": 100},
    "tau_max_R": {"prior": "log-uniform", "low": 0.01, "high": 100000},
}


def make_run(folder: Path, name: str, truth: dict[str, Any], *, data: dict | None = None,
             parameters: dict | None = None, sigma0: float = 0.1, sampler: dict | None = None) -> Path:
    """Write ``folder/name/config.yaml`` (stress and strain columns, the run directory is that
    folder), simulate its data file; return the config path."""
    run = folder / name
    run.mkdir(parents=True, exist_ok=True)
    raw: dict[str, Any] = {
        "name": name,
        "data": {"file": "data.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
                 "observable": "stress", **(data or {})},
        "noise": {"sigma0": sigma0},
        "sampler": {**TINY_SAMPLER, **(sampler or {})},
        "truth": truth,
    }
    if parameters is not None:
        raw["parameters"] = parameters
    path = run / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    simulate_test(load_config(path))
    return path


def ramp_truth(strain_max: float, n_points: int = 300, params: dict | None = None,
               stress_sd: float = 0.1) -> dict[str, Any]:
    """A ramp at 5e-3 1/s to ``strain_max`` (the paper's HDPE by default)."""
    return {"params": params or HDPE, "strain_rate": 5e-3, "strain_max": strain_max,
            "n_points": n_points, "noise": {"strain_sd": 0.0, "stress_sd": stress_sd}, "seed": 7}


def small_ramp_relaxation_truth(sigma_inf: float = 6.0, hold: float = 300.0) -> dict[str, Any]:
    """Like a real stress-relaxation test: a ramp to strain 0.0077 (8 samples), then a long hold."""
    return {"params": {"E": 1200.0, "G": 30.0, "tau_max": 8.0, "sigma_inf": sigma_inf,
                       "tau_max_R": 50.0},
            "strain_rate": 5e-3, "strain_max": 0.0077, "hold": hold, "sample_rate": 5,
            "noise": {"strain_sd": 0.0, "stress_sd": 0.05}, "seed": 11}
