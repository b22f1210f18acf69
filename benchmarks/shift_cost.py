"""The shifted model's cost against today's kernel, on the same grids, in one run.

    .venv/bin/python benchmarks/shift_cost.py [--quick]

For each grid (the paper's uniform ramp at 2000 and 8000 points, the same ±15 % jittered, the real
film's 0.604 s ramp of 1000 points, a ramp then a log-spaced hold like its relaxation exports),
CPU time of one stress evaluation (N = 50 modes, one thread, best of repeated bursts):

- today: ``kernel.stress_into`` (the unshifted model; also a temperature shift at a constant
  temperature, which multiplies tau_max by a_T and runs this same kernel);
- a_T per row: a temperature logged per sample (``reduced_time.stress_shift_into`` with ln a_T
  per step, no stress shift);
- a_σ: the Eyring stress shift, sigma_s = 5 MPa (driving: stress), and 2 MPa;

with the ratios to today's. Also the central-difference Jacobian of the shifted model (4
parameters: 8 evaluations in one parallel call) against the exact basis with gradients.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from forward import cpu_best  # noqa: E402

from bayes_dnlr.model import DNLR, kernel, reduced_time, set_threads  # noqa: E402
from bayes_dnlr.model.shift import Shift, log_temperature_shift  # noqa: E402

PARAMS = {"E": 1500.0, "G": 5.0, "tau_max": 300.0, "sigma_inf": 8.0, "tau_max_R": 300.0}


def grids(quick: bool) -> dict[str, tuple[np.ndarray, np.ndarray, float | None]]:
    rng = np.random.default_rng(1)
    out = {}
    for q in ((2000,) if quick else (2000, 8000)):
        t = np.linspace(0.0, 400.0, q)
        out[f"uniform ramp, q = {q}"] = (t, 2e-3 * t, None)
        dt = np.diff(t) * (1 + 0.15 * rng.uniform(-1, 1, q - 1))
        tj = np.concatenate([[0.0], np.cumsum(dt)])
        out[f"±15 % jitter, q = {q}"] = (tj, 2e-3 * tj, None)
    t = np.arange(1000) * 0.604
    out["real film's ramp, 0.604 s, q = 1000"] = (t, 1.1e-3 * t, None)
    ramp = np.arange(41) * 0.2
    hold = 8.0 + np.geomspace(0.2, 10800.0, 1100)
    t = np.concatenate([ramp, hold])
    out["ramp then log hold, q = 1141"] = (t, np.minimum(1e-3 * t, 8e-3), 8.0)
    return out


def costs(t: np.ndarray, e: np.ndarray, rs: float | None) -> tuple[float, float, float, float]:
    """CPU s of one evaluation: today's kernel, a_T per row, a_σ at sigma_s 5 and 2 MPa."""
    out = np.empty(t.size)
    g = DNLR(t, e, relaxation_start=rs).kernel_args
    p = PARAMS
    args = (p["E"], p["G"], p["sigma_inf"], p["tau_max"], p["tau_max_R"], 0.5)
    today = cpu_best(lambda: kernel.stress_into(*args, g, out))
    temp = 40.0 + 0.01 * t
    ln_at = np.ascontiguousarray(log_temperature_shift(0.5 * (temp[:-1] + temp[1:]), "arrhenius",
                                                       20.0, Ea=200.0))
    none = np.zeros(0)
    at = cpu_best(lambda: reduced_time.stress_shift_into(*args, np.inf, 0, ln_at, g, out))
    s5 = cpu_best(lambda: reduced_time.stress_shift_into(*args, 5.0, 0, none, g, out))
    s2 = cpu_best(lambda: reduced_time.stress_shift_into(*args, 2.0, 0, none, g, out))
    return today, at, s5, s2


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    set_threads(1)
    print("CPU time of one stress evaluation (µs), N = 50 modes, one thread; ratio to today's kernel")
    print(f"{'grid':<38}{'today':>9}{'a_T per row':>18}{'a_σ 5 MPa':>18}{'a_σ 2 MPa':>18}")
    for name, (t, e, rs) in grids(args.quick).items():
        today, at, s5, s2 = costs(t, e, rs)
        cells = "".join(f"{1e6 * v:>10.0f} ({v / today:4.2f}×)" for v in (at, s5, s2))
        print(f"{name:<38}{1e6 * today:>9.0f}{cells}")
    t, e, _ = grids(True)["uniform ramp, q = 2000"]
    base = DNLR(t, e)
    shifted = DNLR(t, e, shift=Shift(stress="eyring"))
    basis = cpu_best(lambda: base.basis(300.0, grad=True))
    names = ["E", "G", "tau_max", "sigma_s"]
    jac = cpu_best(lambda: shifted.jacobian({**PARAMS, "sigma_s": 5.0}, names), repeats=10)
    print(f"\nsensitivities on the uniform ramp, q = 2000: exact basis with gradients {1e6 * basis:.0f} µs; "
          f"the shifted model's central differences ({len(names)} parameters, {2 * len(names)} "
          f"evaluations) {1e6 * jac:.0f} µs ({jac / basis:.1f}×)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
