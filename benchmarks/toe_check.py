"""The toe test of the start check (inference/checks/toe.py): its false alarms on clean starts and
its power on toes, simulated in full (the data, the pooled scatter, the largest rise), with seeds
the threshold's own simulation (toe.NULL_SEED) never used.

    .venv/bin/python benchmarks/toe_check.py [--reps 4000] [--power-reps 500] [--seed 1]

Prints three tables:

- false alarms: the share of clean starts called a toe, per number of samples up to 1 % strain,
  on a straight start (the least favourable clean start: a relaxing material's slope only falls)
  with white stress noise, with stress and strain noise (a DIC strain), with irregular sampling,
  and on a relaxing material; beside it the statistic as it was before (the largest rise over
  the likelihood's σ0 against 2.576, recomputed here for the comparison);
- power: the share of toes found, per slack (the strain reads ahead by slack (1 − e^(−ε/slack)),
  workflows/truth_forms.py's strain-toe), number of samples and noise;
- the real starts of the ETFE film's exports (when present, tests/support/real_data.py): the
  three 20 °C relaxation specimens and the first loadings of the six cyclic ones, the data alone
  (the model's rise, which the check takes off, only lowers z).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

# one BLAS thread: the null law of each new design is a small product that threads only slow
# down on a shared machine (set before numpy loads)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bayes_dnlr.inference.checks.toe import TOE_ALPHA, toe_test  # noqa: E402
from bayes_dnlr.model import simulate  # noqa: E402
from bayes_dnlr.workflows.truth_forms import generate  # noqa: E402

SIZES = (40, 100, 200, 400, 1000)
E = 1500.0                   # MPa
SIGMA = 0.01                 # MPa, stress noise of the straight starts (the test is scale-free)
MATERIAL = {"E": E, "G": 5.0, "tau_max": 30.0}
# the toes' materials: one whose slope falls by 14 % over the first 1 % at RATE (as the ETFE film's
# starts do), one by 58 % (a strongly relaxing one, which bends a toe's rise away)
TOE_MATERIALS = (("slope falls 14 % (tau_max 1000 s)", {"E": E, "G": 5.0, "tau_max": 1000.0}),
                 ("slope falls 58 % (tau_max 30 s)", MATERIAL))
RATE = 1e-3                  # 1/s
OLD_Z = 2.576


def old_statistic(e: np.ndarray, y: np.ndarray, sigma0_sq: float) -> float:
    """The toe statistic before its calibration, for the comparison: the steepest window's slope
    less the first one's over the sd σ0 gives them (windows of n/8 samples, half overlapping)."""
    past = np.flatnonzero(e > 0.01)
    n = int(past[0]) if past.size else e.size
    k = max(4, n // 8)
    windows = []
    for a in range(0, n - k + 1, max(1, k // 2)):
        d = e[a:a + k] - e[a:a + k].mean()
        if d @ d > 0:
            windows.append((a, d, float(d @ d)))
    slopes = [float(d @ (y[a:a + k] - y[a:a + k].mean())) / ss for a, d, ss in windows]
    j = 1 + int(np.argmax(slopes[1:]))
    return (slopes[j] - slopes[0]) / math.sqrt(sigma0_sq / windows[0][2] + sigma0_sq / windows[j][2])


def clean_start(kind: str, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    """(measured nominal strain, nominal stress, the stress noise sd) of a clean start with n
    samples below 1 % strain."""
    if kind == "irregular":
        steps = rng.gamma(2.0, 1.0, n)
        e = 0.0099 * np.concatenate(([0.0], np.cumsum(steps[:-1]))) / steps[:-1].sum()
    else:
        e = np.linspace(0.0, 0.0099, n)
    if kind == "relaxing":
        t = e / RATE
        y = simulate(t, np.log1p(e), MATERIAL) * np.exp(-np.log1p(e))
    else:
        y = E * e
    y = y + rng.normal(0.0, SIGMA, n)
    if kind == "strain noise":              # a DIC strain: its scatter moves the stress as much
        e = e + rng.normal(0.0, SIGMA / E, n)
    return e, y, SIGMA


def false_alarms(reps: int, seed: int) -> None:
    kinds = ("straight", "strain noise", "irregular", "relaxing")
    print(f"false alarms on clean starts ({reps} replicates each; the test's level {TOE_ALPHA:.1%}; "
          f"before: the largest rise over σ0 against {OLD_Z})")
    print(f"{'n':>6} | " + " | ".join(f"{k:>22}" for k in kinds) + " | threshold")
    for n in SIZES:
        cells, thresholds = [], set()
        for i, kind in enumerate(kinds):
            rng = np.random.default_rng([seed, n, i])
            now = before = 0
            for _ in range(reps):
                e, y, sd = clean_start(kind, n, rng)
                toe = toe_test(e, y)
                now += toe.found
                before += old_statistic(e, y, sd**2) > OLD_Z
                if kind == "straight":
                    thresholds.add(round(toe.threshold, 2))
            cells.append(f"{now / reps:6.2%} (before {before / reps:6.2%})")
        print(f"{n:>6} | " + " | ".join(f"{c:>22}" for c in cells) + f" | {sorted(thresholds)}")


def toe_start(material: dict, slack: float, n: int, stress_sd: float, strain_sd: float,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(measured nominal strain, nominal stress, the model's nominal stress driven by the measured
    strain) of a material loaded at RATE with a seating toe, sampled so that n samples lie below
    1 % specimen strain."""
    t = np.arange(0.0, 3.0 * 0.01 / RATE, 0.01 / RATE / n)
    g = generate(t, RATE * t, material, None, "strain-toe", slack)
    measured = g.measured_strain + rng.normal(0.0, strain_sd, t.size)
    y = g.stress * np.exp(-g.measured_strain) + rng.normal(0.0, stress_sd, t.size)
    model = simulate(t, g.measured_strain, material) * np.exp(-g.measured_strain)
    return np.expm1(measured), y, model


def power(reps: int, seed: int) -> None:
    slacks = (2.5e-4, 5e-4, 1e-3, 2e-3)
    noises = (("stress sd 0.01 MPa", 0.01, 0.0), ("the film's: stress 0.002 MPa, strain 3e-5", 0.002, 3e-5),
              ("stress sd 0.1 MPa", 0.1, 0.0))
    print(f"\npower: toes found ({reps} replicates each; E = {E:g} MPa, {RATE:g} 1/s; n samples up to "
          "1 % specimen strain; the rise of the material's own curve, driven by the measured strain, "
          "taken off)")
    for m, (what, material) in enumerate(TOE_MATERIALS):
        for label, stress_sd, strain_sd in noises:
            print(f"  {what}; {label}")
            print(f"{'slack':>10} | " + " | ".join(f"n = {n:>4}" for n in SIZES))
            for slack in slacks:
                row = []
                for n in SIZES:
                    rng = np.random.default_rng([seed, 7, m, n, int(slack * 1e6), int(stress_sd * 1e4)])
                    hits = sum(toe_test(*toe_start(material, slack, n, stress_sd, strain_sd, rng)).found
                               for _ in range(reps))
                    row.append(f"{hits / reps:8.2f}")
                print(f"{slack:>10.2g} | " + " | ".join(row))


def real_starts() -> None:
    """The real starts: the data alone up to the hold or the first peak."""
    from bayes_dnlr.config import parse_config
    from bayes_dnlr.data import load_test

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "tests"))
    from support.real_data import CYCLES, RELAX

    cases = [(RELAX, s, {"specimen_columns": 9, "columns": {"time": 1, "strain": 2, "stress": 8},
                         "relaxation_start": "auto"}) for s in (1, 2, 3)]
    cases += [(CYCLES, s, {"specimen_columns": 8, "columns": {"time": 1, "strain": 2, "stress": 4},
                           "stress_measure": "engineering", "repeated_time": "drop"})
              for s in range(1, 7)]
    print("\nreal starts (data alone, up to the hold or the first peak)")
    print(f"{'export':>32} {'specimen':>8} {'n':>4} {'z':>7} {'threshold':>9} {'p':>8}  toe")
    for path, spec, extra in cases:
        if not path.is_file():
            print(f"{path.name:>32}: absent (set BAYES_DNLR_REAL_EXPORTS)")
            continue
        data = {"file": str(path), "specimen": spec, "strain_unit": "fraction", "strain_measure": "nominal",
                "observable": "stress", "window": {}, **extra}
        cfg = parse_config({"name": "toe", "data": data}, source=Path("/tmp/toe/config.yaml"))
        test = load_test(cfg)
        end = test.first_peak if test.relaxation_start is None else int(
            np.searchsorted(test.time, test.relaxation_start, side="right")) - 1
        rows = slice(test.virtual_start, (end if end is not None else test.time.size - 1) + 1)
        nominal = (test.nominal_stress if test.nominal_stress is not None
                   else test.stress * np.exp(-test.strain))
        toe = toe_test(test.nominal_strain[rows], nominal[rows])
        n = int(np.sum(test.nominal_strain[rows] <= 0.01))
        print(f"{path.name:>32} {spec:>8} {n:>4} {toe.z:>7.2f} {toe.threshold:>9.2f} {toe.p:>8.4f}  "
              f"{'yes' if toe.found else 'no'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=4000, help="replicates per false-alarm cell")
    ap.add_argument("--power-reps", type=int, default=500, help="replicates per power cell")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--skip", nargs="*", default=(), choices=("false-alarms", "power", "real"))
    args = ap.parse_args()
    start = time.perf_counter()
    if "false-alarms" not in args.skip:
        false_alarms(args.reps, args.seed)
    if "power" not in args.skip:
        power(args.power_reps, args.seed)
    if "real" not in args.skip:
        real_starts()
    print(f"\n{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
