"""Speed of ``design``: a grid of 50 conditions at a parameter guess, and a posterior average over
100 draws (one condition, then the 50-condition grid), against one sensitivity evaluation
(DNLR.basis with derivatives on the paper's 2000-point test) measured in the same run.
The target: <= 10 s for the grid of 50, or for the average over 100 draws.

    python benchmarks/design_speed.py [--run runs/hdpe-a-5e-3]

The posterior part needs a finished run; without one, the shipped example is sampled in a
temporary folder first (about 20 s). Timings on a shared 2-core machine are noisy.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from bayes_dnlr.model import DNLR
from bayes_dnlr.workflows.design.config import parse_design
from bayes_dnlr.workflows.design.run import run_design

ROOT = Path(__file__).resolve().parent.parent
GRID = {"strain_rate": {"low": 1e-3, "high": 5e-2, "n": 10}, "strain_max": [0.13, 0.5, 1.0, 1.9, 2.5],
        "sample_rate": 5}


def finished_run(path: str | None, tmp: Path) -> Path:
    if path is not None:
        return Path(path)
    shipped = ROOT / "runs" / "hdpe-a-5e-3"
    if (shipped / "posterior.nc").is_file() and (shipped / "summary.json").is_file():
        return shipped
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    run = tmp / "hdpe-a-5e-3"
    shutil.copytree(shipped, run,
                    ignore=shutil.ignore_patterns("*.h5", "*.nc", "*.json", "figures", "export"))
    print(f"(sampling the shipped example in {run} first)")
    sample(load_config(run / "config.yaml"), progress=False)
    return run


def timed(fn, repeat: int = 3) -> float:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return min(out)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--run", default=None)
    args = ap.parse_args()
    t = np.linspace(0, 380, 2000)
    model = DNLR(t, 5e-3 * t)
    model.basis(5.79, grad=True)
    base = statistics.median(timed(lambda: model.basis(5.79, grad=True), 1) for _ in range(20))
    print(f"baseline: one DNLR.basis with derivatives, 2000 points: {1e3 * base:.2f} ms")
    guess = parse_design({"name": "speed", "parameters": {"E": 2854.0, "G": 2.32, "tau_max": 5.79},
                          "noise": {"sigma0": 0.3}, "conditions": GRID})
    run_design(guess, write=False)     # numba cache, imports
    s = timed(lambda: run_design(guess, write=False))
    print(f"grid of 50 conditions, guess, white noise: {s:.2f} s ({s / base:.0f} baselines)")
    disc = guess.model_copy(update={"noise": parse_design({
        "name": "x", "parameters": {"E": 1, "G": 1, "tau_max": 1},
        "noise": {"sigma0": 0.3, "discrepancy": {"kernel": "exp", "amplitude": 0.5, "length": 10}},
        "conditions": GRID}).noise})
    s = timed(lambda: run_design(disc, write=False))
    print(f"grid of 50 conditions, guess, with the discrepancy (whitening): {s:.2f} s "
          f"({s / base:.0f} baselines)")
    with tempfile.TemporaryDirectory() as tmp:
        run = finished_run(args.run, Path(tmp))
        one = parse_design({"name": "speed", "from_run": str(run), "draws": 100,
                            "conditions": {"strain_rate": 5e-3, "strain_max": 1.9, "n_points": 2000}})
        s = timed(lambda: run_design(one, write=False))
        print(f"posterior average over 100 draws, 1 condition (2000 points): {s:.2f} s ({s / base:.0f} "
              "baselines)")
        grid = parse_design({"name": "speed", "from_run": str(run), "draws": 100, "conditions": GRID})
        s = timed(lambda: run_design(grid, write=False), 1)
        print(f"posterior average over 100 draws x 50 conditions: {s:.2f} s ({s / base:.0f} baselines)")


if __name__ == "__main__":
    main()
