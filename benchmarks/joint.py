"""Joint recovery and speed: three rates with one E and G, tau_max per test.

A synthetic three-rate set (2.5e-3, 5e-3, 1e-2 1/s to Hencky strain 1.9, ``--points`` samples each,
stress noise 0.3 MPa; E 2854, G 2.32, tau_max 10.64 / 5.79 / 3.15 s) is sampled test by test and
jointly, every run with the default sampler (32 walkers, ESS >= 1000) and the default noise model
(the discrepancy, which falls back to white noise where a test shows no model error). Printed per
seed: the joint E, its distance to the truth in posterior sd (target within 3), its sd against the
best single-test posterior sd (target <= 0.75), the largest R-hat (<= 1.01) and the smallest ESS
(>= 1000) over every parameter, and the joint sampling time against the mean single-test time
measured in the same run (target <= 3x), with the load-independent work ratio (steps x model
points: the joint likelihood evaluates every test's model at each step).

    .venv/bin/python benchmarks/joint.py [--seeds 0 1 2] [--points 400]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from support.joint import SHARED, recovery  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--points", type=int, default=400)
    args = ap.parse_args()
    print(f"load before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    print(f"truth E {SHARED['E']:g} MPa; {args.points} points per test")
    head = (f"{'seed':>4} {'joint E':>9} {'sd':>6} {'z':>6} {'sd/best':>8} {'R-hat max':>9} "
            f"{'ESS min':>8} {'steps':>6} {'joint s':>8} {'single s':>24} {'ratio':>6} {'ratio total':>11} "
            f"{'work ratio':>10}")
    print(head)
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            r = recovery(Path(tmp), seed, n_points=args.points)
        j = r["joint"]
        singles = " / ".join(f"{v['sampling_s']:.1f}" for v in r["single"].values())
        print(f"{seed:>4} {j['E_mean']:>9.1f} {j['E_sd']:>6.1f} {j['E_z']:>+6.2f} "
              f"{j['sd_ratio_to_best_single']:>8.3f} {j['r_hat_max']:>9.4f} "
              f"{min(j['ess_bulk_min'], j['ess_tail_min']):>8.0f} {j['steps']:>6} {j['sampling_s']:>8.1f} "
              f"{singles:>24} {r['time_ratio_sampling_to_mean_single']:>6.2f} "
              f"{r['time_ratio_total_to_mean_single']:>11.2f} {r['work_ratio_to_mean_single']:>10.2f}")
        print("      single-test E: " + ", ".join(
            f"{t} {v['E_mean']:.0f} ± {v['E_sd']:.1f} ({v['steps']} steps)" for t, v in r["single"].items()))
    print(f"load after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print("ratio: joint sampling time / mean single-test sampling time; ratio total: fit + sample "
          "wall time of the joint run / mean single-test fit + sample wall time;\nwork ratio: steps x "
          "model points of the joint run / the mean single test's (load-independent; same walkers)")


if __name__ == "__main__":
    main()
