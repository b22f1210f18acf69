"""Specimens as a population: coverage of the two-stage method and the time of one step.

1. Coverage: ``--populations`` (default 100) synthetic populations of ``--specimens`` (8) specimens,
   E_k ~ Normal(2850, 100) MPa. Stage 1 is drawn cheaply, NOT sampled: each specimen's posterior is
   4000 normal draws around a centre scattered by its own sd (25-60 MPa, as single HDPE tests give;
   tests/support/population.py says why this stands in for a full `sample`). Stage 2 is the package's
   (inference/analyses/population.py). Printed: the fraction of 90 % HDIs of mu_E and of s_E that hold the
   truth (target 80-97 %), the mean estimates and the Monte Carlo check's pass rate.
2. Time of the population step on 8 specimens with 40 000 draws each (a full run's worth: 32 walkers
   × 1250 kept steps), against the time of one single-test `fit` measured in the same run.

3. ``--big-joint``: why two stages. The six shipped specimens (runs/population/spec-*) sampled as ONE
   emcee run with E, G and tau_max per specimen (18 parameters, 40 walkers; a hierarchical run would
   add mu and s), against the six single runs (3 parameters each; they must be finished: `sample`
   each first): steps, autocorrelation times and sampling time to ESS >= 1000.

    .venv/bin/python benchmarks/population.py [--populations 100] [--specimens 8] [--big-joint]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from support.population import MU, PRIOR, S, coverage, draw_population  # noqa: E402

from bayes_dnlr.inference.analyses.population import population  # noqa: E402


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
    from bayes_dnlr.runs.fit import fit

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


def big_joint() -> None:
    """The six shipped specimens as one 18-parameter emcee run against their six single runs."""
    import json
    import tempfile

    import yaml

    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    root = Path(__file__).resolve().parents[1] / "runs" / "population"
    specs = sorted(root.glob("spec-*/config.yaml"))
    singles = []
    for c in specs:
        summary = c.parent / "summary.json"
        if not summary.is_file():
            sys.exit(f"{c.parent}: not sampled yet: run `python -m bayes_dnlr sample {c}` first")
        singles.append(json.loads(summary.read_text()))
    tests = []
    for c in specs:
        raw = yaml.safe_load(c.read_text())
        raw["data"]["file"] = str(c.parent / raw["data"]["file"])
        tests.append({"name": raw["name"], "data": raw["data"], "noise": raw["noise"]})
    priors = {"E": {"prior": "uniform", "low": 100, "high": 20000},
              "G": {"prior": "uniform", "low": 0, "high": 50},
              "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 10000}}
    with tempfile.TemporaryDirectory() as tmp:
        cfg_path = Path(tmp) / "config.yaml"
        cfg_path.write_text(yaml.safe_dump({
            "name": "bigjoint", "tests": tests, "output": {"dir": tmp},
            "parameters": {k: {**v, "per": "test"} for k, v in priors.items()},
            "sampler": {"walkers": 40, "max_steps": 20000, "target_ess": 1000, "seed": 1,
                        "checkpoint_every": 200}}))
        s = sample(load_config(cfg_path), progress=False).summary
    taus = [v for v in s["autocorr_time"].values()]
    st = [x["steps"] for x in singles]
    stau = [v for x in singles for v in x["autocorr_time"].values()]
    tsingle = sum(x["wall_time_s"] for x in singles)
    print(f"one emcee run, {len(s['posterior'])} parameters, 40 walkers: {s['steps']} steps, tau "
          f"{min(taus):.0f}-{max(taus):.0f}, sampling {s['wall_time_s']:.1f} s")
    print(f"{len(singles)} single runs, 3 parameters, 32 walkers: {min(st)}-{max(st)} steps, tau "
          f"{min(stau):.1f}-{max(stau):.1f}, sampling {tsingle:.1f} s in all; ratio "
          f"{s['wall_time_s'] / tsingle:.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--populations", type=int, default=100)
    ap.add_argument("--specimens", type=int, default=8)
    ap.add_argument("--big-joint", action="store_true", help="only part 3 (see the module doc)")
    args = ap.parse_args()
    if args.big_joint:
        big_joint()
        return
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
