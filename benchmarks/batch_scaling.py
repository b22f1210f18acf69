"""Scaling of the batch runner: wall time of ``python -m bayes_dnlr batch`` on 8 tests with 1 worker
and with 2 workers (joblib, loky), in the same run, fresh run directories each time.

Each test: a synthetic ramp (5e-3 1/s to strain 1.9, 1000 points, stress noise 0.3 MPa, its own noise
seed), fit + sample to ESS 400 (+ report unless --no-report). The figure of merit is
time(2 workers) / time(1 worker); the target on a 2-core machine is <= 0.6. The whole command is
timed, as a user sees it (interpreter start, imports in each worker, the batch page). The CPU time
of the batch and its workers is printed too: CPU / wall near the number of workers means they had a
core each; well below, other processes on the machine took the cores (the ratio then says little).

    .venv/bin/python benchmarks/batch_scaling.py [--tests 8] [--points 1000] [--no-report]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from support.sampling import write_case  # noqa: E402


def batch(configs: list[Path], out: Path, jobs: int, report: bool) -> tuple[float, float]:
    """(wall time, CPU time of the batch process and its workers) in s."""
    cmd = [sys.executable, "-m", "bayes_dnlr", "batch", *map(str, configs), "--out", str(out),
           "--jobs", str(jobs), "--quiet"] + ([] if report else ["--no-report"])
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tests", type=int, default=8)
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--target-ess", type=float, default=400)
    ap.add_argument("--report", action=argparse.BooleanOptionalAction, default=True)
    args = ap.parse_args()
    print(f"{args.tests} tests, {args.points} points, target ESS {args.target_ess:g}, "
          f"report {'on' if args.report else 'off'}; machine cores {os.cpu_count()}, load average "
          f"before {os.getloadavg()[0]:.2f}")
    times = {}
    with tempfile.TemporaryDirectory() as tmp:
        for jobs in (1, 2):
            folder = Path(tmp) / f"jobs{jobs}"
            configs = [write_case(folder, f"s{i}", n=args.points, seed=500 + i,
                                  sampler={"target_ess": args.target_ess, "max_steps": 20000,
                                           "checkpoint_every": 100, "seed": i + 1})
                       for i in range(args.tests)]
            times[jobs], cpu = batch(configs, folder / "batch", jobs, args.report)
            print(f"  {jobs} worker{'s' if jobs > 1 else ''}: {times[jobs]:.1f} s wall, {cpu:.1f} s CPU "
                  f"(cores busy on average {cpu / times[jobs]:.2f}; load average now "
                  f"{os.getloadavg()[0]:.2f})")
    ratio = times[2] / times[1]
    print(f"ratio 2 workers / 1 worker: {ratio:.3f} (target <= 0.6): {'ok' if ratio <= 0.6 else 'MISSED'}")


if __name__ == "__main__":
    main()
