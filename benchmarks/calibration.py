"""Calibration of the posterior: do 90 % credible intervals hold the truth 90 % of the time?

``--replicates`` synthetic ramp tests (5e-3 1/s to strain 1.9, 2000 points, E 2854, G 2.32,
tau_max 5.79), each with fresh Gaussian stress noise (sd 0.3 MPa, exact strain input), go through
the whole ``sample`` pipeline (CSV -> fit -> emcee to ESS >= 1000 -> summary.json). For each
parameter: the fraction of 90 % HDIs that hold the true value (target 84-96 % for >= 100
replicates) and the mean and sd of z = (posterior mean - truth) / posterior sd (0 and 1 when the
posterior is calibrated).

    .venv/bin/python benchmarks/calibration.py [--replicates 100] [--jobs 2] [--sigma0 fixed|sampled]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from sampling_support import TRUTH, calibration, coverage  # noqa: E402

BAND = (0.84, 0.96)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicates", type=int, default=100)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--sigma0", choices=("fixed", "sampled"), default="fixed",
                    help="fixed: sigma0 = 0.3 MPa known; sampled: half-normal(5) prior on sigma0")
    args = ap.parse_args()
    noise = 0.3 if args.sigma0 == "fixed" else {"prior": "half-normal", "scale": 5.0}
    truth = dict(TRUTH)
    if args.sigma0 == "sampled":
        truth["sigma0"] = 0.3
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        results = calibration(args.replicates, Path(tmp), jobs=args.jobs, noise=noise)
    wall = time.perf_counter() - t0
    cov = coverage(results, truth)
    n = len(results)
    conv = sum(r["_run"]["converged"] for r in results)
    steps = sorted(r["_run"]["steps"] for r in results)
    print(f"{n} replicates, sigma0 {args.sigma0}, {wall:.0f} s ({args.jobs} jobs); converged {conv}/{n}; "
          f"steps median {steps[n // 2]} (range {steps[0]}-{steps[-1]})")
    half = 1.96 * math.sqrt(0.9 * 0.1 / n)
    print(f"binomial 95 % range of the coverage for a calibrated 90 % interval: "
          f"{0.9 - half:.3f}-{0.9 + half:.3f}; required {BAND[0]:.2f}-{BAND[1]:.2f}")
    print(f"{'parameter':<10} {'coverage':>9} {'z mean':>7} {'z sd':>6}  verdict")
    ok = True
    for k, c in cov.items():
        good = BAND[0] <= c["coverage"] <= BAND[1]
        ok &= good
        print(f"{k:<10} {c['coverage']:>9.3f} {c['z_mean']:>+7.3f} {c['z_sd']:>6.3f}  "
              f"{'ok' if good else 'OUT OF BAND'}")
    rhat = max(r[k]["r_hat"] for r in results for k in cov)
    ess = min(r[k]["ess"] for r in results for k in cov)
    print(f"worst R-hat {rhat:.4f}, smallest ArviZ ESS {ess:.0f}")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
