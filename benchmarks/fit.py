"""Wall time of `fit` on the 2000-point example, and of its multi-start check.

    .venv/bin/python benchmarks/fit.py [runs/hdpe-a-5e-3/config.yaml]

Times (median of several runs, nothing written to the run directory):
- load_test alone (CSV, σ*, GCV smoothing of the strain);
- the fit without multi-start (physics start + minimisation + stochastic analysis), per method;
- the same with cfg.fit.multistart starts (the difference is the multi-start check);
- the first call in this process (numba cache load included).
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def median_time(f, repeat: int = 7) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv: list[str]) -> int:
    path = Path(argv[0]) if argv else REPO / "runs" / "hdpe-a-5e-3" / "config.yaml"
    from bayes_dnlr.config import load_config
    from bayes_dnlr.data import load_test
    from bayes_dnlr.inference.lsq.identify import fit_test
    from bayes_dnlr.runs.fit import fit

    cfg = load_config(path)
    if not cfg.data_path.is_file():
        print(f"{cfg.data_path} not found: run `python -m bayes_dnlr simulate {path}` first")
        return 1
    t0 = time.perf_counter()
    first = fit(cfg, write=False).only
    cold = time.perf_counter() - t0
    test = load_test(cfg)
    n_ms = cfg.fit.multistart or 8
    print(f"{cfg.name}: {test.time.size} samples, {first.n_points} in the window, free {first.names}, "
          f"multistart {n_ms}")
    print(f"first fit in this process (numba cache load, load_test, fit, {cfg.fit.multistart} starts): "
          f"{cold:.3f} s")
    print(f"load_test: {1e3 * median_time(lambda: load_test(cfg)):.1f} ms")
    for method in ("lm", "gauss-newton"):
        single = cfg.model_copy(deep=True)
        single.fit.method, single.fit.multistart = method, 0
        multi = cfg.model_copy(deep=True)
        multi.fit.method, multi.fit.multistart = method, n_ms
        r0 = fit_test(single, test)
        r1 = fit_test(multi, test)
        t_single = median_time(lambda c=single: fit_test(c, test))
        t_multi = median_time(lambda c=multi: fit_test(c, test))
        t_full = median_time(lambda c=multi: fit(c, write=False), repeat=5)
        iters = [run["iterations"] for run in r1.multistart["runs"]]
        print(f"{method:>12}: fit {1e3 * t_single:6.1f} ms ({r0.iterations} iterations, "
              f"{r0.evaluations} model evaluations); with {n_ms} starts {1e3 * t_multi:6.1f} ms "
              f"(multi-start check {1e3 * (t_multi - t_single):6.1f} ms, {min(iters)}-{max(iters)} "
              f"iterations per start, {r1.multistart['converged']}/{n_ms} converged, same optimum: "
              f"{r1.multistart['same_optimum']}); full fit(cfg) incl. load_test {1e3 * t_full:6.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
