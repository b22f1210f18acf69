"""Synthetic tests for the sampling tests: a ramp test as TestData, and a config + CSV on disk."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from bayes_dnlr.data import TestData
from bayes_dnlr.model import simulate

TRUTH = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
TRUTH_RELAX = {"E": 1200.0, "G": 1.5, "tau_max": 8.0, "sigma_inf": 15.0, "tau_max_R": 20.0}


def ramp(rate: float = 5e-3, strain_max: float = 1.9, n: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    strain = np.linspace(0.0, strain_max, n)
    return strain / rate, strain


def relaxation_history(rate: float = 5e-3, strain_max: float = 0.5, n_ramp: int = 400,
                       hold: float = 600.0, n_hold: int = 300) -> tuple[np.ndarray, np.ndarray, float]:
    t1, e1 = ramp(rate, strain_max, n_ramp)
    t2 = t1[-1] + np.linspace(0.0, hold, n_hold + 1)[1:]
    return np.concatenate([t1, t2]), np.concatenate([e1, np.full(n_hold, strain_max)]), float(t1[-1])


def make_test(params: dict[str, float] | None = None, sigma: float = 0.3, seed: int = 0,
              n: int = 2000, relaxation: bool = False, window: np.ndarray | None = None) -> TestData:
    """A TestData of the DNLR model plus Gaussian stress noise (strain exact)."""
    rng = np.random.default_rng(seed)
    if relaxation:
        params = params or TRUTH_RELAX
        t, e, t_switch = relaxation_history()
    else:
        params = params or TRUTH
        t, e = ramp(n=n)
        t_switch = None
    true = simulate(t, e, params, relaxation_start=t_switch)
    y = true + rng.normal(0.0, sigma, t.size)
    return TestData(path=Path("synthetic.csv"), sha256="0" * 64, time=t, strain=e, strain_input=e,
                    stress=y, nominal_strain=np.expm1(e), nominal_stress=None,
                    window=np.ones(t.size, bool) if window is None else window,
                    relaxation_start=t_switch, strain_rate=5e-3, observable="stress")


def write_case(folder: Path, name: str = "syn", *, params: dict[str, float] | None = None,
               sigma: float = 0.3, seed: int = 0, n: int = 2000, relaxation: bool = False,
               sampler: dict | None = None, noise: object = 0.3, parameters: dict | None = None,
               extra: dict | None = None) -> Path:
    """Write a CSV (time, strain, stress) and a config.yaml in ``folder/name``; return the config path."""
    test = make_test(params, sigma, seed, n, relaxation)
    run = folder / name
    run.mkdir(parents=True, exist_ok=True)
    data = np.column_stack([test.time, test.strain, test.stress])
    np.savetxt(run / "data.csv", data, delimiter=",", header="t_s,eps,stress_MPa", comments="",
               fmt="%.10g")
    raw: dict = {
        "name": name,
        "data": {"file": "data.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "stress_MPa"},
                 "observable": "stress", "strain_input": "measured"},
        "model": {"modes": 50, "decades": 6},
        "noise": {"sigma0": noise},
        "sampler": {"walkers": 32, "max_steps": 600, "target_ess": 200, "seed": 1,
                    "checkpoint_every": 50, **(sampler or {})},
    }
    if relaxation:
        raw["data"]["relaxation_start"] = test.relaxation_start
    if parameters is not None:
        raw["parameters"] = parameters
    raw.update(extra or {})
    path = run / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path
