"""Synthetic tests for the sampling tests: a ramp test as TestData, and a config + CSV on disk."""

from __future__ import annotations

import math
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


def correlated_error(time: np.ndarray, kind: str, amplitude: float, length: float,
                     rng: np.random.Generator) -> np.ndarray:
    """A draw of a zero-mean stationary Gaussian process on ``time``: a smooth model error.

    kind: exp (Ornstein-Uhlenbeck), matern32, or matern52 (smoother than anything the package
    models: k = a² (1 + u + u²/3) e^{-u}, u = √5 τ/ℓ)."""
    tau = np.abs(time[:, None] - time[None, :])
    if kind == "matern52":
        u = math.sqrt(5.0) * tau / length
        K = amplitude**2 * (1.0 + u + u * u / 3.0) * np.exp(-u)
    else:
        from bayes_dnlr.inference.discrepancy.gp import covariance

        K = covariance(time, amplitude, length, kind)
    K[np.diag_indices_from(K)] += 1e-10 * amplitude**2
    return np.linalg.cholesky(K) @ rng.standard_normal(time.size)


def make_test(params: dict[str, float] | None = None, sigma: float = 0.3, seed: int = 0,
              n: int = 2000, relaxation: bool = False, window: np.ndarray | None = None,
              error: tuple[str, float, float] | None = None) -> TestData:
    """A TestData of the DNLR model plus Gaussian stress noise (strain exact), plus a correlated
    model error ``error`` = (kind, amplitude MPa, length s) when given."""
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
    if error is not None:
        y = y + correlated_error(t, *error, rng)
    return TestData(path=Path("synthetic.csv"), sha256="0" * 64, time=t, strain=e, strain_input=e,
                    stress=y, nominal_strain=np.expm1(e), nominal_stress=None,
                    window=np.ones(t.size, bool) if window is None else window,
                    relaxation_start=t_switch, strain_rate=5e-3, observable="stress")


def write_case(folder: Path, name: str = "syn", *, params: dict[str, float] | None = None,
               sigma: float = 0.3, seed: int = 0, n: int = 2000, relaxation: bool = False,
               sampler: dict | None = None, noise: object = 0.3, parameters: dict | None = None,
               extra: dict | None = None, discrepancy: object = "none",
               error: tuple[str, float, float] | None = None) -> Path:
    """Write a CSV (time, strain, stress) and a config.yaml in ``folder/name``; return the config path.

    The likelihood is white (``discrepancy: none``) unless ``discrepancy`` says otherwise (a
    mapping, or "default" for the package's default discrepancy): these synthetic tests have white
    noise, and the machinery tests compare with exact white results."""
    test = make_test(params, sigma, seed, n, relaxation, error=error)
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
        "noise": {"sigma0": noise} | ({} if discrepancy == "default" else {"discrepancy": discrepancy}),
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


def _replicate(args: tuple) -> dict[str, dict[str, float]]:
    """One calibration replicate: fresh noise, fit, sample; per parameter mean, sd, 90 % HDI."""
    folder, r, base_seed, sampler, noise, case = args
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    path = write_case(Path(folder), f"rep{r:04d}", seed=base_seed + r, noise=noise,
                      sampler={"max_steps": 20000, "target_ess": 1000, "checkpoint_every": 100,
                               "seed": r + 1, **sampler}, **case)
    s = sample(load_config(path), progress=False).summary
    out = {k: {"mean": p["mean"], "sd": p["sd"], "lo": p["hdi_90"][0], "hi": p["hdi_90"][1],
               "r_hat": p["r_hat"], "ess": min(p["ess_bulk"], p["ess_tail"])}
           for k, p in s["posterior"].items()}
    noise = s.get("noise") or {}
    out["_run"] = {"steps": s["steps"], "converged": s["stop_reason"] == "converged",
                   "wall_time_s": s["wall_time_s"],
                   "kernel": noise.get("kernel") if noise.get("model") == "discrepancy" else None,
                   "weights": (noise.get("kernel_choice") or {}).get("weights"),
                   "sd_factor": (noise.get("projection") or {}).get("sd_factor")}
    return out


def calibration(replicates: int, folder: Path, *, jobs: int = 2, base_seed: int = 10_000,
                sampler: dict | None = None, noise: object = 0.3,
                **case) -> list[dict[str, dict[str, float]]]:
    """Noisy replicates of the synthetic ramp test (TRUTH, noise 0.3 MPa, exact strain input).

    ``case``: more write_case keys, e.g. ``error=("matern52", 0.5, 30.0)`` (a correlated model
    error added to the data), ``discrepancy="default"`` (the default likelihood) or ``n=1000``."""
    args = [(str(folder), r, base_seed, sampler or {}, noise, case) for r in range(replicates)]
    if jobs <= 1:
        return [_replicate(a) for a in args]
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(jobs, mp_context=mp.get_context("spawn")) as pool:
        return list(pool.map(_replicate, args))


def coverage(results: list[dict[str, dict[str, float]]], truth: dict[str, float]) -> dict[str, dict]:
    """Per parameter: fraction of 90 % HDIs holding the truth, and the sd of z = (mean - truth)/sd."""
    out = {}
    for k in truth:
        if k not in results[0]:
            continue
        inside = [r[k]["lo"] <= truth[k] <= r[k]["hi"] for r in results]
        z = np.array([(r[k]["mean"] - truth[k]) / r[k]["sd"] for r in results])
        out[k] = {"coverage": float(np.mean(inside)), "z_mean": float(z.mean()),
                  "z_sd": float(z.std(ddof=1)), "n": len(results)}
    return out


def with_sampler(cfg: Path, **sampler) -> Path:
    """``cfg`` with these ``sampler:`` keys (and its name set to its folder's, as a copied run's)."""
    raw = yaml.safe_load(cfg.read_text())
    raw["name"] = cfg.parent.name
    raw["sampler"].update(sampler)
    cfg.write_text(yaml.safe_dump(raw, sort_keys=False))
    return cfg


def taken_further_and_in_one_go(cfg: Path, steps: int):
    """The finished short run of ``cfg`` taken further to ``steps``, and a copy of it sampled to
    ``steps`` in one go from an empty run folder beside it: their two chains (StoredRun)."""
    import shutil

    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.chains import read_run
    from bayes_dnlr.runs.sample import sample

    run = cfg.parent
    one = with_sampler(Path(shutil.copytree(run, run.parent / f"{run.name}-one")) / cfg.name,
                       max_steps=steps)
    for name in ("chains.h5", "posterior.nc", "summary.json"):
        (one.parent / name).unlink()
    sample(load_config(one), progress=False)
    sample(load_config(with_sampler(cfg, max_steps=steps)), progress=False)
    return read_run(run / "chains.h5"), read_run(one.parent / "chains.h5")

