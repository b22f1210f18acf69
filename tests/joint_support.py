"""Synthetic runs with several tests (``tests:``) made the way a user makes them: a config with each
test's truth: section, then ``simulate`` writes every test's data file."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from bayes_dnlr.config import load_config
from bayes_dnlr.synthetic import simulate_tests

RATES = {"r2.5e-3": 2.5e-3, "r5e-3": 5e-3, "r1e-2": 1e-2}
# one E and G, a rate-dependent tau_max (shorter at higher rate, as in the paper's Table 3)
SHARED = {"E": 2854.0, "G": 2.32}
TAU_MAX = {"r2.5e-3": 8.0, "r5e-3": 5.79, "r1e-2": 4.0}
TINY_SAMPLER = {"walkers": 16, "max_steps": 120, "target_ess": 50, "seed": 1, "checkpoint_every": 60}


def rate_test(name: str, rate: float, params: dict[str, float], *, n_points: int = 150,
              strain_max: float = 0.6, stress_sd: float = 0.1, seed: int = 1,
              discrepancy: bool = False) -> dict[str, Any]:
    """One entry of ``tests:``: a ramp at ``rate`` with its truth and noise."""
    noise: dict[str, Any] = {"sigma0": stress_sd}
    if not discrepancy:
        noise["discrepancy"] = "none"
    return {
        "name": name,
        "data": {"file": f"{name}.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
                 "observable": "stress"},
        "noise": noise,
        "truth": {"params": params, "strain_rate": rate, "strain_max": strain_max, "n_points": n_points,
                  "noise": {"strain_sd": 0.0, "stress_sd": stress_sd}, "seed": seed},
    }


def e_at(rate: float, e0: float = SHARED["E"], per_decade: float = 0.0, ref: float = 2.5e-3) -> float:
    """E rising by ``per_decade`` (0.1 = 10 %) per decade of rate from ``e0`` at ``ref``."""
    return e0 * (1.0 + per_decade) ** math.log10(rate / ref)


def make_joint(folder: Path, name: str = "joint", *, per_test: tuple[str, ...] = ("tau_max",),
               e_per_decade: float = 0.0, sampler: dict | None = None, n_points: int = 150,
               stress_sd: float = 0.1, discrepancy: bool = False, extra: dict | None = None) -> Path:
    """Write ``folder/name/config.yaml`` for the three rates and simulate their files; return the
    config path. ``per_test``: the parameters with ``per: test``."""
    run = folder / name
    run.mkdir(parents=True, exist_ok=True)
    tests = []
    for i, (t, rate) in enumerate(RATES.items()):
        params = {"E": e_at(rate, per_decade=e_per_decade), "G": SHARED["G"], "tau_max": TAU_MAX[t]}
        tests.append(rate_test(t, rate, params, n_points=n_points, stress_sd=stress_sd, seed=11 + i,
                               discrepancy=discrepancy))
    priors = {"E": {"prior": "uniform", "low": 100, "high": 20000},
              "G": {"prior": "uniform", "low": 0, "high": 50},
              "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 10000}}
    for k in per_test:
        priors[k]["per"] = "test"
    raw: dict[str, Any] = {"name": name, "tests": tests, "parameters": priors,
                           "sampler": {**TINY_SAMPLER, **(sampler or {})}, **(extra or {})}
    path = run / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    simulate_tests(load_config(path))
    return path
