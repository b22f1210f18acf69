"""Specimens as a population (issue 11): coverage of the two-stage method and the time of one step.

1. Coverage: ``--populations`` (default 100) synthetic populations of ``--specimens`` (8) specimens,
   E_k ~ Normal(2850, 100) MPa. Stage 1 is drawn cheaply, NOT sampled: each specimen's posterior is
   4000 normal draws around a centre scattered by its own sd (25-60 MPa, as single HDPE tests give;
   tests/population_support.py says why this stands in for a full `sample`). Stage 2 is the package's
   (inference/population.py). Printed: the fraction of 90 % HDIs of mu_E and of s_E that hold the
   truth (target 80-97 %), the mean estimates and the Monte Carlo check's pass rate.
2. Time of the population step on 8 specimens with 40 000 draws each (a full run's worth: 32 walkers
   × 1250 kept steps), against the time of one single-test `fit` measured in the same run.

    .venv/bin/python benchmarks/population.py [--populations 100] [--specimens 8]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from population_support import MU, PRIOR, S, coverage, draw_population  # noqa: E402

from bayes_dnlr.inference.population import population  # noqa: E402


def step_time(n_specimens: int, n_draws: int = 40_000, repeats: int = 3) -> float:
    rng = np.random.default_rng(7)
    draws = draw_population(rng, n_specimens, n_draws)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        population(draws, dict.fromkeys(draws, PRIOR))
        best = min(best, time.perf_counter() - t0)
    return best


def fit_time() -> float:
    """One single-test least-squares fit of the shipped runs/hdpe-a-5e-3 (the baseline)."""
    import tempfile

    import yaml

    from bayes_dnlr.config import load_config
    from bayes_dnlr.pipeline.fit import fit

    root = Path(__file__).resolve().parents[1] / "runs" / "hdpe-a-5e-3"
    with tempfile.TemporaryDirectory() as tmp:
        raw = yaml.safe_load((root / "config.yaml").read_text())
        raw["data"]["file"] = str(root / raw["data"]["file"])
        raw["output"] = {"dir": tmp}
        path = Path(tmp) / "config.yaml"
        path.write_text(yaml.safe_dump(raw))
        cfg = load_config(path)
        fit(cfg, write=False)                # numba compile outside the timing
        t0 = time.perf_counter()
        fit(cfg, write=False)
        return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--populations", type=int, default=100)
    ap.add_argument("--specimens", type=int, default=8)
    args = ap.parse_args()
    print(f"load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f} "
          f"on {os.cpu_count()} cores")
    t0 = time.perf_counter()
    c = coverage(args.populations, n_specimens=args.specimens)
    el = time.perf_counter() - t0
    print(f"coverage over {c['n']} populations of {args.specimens} specimens (truth mu {MU:g}, s {S:g} MPa; "
          "stage 1: normal draws, not sampled):")
    print(f"  90 % HDI of mu_E holds the truth: {100 * c['mu']:.1f} %   (target 80-97 %)")
    print(f"  90 % HDI of s_E  holds the truth: {100 * c['s']:.1f} %   (target 80-97 %)")
    print(f"  mean posterior mean of mu_E {c['mu_mean']:.1f} MPa, of s_E {c['s_mean']:.1f} MPa")
    print(f"  Monte Carlo check passed in {100 * c['mc_passed']:.0f} % of populations ({el:.1f} s in all)")
    pop = step_time(args.specimens)
    base = fit_time()
    print(f"population step, {args.specimens} specimens x 40000 draws: {pop:.2f} s (target <= 10 s); "
          f"one single-test fit (runs/hdpe-a-5e-3) {base:.2f} s; ratio {pop / base:.2f}")


if __name__ == "__main__":
    main()
