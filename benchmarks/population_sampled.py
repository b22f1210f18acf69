"""Population coverage with real stage-1 posteriors: every specimen fitted and sampled.

``benchmarks/population.py`` draws each specimen's posterior cheaply (normal draws). Here every
specimen is a synthetic test (a 5e-3 1/s ramp to strain 1.9, ``--points`` points, stress noise 0.3
MPa) with its own true E_k ~ Normal(2850, 100) MPa (G = 2.32 MPa, tau_max = 5.79 s), run through
`fit` and `sample` by the batch runner (joblib, ``--jobs`` processes; no report, no population step),
and each population of ``--specimens`` runs is pooled by the `population` command's code. Printed:
the share of 90 % HDIs of mu_E and s_E that hold the generating values (target 80-97 %), the mean
estimates, the Monte Carlo check's pass rate and the time.

    .venv/bin/python benchmarks/population_sampled.py [--populations 50] [--specimens 8] \
        [--points 500] [--target-ess 400] [--jobs 2] [--out DIR]

Resumable: with ``--out``, a rerun reuses the finished runs (the batch skips them).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from support.population import MU, S  # noqa: E402
from support.sampling import TRUTH, write_case  # noqa: E402

from bayes_dnlr.workflows.batch.page import run_campaign  # noqa: E402
from bayes_dnlr.workflows.population.run import run_population  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--populations", type=int, default=50)
    ap.add_argument("--specimens", type=int, default=8)
    ap.add_argument("--points", type=int, default=500)
    ap.add_argument("--target-ess", type=float, default=400.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--out", type=Path, default=None, help="folder for the runs (default: a temporary one)")
    args = ap.parse_args()
    tmp = None if args.out is not None else tempfile.TemporaryDirectory()
    root = args.out if args.out is not None else Path(tmp.name)
    rng = np.random.default_rng(args.seed)
    true_e = rng.normal(MU, S, (args.populations, args.specimens))
    configs = []
    for p in range(args.populations):
        for k in range(args.specimens):
            params = dict(TRUTH, E=float(true_e[p, k]))
            configs.append(write_case(root / f"pop{p:03d}", f"p{p:03d}-spec{k + 1}", params=params,
                                      n=args.points, seed=10_000 * p + k,
                                      sampler={"target_ess": args.target_ess, "max_steps": 20000,
                                               "checkpoint_every": 100, "seed": k + 1}))
    print(f"{args.populations} populations x {args.specimens} specimens, E_k ~ Normal({MU:g}, {S:g}) MPa; "
          f"{args.points} points per test, target ESS {args.target_ess:g}; {args.jobs} processes; "
          f"load average {os.getloadavg()[0]:.2f}")
    t0 = time.perf_counter()
    result = run_campaign([str(c) for c in configs], out=root / "batch", n_jobs=args.jobs, report=False,
                          progress=True, population=False)
    t_batch = time.perf_counter() - t0
    if result.failed:
        print(f"{len(result.failed)} tests failed; their populations are left out")
    failed = {os.path.realpath(r["run_dir"]) for r in result.failed if r.get("run_dir")}
    cover_mu, cover_s, mu_mean, s_mean, passed, sd_e = [], [], [], [], [], []
    t1 = time.perf_counter()
    for p in range(args.populations):
        runs = [c.parent for c in configs[p * args.specimens:(p + 1) * args.specimens]]
        if any(os.path.realpath(r) in failed for r in runs):
            continue
        pop = run_population(runs, write=False).result
        lo, hi = pop.mu["hdi_90"]
        slo, shi = pop.s["hdi_90"]
        cover_mu.append(lo <= MU <= hi)
        cover_s.append(slo <= S <= shi)
        mu_mean.append(pop.mu["mean"])
        s_mean.append(pop.s["mean"])
        passed.append(pop.passed)
        sd_e += [pop.specimens[k]["own"]["sd"] for k in pop.names]
    t_pop = time.perf_counter() - t1
    n = len(cover_mu)
    print(f"stage 1 (fit + sample of {len(configs)} tests): {t_batch:.0f} s; stage 2 ({n} populations): "
          f"{t_pop:.1f} s, {t_pop / max(n, 1):.2f} s each")
    print(f"each specimen's own posterior sd of E: median {np.median(sd_e):.1f} MPa "
          f"(range {np.min(sd_e):.1f}-{np.max(sd_e):.1f})")
    print(f"coverage of the 90 % HDI over {n} populations: mu_E {np.mean(cover_mu):.2f}, "
          f"s_E {np.mean(cover_s):.2f} (target 0.80-0.97)")
    print(f"mean estimates: mu_E {np.mean(mu_mean):.1f} (true {MU:g}), s_E {np.mean(s_mean):.1f} "
          f"(true {S:g}); Monte Carlo check passed in {np.mean(passed):.2f}")
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
