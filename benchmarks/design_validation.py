"""Does the design's prediction come true? For a few designs (one planned test each), simulate
N tests with the planned conditions and the design's noise (white σ0, and the model discrepancy in
two of them), fit each (``fit``: GLS with the known hyperparameters when there is a discrepancy),
and compare the spread of the estimates with the predicted sd. A correct prediction gives a ratio
within the printed 95 % band (χ² with N-1 dof); the acceptance is |ratio - 1| <= 20 %.

    python benchmarks/design_validation.py [--tests 100] [--jobs 2]
"""

from __future__ import annotations

import argparse
import time

from bayes_dnlr.workflows.design.validate import validate_design

GUESS = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
DESIGNS = {
    "A: paper A_//, interval II, white": {
        "noise": {"sigma0": 0.3},
        "conditions": {"strain_rate": 5e-3, "strain_max": 1.9, "n_points": 2000}},
    "B: interval I (G fixed), white": {
        "noise": {"sigma0": 0.3},
        "conditions": {"strain_rate": 1e-2, "strain_max": 0.5, "n_points": 2000,
                       "windows": {"I": {"strain_max": 0.13, "fixed": ["G"]}}}},
    "C: exp discrepancy, time axis": {
        "noise": {"sigma0": 0.3, "discrepancy": {"kernel": "exp", "axis": "time", "amplitude": 0.5,
                                                 "length": 5.0}},
        "conditions": {"strain_rate": 1e-2, "strain_max": 1.0, "n_points": 2000}},
    "D: matern32 discrepancy, strain axis": {
        "noise": {"sigma0": 0.3, "discrepancy": {"kernel": "matern32", "axis": "strain",
                                                 "amplitude": 1.0, "length": 0.05}},
        "conditions": {"strain_rate": 2e-2, "strain_max": 1.9, "sample_rate": 20}},
    "E: exp discrepancy pinned at the start": {
        "noise": {"sigma0": 0.3, "discrepancy": {"kernel": "exp", "axis": "strain", "start": "pinned",
                                                 "amplitude": 1.0, "length": 0.05}},
        "conditions": {"strain_rate": 5e-3, "strain_max": 1.9, "n_points": 2000}},
}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--tests", type=int, default=100)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=12)
    args = ap.parse_args()
    print(f"{args.tests} simulated tests per design, {args.jobs} processes (2-core shared machine)")
    print(f"{'design':<38}{'param':>9}{'predicted sd':>14}{'observed sd':>13}{'ratio':>8}"
          f"{'95 % band':>16}{'|r-1|<=20 %':>13}")
    worst = 0.0
    for k, (name, d) in enumerate(DESIGNS.items()):
        t0 = time.perf_counter()
        raw = {"name": "validation", "parameters": GUESS, **d}
        rep = validate_design(raw, args.tests, seed=args.seed + 10_000 * k, jobs=args.jobs)
        lo, hi = rep.ratio_interval()
        spread, ratio = rep.spread(), rep.ratio()
        for j, p in enumerate(rep.names):
            ok = abs(ratio[p] - 1.0) <= 0.2
            worst = max(worst, abs(ratio[p] - 1.0))
            label = name if j == 0 else ""
            print(f"{label:<38}{p:>9}{rep.prediction.sd[p]:>14.4g}{spread[p]:>13.4g}{ratio[p]:>8.3f}"
                  f"{f'[{lo:.2f}, {hi:.2f}]':>16}{'yes' if ok else 'NO':>13}")
        print(f"{'':<38}{'':>9}  ({rep.estimates.shape[0]} fits, {rep.failed} failed, "
              f"Err(E) predicted {100 * rep.prediction.err['E']:.3g} %, {time.perf_counter() - t0:.0f} s)")
    print(f"largest |ratio - 1|: {100 * worst:.1f} %")


if __name__ == "__main__":
    main()
