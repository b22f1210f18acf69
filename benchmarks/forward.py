"""Forward-model speed: N = 50 modes, uniform and ±15 % jittered time grids.

Prints, with ratios against baselines measured in the same run:

1. numba compile cost, cold (empty cache, in a fresh process) and warm (cache present);
2. per evaluation and per mode-step, q = 500 … 128 000 points, one thread, for the model and for
   the pre-issue-14 implementation (benchmarks/baseline_forward.py, a frozen copy);
3. peak extra memory of one evaluation at q = 128 000 (max RSS of a fresh process);
4. the batch (32 parameter sets, q = 2000) with 1 and 2 threads, against a Python loop of single
   calls and the old stress_batch;
5. simulate() called repeatedly with the same time vector, against building the model each time;
6. at q = 2000: scipy's LSODA (rtol 1e-8) and a plain numba loop with one libm exp per mode-step;
7. the basis (least squares, with and without gradients) and the Python cost of one stress().

Times are CPU time of this process (time.process_time), the minimum over repeated bursts, except
the multi-thread batch (wall clock). The machine is shared: figures vary from run to run.

    .venv/bin/python benchmarks/forward.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from numba import njit
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from baseline_forward import OldDNLR  # noqa: E402

from bayes_dnlr.data.conversions import haward_thackray_strain as haward_thackray  # noqa: E402
from bayes_dnlr.model import (  # noqa: E402
    DNLR,
    get_threads,
    kernel,
    relaxation_times,
    set_threads,
    simulate,
    weights,
)
from bayes_dnlr.model.threads import available_threads  # noqa: E402

N, RATE, STRAIN_MAX = 50, 5e-3, 1.9
PARAMS = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
SIZES = (500, 2000, 8000, 32000, 128000)
ROOT = Path(__file__).resolve().parents[1]


def cpu_best(f, burst: float = 0.004, repeats: int = 25) -> float:
    """Best CPU time of one call (s): minimum over ``repeats`` bursts of at least ``burst`` s."""
    f()
    t0 = time.process_time()
    f()
    one = max(time.process_time() - t0, 1e-7)
    n = max(1, int(burst / one))
    best = np.inf
    for _ in range(repeats):
        t0 = time.process_time()
        for _ in range(n):
            f()
        best = min(best, (time.process_time() - t0) / n)
    return best


def wall_best(f, burst: float = 0.004, repeats: int = 25) -> float:
    f()
    t0 = time.perf_counter()
    f()
    one = max(time.perf_counter() - t0, 1e-7)
    n = max(1, int(burst / one))
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            f()
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def grid(q: int, jitter: float) -> tuple[np.ndarray, np.ndarray]:
    """The 380 s ramp of the paper's 5e-3 1/s test sampled at q points (denser as q grows)."""
    dt = np.full(q - 1, STRAIN_MAX / RATE / (q - 1))
    if jitter:
        dt *= 1 + np.random.default_rng(0).uniform(-jitter, jitter, q - 1)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    return t, RATE * t


# ------------------------------------------------------------------------------- 1. compile

COMPILE_PROBE = """
import time
t0 = time.perf_counter()
import numpy as np
from bayes_dnlr.model import DNLR
t1 = time.perf_counter()
t = np.linspace(0, 380, 2000)
m = DNLR(t, 5e-3 * t, relaxation_start=300.0)
p = {"E": 2854.0, "G": 2.32, "tau_max": 5.79, "sigma_inf": 50.0, "tau_max_R": 30.0}
m.stress(p)
t2 = time.perf_counter()
m.basis(5.79, 30.0, grad=True)
t3 = time.perf_counter()
m.stress_batch(np.array([list(p.values())] * 4), list(p))
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3)
"""


OLD_PROBE = """
import sys, time
sys.path.insert(0, {bench!r})
t0 = time.perf_counter()
import numpy as np
from baseline_forward import OldDNLR
t1 = time.perf_counter()
t = np.linspace(0, 380, 2000)
m = OldDNLR(t, 5e-3 * t, relaxation_start=300.0)
m.stress({{"E": 2854.0, "G": 2.32, "tau_max": 5.79, "sigma_inf": 50.0, "tau_max_R": 30.0}})
t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def compile_costs() -> None:
    print("1. numba compile cost (fresh process; wall s: import, first stress, first basis with"
          " gradients, first parallel batch)")
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        for label, env in (("cold (empty cache)", {"NUMBA_CACHE_DIR": cache}),
                           ("warm (cache present)", {"NUMBA_CACHE_DIR": cache}),
                           ("warm, again", {"NUMBA_CACHE_DIR": cache})):
            out = subprocess.run([sys.executable, "-c", COMPILE_PROBE], capture_output=True,
                                 text=True, check=True, env={**os.environ, **env}, cwd=ROOT)
            rows.append((label, [float(v) for v in out.stdout.split()]))
    code = OLD_PROBE.format(bench=str(Path(__file__).resolve().parent))
    subprocess.run([sys.executable, "-c", code], capture_output=True, check=True, cwd=ROOT)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=ROOT)
    old = [float(v) for v in out.stdout.split()]
    print(f"   {'':22}{'import':>9}{'stress':>9}{'basis':>9}{'batch':>9}{'total':>9}")
    for label, v in rows:
        print(f"   {label:22}" + "".join(f"{x:9.2f}" for x in v) + f"{sum(v):9.2f}")
    print(f"   {'old model, warm':22}{old[0]:9.2f}{old[1]:9.2f}{'':>27}{sum(old):9.2f}")
    print()


# ----------------------------------------------------------------------- 2. cost against q

def active_modes(model: DNLR) -> int:
    return N - kernel._phase_tables(model.kernel_args, model.p, PARAMS["tau_max"], False, False).j0


def scaling(sizes: tuple[int, ...], rounds: int = 3) -> dict[tuple[int, str], float]:
    print("2. one evaluation, one thread. kernel: stress_into (ns per mode-step counts all N = 50"
          " modes; per active mode: the modes not yet relaxed); stress(): the Python call;"
          f" old: the pre-issue-14 stress(). Best of {rounds} rounds.")
    print(f"   {'q':>7} {'grid':8}{'active':>7}{'kernel µs':>11}{'ns/m-s':>8}{'ns/act':>8}"
          f"{'stress() µs':>13}{'old µs':>10}{'ns/m-s':>8}{'× old':>7}{'max rel diff':>14}")
    set_threads(1)
    cases = []
    for q in sizes:
        for name, jitter in (("uniform", 0.0), ("±15 %", 0.15)):
            t, e = grid(q, jitter)
            new, old = DNLR(t, e, N), OldDNLR(t, e, N)
            ref = old.stress(PARAMS)
            diff = np.max(np.abs(new.stress(PARAMS) - ref)[1:] / np.abs(ref[1:]))
            cases.append((q, name, new, old, diff))
    best = {}
    for _ in range(rounds):
        for q, name, new, old, _ in cases:
            out = np.empty(q)
            args = (PARAMS["E"], PARAMS["G"], 0.0, PARAMS["tau_max"], PARAMS["tau_max"], 0.5,
                    new.kernel_args, out)
            times = (cpu_best(lambda a=args: kernel.stress_into(*a), burst=0.002, repeats=15),
                     cpu_best(lambda m=new: m.stress(PARAMS), burst=0.002, repeats=15),
                     cpu_best(lambda m=old: m.stress(PARAMS), burst=0.002,
                              repeats=3 if q > 10000 else 8))
            prev = best.get((q, name), (np.inf,) * 3)
            best[(q, name)] = tuple(min(a, b) for a, b in zip(prev, times, strict=True))
    result = {}
    for q, name, new, _, diff in cases:
        t_k, t_s, t_o = best[(q, name)]
        per = 1e9 / (N * (q - 1))
        act = active_modes(new)
        result[(q, name)] = t_k * per
        print(f"   {q:>7} {name:8}{act:>7}{t_k * 1e6:>11.1f}{t_k * per:>8.3f}"
              f"{t_k * per * N / act:>8.3f}{t_s * 1e6:>13.1f}{t_o * 1e6:>10.1f}{t_o * per:>8.3f}"
              f"{t_o / t_s:>7.1f}{diff:>14.1e}")
    print("   linear cost: ns per active mode-step stays flat from q = 2000 on (at q = 500 the"
          " fixed cost per call, tables and setup, still shows)")
    print("   targets: uniform <= 0.5, jittered <= 1 ns per mode-step at q = 2000 and 128 000\n")
    return result


# -------------------------------------------------------------------------------- 3. memory

MEMORY_PROBE = """
import sys
import numpy as np
sys.path.insert(0, {bench!r})
from baseline_forward import OldDNLR
from bayes_dnlr.model import DNLR


def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) / 1024


impl, jitter, q = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
cls = DNLR if impl == "new" else OldDNLR
dt = np.full(q - 1, 380.0 / (q - 1))
if jitter:
    dt *= 1 + np.random.default_rng(0).uniform(-jitter, jitter, q - 1)
t = np.concatenate([[0.0], np.cumsum(dt)])
p = {{"E": 2854.0, "G": 2.32, "tau_max": 5.79}}
small = cls(t[:50], 5e-3 * t[:50])
small.stress(p)                                     # compile or load, outside the measurement
model = cls(t, 5e-3 * t)
grid = (sum(a.nbytes for a in model.kernel_args if hasattr(a, "nbytes")) / 2**20
        if impl == "new" else 0.0)
with open("/proc/self/clear_refs", "w") as f:       # reset the peak RSS (VmHWM)
    f.write("5")
before = status("VmRSS")
model.stress(p)
print(status("VmHWM") - before, grid)
"""


def memory(q: int = 128000) -> None:
    print(f"3. peak extra memory of one evaluation at q = {q}: peak RSS during the call minus RSS"
          " before it, fresh process, MB (includes the (q,) result, 1 MB)")
    code = MEMORY_PROBE.format(bench=str(Path(__file__).resolve().parent))
    # allocations >= 64 kB are mapped and unmapped at once: RSS follows what is alive
    env = {**os.environ, "MALLOC_MMAP_THRESHOLD_": "65536", "MALLOC_TRIM_THRESHOLD_": "0"}
    for name, jitter in (("uniform", 0.0), ("±15 %", 0.15)):
        vals = {}
        for impl in ("new", "old"):
            try:
                out = subprocess.run([sys.executable, "-c", code, impl, str(jitter), str(q)],
                                     capture_output=True, text=True, check=True, cwd=ROOT,
                                     env=env)
            except subprocess.CalledProcessError as err:
                print(f"   (not measured: {err.stderr.strip().splitlines()[-1]})")
                return
            vals[impl] = [float(v) for v in out.stdout.split()]
        print(f"   {name:8} new {vals['new'][0]:6.1f} MB   old {vals['old'][0]:6.1f} MB"
              f"   (the new model's prepared grid, held once per model: {vals['new'][1]:.1f} MB)")
    print("   target: <= 10 MB\n")


# --------------------------------------------------------------------------------- 4. batch

def batch(q: int = 2000, k: int = 32) -> None:
    print(f"4. batch of {k} parameter sets, q = {q}: time per set (µs), wall clock; machine has"
          f" {os.cpu_count()} CPUs, numba pool {available_threads()}, layer and load below")
    rng = np.random.default_rng(1)
    theta = np.column_stack([rng.uniform(2500, 3200, k), rng.uniform(2.0, 2.6, k),
                             np.exp(rng.uniform(np.log(3), np.log(12), k))])
    names = ["E", "G", "tau_max"]
    before = get_threads()
    print(f"   {'grid':9}{'old batch':>11}{'loop of stress':>16}{'1 thread':>10}{'2 threads':>11}"
          f"{'2 vs 1':>8}{'× old':>8}{'CPU/wall (2)':>14}")
    for name, jitter in (("uniform", 0.0), ("±15 %", 0.15)):
        t, e = grid(q, jitter)
        new, old = DNLR(t, e, N), OldDNLR(t, e, N)
        t_old = wall_best(lambda m=old: m.stress_batch(theta, names), repeats=15) / k
        t_loop = wall_best(lambda m=new: [m.stress(dict(zip(names, r, strict=True)))
                                          for r in theta], repeats=15) / k
        set_threads(1)
        one = new.stress_batch(theta, names)
        t_1 = wall_best(lambda m=new: m.stress_batch(theta, names), repeats=40) / k
        n2 = set_threads(2)
        two = new.stress_batch(theta, names)
        t_2 = wall_best(lambda m=new: m.stress_batch(theta, names), repeats=40) / k
        c0, w0 = time.process_time(), time.perf_counter()
        for _ in range(20):
            new.stress_batch(theta, names)
        usage = (time.process_time() - c0) / (time.perf_counter() - w0)
        assert np.array_equal(one, two), "thread count changed the result"
        print(f"   {name:9}{t_old * 1e6:>11.1f}{t_loop * 1e6:>16.1f}{t_1 * 1e6:>10.1f}"
              f"{t_2 * 1e6:>11.1f}{t_1 / t_2:>8.2f}{t_old / t_2:>8.1f}{usage:>14.2f}"
              + ("" if n2 == 2 else f"   (only {n2} thread available)"))
    set_threads(before)
    print(f"   threading layer {numba.threading_layer()}, OMP_WAIT_POLICY"
          f" {os.environ.get('OMP_WAIT_POLICY')}, load average now {os.getloadavg()[0]:.1f}:"
          " a speed-up needs a second idle core")
    print("   1- and 2-thread results bit-identical: yes (checked above)\n")


# ------------------------------------------------------------------------------ 5. simulate

def repeated_simulate() -> None:
    print("5. simulate() called again with the same time vector (µs per call)")
    print(f"   {'q':>7} {'grid':8}{'cached':>10}{'model built':>13}{'old simulate':>14}{'× old':>8}")
    for q in (2000, 128000):
        for name, jitter in (("uniform", 0.0), ("±15 %", 0.15)):
            t, e = grid(q, jitter)
            hit = cpu_best(lambda t=t, e=e: simulate(t, e, PARAMS), repeats=10)
            built = cpu_best(lambda t=t, e=e: DNLR(t, e).stress(PARAMS), repeats=10)
            old = cpu_best(lambda t=t, e=e: OldDNLR(t, e).stress(PARAMS), repeats=5)
            print(f"   {q:>7} {name:8}{hit * 1e6:>10.1f}{built * 1e6:>13.1f}{old * 1e6:>14.1f}"
                  f"{old / hit:>8.1f}")
    print()


# ------------------------------------------------------------- 6. LSODA and the plain loop

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


def references(q: int = 2000) -> None:
    print(f"6. q = {q}: against scipy LSODA (rtol 1e-8) and a plain numba loop (libm exp per"
          " mode-step)")
    print(f"   {'grid':9}{'eval (µs)':>11}{'plain loop (µs)':>17}{'LSODA (ms)':>12}{'× plain':>9}"
          f"{'× LSODA':>10}{'max rel diff to LSODA':>23}")
    for name, jitter in (("uniform", 0.0), ("±15 %", 0.15)):
        t, e = grid(q, jitter)
        model = DNLR(t, e, N)
        one = cpu_best(lambda m=model: m.stress(PARAMS))
        tau, p, h = relaxation_times(PARAMS["tau_max"], N), weights(N), haward_thackray(e)
        args = (t, e, h, p, tau, PARAMS["E"], PARAMS["G"])
        plain = cpu_best(lambda a=args: plain_loop(*a))
        t0 = time.process_time()
        ref = lsoda(t, e)
        t_lsoda = time.process_time() - t0
        err = np.max(np.abs(model.stress(PARAMS) - ref)[1:] / np.abs(ref[1:]))
        print(f"   {name:9}{one * 1e6:>11.1f}{plain * 1e6:>17.1f}{t_lsoda * 1e3:>12.1f}"
              f"{plain / one:>9.1f}{t_lsoda / one:>10.0f}{err:>23.1e}")
    print()


def basis_and_overhead() -> None:
    print("7. basis (unit responses, used by least squares) and the Python cost of stress(), µs")
    print(f"   {'q':>7} {'grid':8}{'basis':>9}{'old':>9}{'× old':>7}{'+grad':>9}{'old':>9}{'× old':>7}"
          f"{'stress()':>10}{'stress_into':>13}")
    for q in (2000, 32000):
        for name, jitter in (("uniform", 0.0), ("±15 %", 0.15)):
            t, e = grid(q, jitter)
            new, old = DNLR(t, e, N), OldDNLR(t, e, N)
            b = cpu_best(lambda m=new: m.basis(5.79))
            bo = cpu_best(lambda m=old: m.basis(5.79))
            g = cpu_best(lambda m=new: m.basis(5.79, grad=True))
            go = cpu_best(lambda m=old: m.basis(5.79, grad=True))
            out = np.empty(q)
            args = (PARAMS["E"], PARAMS["G"], 0.0, 5.79, 5.79, 0.5, new.kernel_args, out)
            s_py = cpu_best(lambda m=new: m.stress(PARAMS))
            s_nb = cpu_best(lambda a=args: kernel.stress_into(*a))
            print(f"   {q:>7} {name:8}{b * 1e6:>9.1f}{bo * 1e6:>9.1f}{bo / b:>7.1f}{g * 1e6:>9.1f}"
                  f"{go * 1e6:>9.1f}{go / g:>7.1f}{s_py * 1e6:>10.1f}{s_nb * 1e6:>13.1f}")
    print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip compile and memory probes")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    print(f"DNLR forward model, N = {N} modes; {os.cpu_count()} CPUs, load average {load:.1f}"
          " (a shared machine: figures vary between runs)\n")
    if not args.quick:
        compile_costs()
    scaling(SIZES)
    if not args.quick:
        memory()
    batch()
    repeated_simulate()
    references()
    basis_and_overhead()


if __name__ == "__main__":
    main()
