"""Synthetic runs with several tests (``tests:``) made the way a user makes them: a config with each
test's truth: section, then ``simulate`` writes every test's data file."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from bayes_dnlr.config import load_config
from bayes_dnlr.workflows.simulate import simulate_tests

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


def recovery(folder: Path, seed: int = 0, n_points: int = 400, stress_sd: float = 0.3) -> dict[str, Any]:
    """Joint recovery on a synthetic three-rate set (one E and G, tau_max per test, the paper's
    protocol to strain 1.9): the joint posterior beside each test sampled alone, all with the default
    sampler (ESS >= 1000) and the default noise model. Returns the figures of the joint recovery."""
    import json
    import time

    from bayes_dnlr.runs.sample import sample

    run = folder / "joint"
    run.mkdir(parents=True, exist_ok=True)
    taus = {"r2.5e-3": 10.64, "r5e-3": 5.79, "r1e-2": 3.15}
    tests = []
    for i, (t, rate) in enumerate(RATES.items()):
        spec = rate_test(t, rate, {**SHARED, "tau_max": taus[t]}, n_points=n_points, strain_max=1.9,
                         stress_sd=stress_sd, seed=100 * seed + i + 1, discrepancy=True)
        spec["data"]["window"] = {"strain_max": 1.9}
        tests.append(spec)
    # the stopping rule is checked at every checkpoint: 100 steps keeps the step counts comparable
    sampler = {"walkers": 32, "max_steps": 20000, "target_ess": 1000, "seed": seed + 1,
               "checkpoint_every": 100}
    raw = {"name": "joint", "tests": tests, "sampler": sampler,
           "parameters": {"tau_max": {"prior": "log-uniform", "low": 0.01, "high": 10000, "per": "test"}}}
    (run / "config.yaml").write_text(yaml.safe_dump(raw, sort_keys=False))
    cfg = load_config(run / "config.yaml")
    simulate_tests(cfg)
    out: dict[str, Any] = {"single": {}}
    for t in RATES:
        view = cfg.for_test(t)
        t0 = time.perf_counter()
        s = sample(view, progress=False).summary
        out["single"][t] = {"E_mean": s["posterior"]["E"]["mean"], "E_sd": s["posterior"]["E"]["sd"],
                            "sampling_s": s["wall_time_s"], "total_s": time.perf_counter() - t0,
                            "steps": s["steps"], "n_points": s["n_points"]}
    t0 = time.perf_counter()
    s = sample(cfg, progress=False).summary
    total = time.perf_counter() - t0
    post = s["posterior"]
    best = min(v["E_sd"] for v in out["single"].values())
    out["joint"] = {
        "E_mean": post["E"]["mean"], "E_sd": post["E"]["sd"],
        "E_z": (post["E"]["mean"] - SHARED["E"]) / post["E"]["sd"],
        "sd_ratio_to_best_single": post["E"]["sd"] / best,
        "r_hat_max": max(v["r_hat"] for v in post.values()),
        "ess_bulk_min": min(v["ess_bulk"] for v in post.values()),
        "ess_tail_min": min(v["ess_tail"] for v in post.values()),
        "sampling_s": s["wall_time_s"], "total_s": total, "steps": s["steps"],
        "parameters": list(post), "converged": s["converged"],
    }
    singles = out["single"].values()
    out["time_ratio_sampling_to_mean_single"] = s["wall_time_s"] / np.mean([v["sampling_s"] for v in singles])
    out["time_ratio_total_to_mean_single"] = total / np.mean([v["total_s"] for v in singles])
    # load-independent: model points evaluated (steps x points; the walkers are the same)
    out["work_ratio_to_mean_single"] = (s["steps"] * s["n_points"]
                                        / np.mean([v["steps"] * v["n_points"] for v in singles]))
    (folder / "recovery.json").write_text(json.dumps(out, indent=2))
    return out
