"""Forward-model speed: N = 50 modes, q = 2000 points, uniform and ±15 % jittered time grids.

Prints the time per evaluation, per mode-step, the batch time per parameter set (32 sets), and
ratios against baselines measured in the same run: scipy's LSODA (rtol 1e-8) on the same ODE,
and a plain numba loop that calls exp for every mode and step.

    python benchmarks/forward.py
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit
from scipy.integrate import solve_ivp

from bayes_dnlr.model import DNLR, haward_thackray, relaxation_times, weights

N, Q, RATE, STRAIN_MAX = 50, 2000, 5e-3, 1.9
PARAMS = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}


def best_of(f, repeat: int = 7, number: int = 20) -> float:
    """Best mean time of one call (s) over ``repeat`` rounds of ``number`` calls."""
    f()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            f()
        times.append((time.perf_counter() - t0) / number)
    return min(times)


@njit(cache=True)
def plain_loop(t, eps, h, p, tau, E, G):
    """The obvious integrator: one exp per mode and step."""
    n, q = p.size, t.size
    s = p * G * h[0]
    out = np.empty(q)
    out[0] = s.sum()
    for i in range(q - 1):
        d = t[i + 1] - t[i]
        de, dh = eps[i + 1] - eps[i], h[i + 1] - h[i]
        acc = 0.0
        for j in range(n):
            x = d / tau[j]
            a = np.exp(-x)
            phi = (1.0 - a) / x
            s[j] = a * s[j] + p[j] * (E * phi * de + G * (h[i + 1] - a * h[i] - phi * dh))
            acc += s[j]
        out[i + 1] = acc
    return out


def lsoda(t, eps):
    tau, p = relaxation_times(PARAMS["tau_max"], N), weights(N)

    def rhs(tt, s):
        e = np.interp(tt, t, eps)
        return p * PARAMS["E"] * RATE - (s - p * PARAMS["G"] * haward_thackray(e)) / tau

    sol = solve_ivp(rhs, (t[0], t[-1]), p * PARAMS["G"] * haward_thackray(eps[0]), method="LSODA",
                    t_eval=t, rtol=1e-8, atol=1e-10)
    assert sol.success, sol.message
    return sol.y.sum(axis=0)


def grid(jitter: float) -> np.ndarray:
    dt = np.full(Q - 1, STRAIN_MAX / RATE / (Q - 1))
    if jitter:
        dt *= 1 + np.random.default_rng(0).uniform(-jitter, jitter, Q - 1)
    return np.concatenate([[0.0], np.cumsum(dt)])


def main() -> None:
    rng = np.random.default_rng(1)
    batch = np.column_stack([rng.uniform(2500, 3200, 32), rng.uniform(2.0, 2.6, 32),
                             np.exp(rng.uniform(np.log(3), np.log(12), 32))])
    print(f"DNLR forward model, N = {N} modes, q = {Q} points ({N * (Q - 1)} mode-steps)\n")
    header = (f"{'grid':<10}{'eval (µs)':>11}{'ns/mode-step':>14}{'batch/set (µs)':>16}"
              f"{'plain loop (µs)':>17}{'LSODA (ms)':>12}{'× plain':>9}{'× LSODA':>10}")
    print(header)
    for name, jitter in (("uniform", 0.0), ("±15 %", 0.15)):
        t = grid(jitter)
        eps = RATE * t
        model = DNLR(t, eps, N)
        one = best_of(lambda m=model: m.stress(PARAMS))
        per_set = best_of(lambda m=model: m.stress_batch(batch, ["E", "G", "tau_max"]),
                          repeat=5, number=3) / len(batch)
        tau, p, h = relaxation_times(PARAMS["tau_max"], N), weights(N), haward_thackray(eps)
        args = (t, eps, h, p, tau, PARAMS["E"], PARAMS["G"])
        plain = best_of(lambda a=args: plain_loop(*a))
        t0 = time.perf_counter()
        ref = lsoda(t, eps)
        t_lsoda = time.perf_counter() - t0
        err = np.max(np.abs(model.stress(PARAMS) - ref)[1:] / np.abs(ref[1:]))
        print(f"{name:<10}{one * 1e6:>11.1f}{one * 1e9 / (N * (Q - 1)):>14.2f}{per_set * 1e6:>16.1f}"
              f"{plain * 1e6:>17.1f}{t_lsoda * 1e3:>12.1f}{plain / one:>9.1f}{t_lsoda / one:>10.0f}"
              f"   (max rel. diff. to LSODA {err:.1e})")
    print("\ntargets: uniform <= 1 ns per mode-step (<= 100 µs per evaluation) and >= 300x LSODA;"
          " jittered <= 2 ns per mode-step")


if __name__ == "__main__":
    main()
