"""Speed of ``sample``: wall time to ESS >= 1000, log-posterior evaluations per second, storage overhead.

On the 2000-point 3-parameter example (default runs/hdpe-a-5e-3, copied to a temporary folder so
the shipped run is not touched), 32 walkers, target_ess 1000:

- numba: the first model evaluation in a fresh process (cache load or compile), reported apart;
- fit: the least-squares fit that ``sample`` runs first, reported apart;
- sampling: the loop to convergence (emcee + model + checkpoints), from summary.json's wall_time_s;
- outputs: ArviZ statistics, posterior.nc and summary.json;
- storage overhead: time spent writing checkpoints / sampling time, measured inside the loop, and
  checked against the same run with checkpoints as rare as possible.

    .venv/bin/python benchmarks/sample.py [config.yaml] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
COMPILE_PROBE = """
import time, numpy as np
t0 = time.perf_counter()
from bayes_dnlr.model import DNLR
t1 = time.perf_counter()
m = DNLR(np.linspace(0, 380, 2000), np.linspace(0, 1.9, 2000))
m.basis(5.79)
t2 = time.perf_counter()
m.basis(5.8)
t3 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2)
"""


def copy_run(config: Path, folder: Path, **sampler) -> Path:
    raw = yaml.safe_load(config.read_text())
    run = folder / raw["name"]
    run.mkdir(parents=True)
    shutil.copy(config.parent / raw["data"]["file"], run / raw["data"]["file"])
    raw["sampler"].update(sampler)
    (run / "config.yaml").write_text(yaml.safe_dump(raw, sort_keys=False))
    return run / "config.yaml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", nargs="?", default=str(ROOT / "runs/hdpe-a-5e-3/config.yaml"))
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    config = Path(args.config)

    with tempfile.TemporaryDirectory() as cache:
        for label, env in (("cold compile (empty NUMBA_CACHE_DIR)", {"NUMBA_CACHE_DIR": cache}),
                           ("cached", {})):
            out = subprocess.run([sys.executable, "-c", COMPILE_PROBE], capture_output=True, text=True,
                                 check=True, cwd=ROOT, env={**os.environ, **env})
            imp, first, second = map(float, out.stdout.split())
            print(f"numba, fresh process, {label}: import {imp:.2f} s, first evaluation {first:.3f} s, "
                  f"next one {1e6 * second:.0f} µs")

    t0 = time.perf_counter()
    import arviz  # noqa: F401
    import emcee  # noqa: F401
    t_imp = time.perf_counter() - t0
    print(f"imports emcee + arviz: {t_imp:.2f} s (once per process, not counted below)")

    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.sample import sample

    rows = []
    for _ in range(args.repeats):
        with tempfile.TemporaryDirectory() as tmp:
            cfg = load_config(copy_run(config, Path(tmp), target_ess=1000, walkers=32))
            t0 = time.perf_counter()
            fit(cfg)
            t_fit = time.perf_counter() - t0
            t0 = time.perf_counter()
            post = sample(cfg, progress=False)
            t_total = time.perf_counter() - t0
            s = post.summary
            ess_min = min(min(p["ess_bulk"], p["ess_tail"]) for p in s["posterior"].values())
            ess_tau = min(s["ess_autocorr"].values())
            rows.append((t_fit, s["wall_time_s"], t_total - s["wall_time_s"], t_total, s["steps"],
                         ess_tau, ess_min, s["log_prob_evals_per_s"], s["storage_overhead"],
                         max(s["autocorr_time"].values()), s["stop_reason"]))
            # the same chain with a single checkpoint at the end: the cost of checkpointing
            cfg2 = load_config(copy_run(config, Path(tmp) / "rare", max_steps=s["steps"],
                                        target_ess=1e12, checkpoint_every=s["steps"]))
            fit(cfg2)
            post2 = sample(cfg2, progress=False)
            rows[-1] += (s["wall_time_s"] / post2.summary["wall_time_s"] - 1.0,)
    print(f"\n{config.parent.name}: 2000 points, 3 parameters, 32 walkers, target ESS 1000, "
          f"moves {s['moves']}")
    print(f"{'run':>3} {'fit s':>6} {'sampling s':>10} {'outputs s':>9} {'sample() s':>10} {'steps':>6} "
          f"{'ESS(tau)':>8} {'ESS arviz':>9} {'evals/s':>8} {'store %':>7} {'A/B %':>6} {'tau':>5}")
    for i, r in enumerate(rows):
        print(f"{i:>3} {r[0]:>6.2f} {r[1]:>10.2f} {r[2]:>9.2f} {r[3]:>10.2f} {r[4]:>6d} {r[5]:>8.0f} "
              f"{r[6]:>9.0f} {r[7]:>8.0f} {100 * r[8]:>7.1f} {100 * r[11]:>6.1f} {r[9]:>5.1f}  {r[10]}")
    best = min(rows, key=lambda r: r[3])
    print(f"\nwall time to ESS >= 1000 (sample(), fit and numba compile excluded): best {best[3]:.2f} s "
          f"(sampling loop {best[1]:.2f} s); target <= 10 s")
    print(f"log-posterior evaluations per second: {best[7]:.0f}; storage overhead {100 * best[8]:.1f} % "
          "(target <= 10 %)")


if __name__ == "__main__":
    main()
