"""Time of ``python -m bayes_dnlr report RUN_DIR`` (target: <= 3 s on a quiet machine, real curves
included).

1. The command itself from a fresh process, min (and median) of ``--repeats`` runs: the first build
   (no figures from an earlier report) and the rebuild ``report --force`` (every figure kept whose
   inputs are the same).
2. The split of a first build, in one more fresh process drawing every figure itself: imports,
   loading the run (config, fit.json, summary.json, posterior.nc), reading the data, the model
   curves (posterior draws through the model), and each figure (every ``report.figures`` function
   timed where it is called), the rest of the page.
3. The two processes of a first build, in one more fresh process with the figure worker forced on
   (the report forks it only when a core is idle at its start, and not to rebuild a current
   report): the CPU of this process and of the worker. On an idle machine with two cores the wall
   time is about the larger of the two plus the start; on a loaded one, about their sum (then the
   report draws alone).
4. ``--refjob SCRIPT``: a reference job (a script printing its own seconds), run before and after,
   and the report's times as ratios to it.

The run directory is copied to a temporary folder beside it (the shipped one is not touched): at
the same depth, so that the relative data path of its config.resolved.yaml still reaches the data
(a copy elsewhere reported a real curve without its data, and without the figures that need it).
It must hold a finished ``sample`` (run ``python -m bayes_dnlr sample runs/hdpe-a-5e-3/config.yaml``
first).

    .venv/bin/python benchmarks/report_command.py [runs/hdpe-a-5e-3] [--repeats 5] [--refjob job.py]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SPLIT = r"""
import json, sys, time
t0 = time.perf_counter()
from bayes_dnlr.report import figure_cache, figures, html, tables
figures.import_figure_modules()       # the figures' imports (matplotlib, corner), counted here
figure_cache._free_core = lambda: False       # every figure drawn and timed in this process
t_imp = time.perf_counter() - t0
split = {}

cpu = {}

def timed(label, f):
    def g(*a, **k):
        t, c = time.perf_counter(), time.process_time()
        try:
            return f(*a, **k)
        finally:
            split[label] = split.get(label, 0.0) + time.perf_counter() - t
            cpu[label] = cpu.get(label, 0.0) + time.process_time() - c
    return g

for name in dir(figures):
    if name.endswith("_plot"):
        setattr(figures, name, timed("figure " + name, getattr(figures, name)))
html.load_run = timed("load run (config, fit, summary, posterior.nc)", html.load_run)
html.attach_data = timed("read the data", html.attach_data)
html.model_curves = timed("model curves (posterior draws through the model)", html.model_curves)  # noqa: E501
t1, c1 = time.perf_counter(), time.process_time()
html.build_report(sys.argv[1])   # a first build: the caller removed the figures
total, total_cpu = time.perf_counter() - t1, time.process_time() - c1
split["rest of the page (tables, standards, HTML)"] = total - sum(split.values())
cpu["rest of the page (tables, standards, HTML)"] = total_cpu - sum(cpu.values())
print(json.dumps({"imports": t_imp, "imports_cpu": c1, "build": total, "build_cpu": total_cpu,
                  "split": split, "cpu": cpu}))
"""

PAIR = r"""
import json, resource, sys, time
from bayes_dnlr.report import figure_cache, html
figure_cache._free_core = lambda: True            # the worker, whatever the load
t = time.perf_counter()
html.build_report(sys.argv[1])
wall = time.perf_counter() - t
me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"wall": wall, "self": me.ru_utime + me.ru_stime, "worker": kids.ru_utime + kids.ru_stime}))
"""


def _refjob(script: str | None) -> float | None:
    if script is None:
        return None
    out = subprocess.run([sys.executable, script], check=True, capture_output=True, text=True)
    return float(out.stdout.strip().split()[-1])


def _times(cmd: list[str], env: dict, run: Path, repeats: int, first: bool) -> tuple[list, list]:
    walls, cpus = [], []
    for _ in range(repeats):
        if first:
            shutil.rmtree(run / "figures", ignore_errors=True)
            (run / "report.html").unlink(missing_ok=True)
        r0 = os.times()
        t = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, env=env, cwd=ROOT)
        walls.append(time.perf_counter() - t)
        r1 = os.times()
        cpus.append((r1.children_user - r0.children_user) + (r1.children_system - r0.children_system))
    return walls, cpus


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", nargs="?", default=str(ROOT / "runs/hdpe-a-5e-3"))
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--refjob", help="a reference job script that prints its seconds")
    args = ap.parse_args()
    src = Path(args.run_dir)
    if not (src / "summary.json").is_file():
        sys.exit(f"error: {src} has no finished sample (summary.json); run sample first")
    print(f"load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f} "
          f"(1/5/15 min), {os.cpu_count()} CPUs")
    ref = [_refjob(args.refjob)]
    with tempfile.TemporaryDirectory(dir=src.resolve().parent, prefix=f".{src.name}-bench-") as tmp:
        run = Path(tmp)
        shutil.copytree(src, run, ignore=shutil.ignore_patterns("figures", "report.html"),
                        dirs_exist_ok=True)
        env = {**os.environ, "MPLBACKEND": "Agg"}
        cmd = [sys.executable, "-m", "bayes_dnlr", "report", "--force", str(run)]
        subprocess.run(cmd, check=True, capture_output=True, env=env, cwd=ROOT)    # warm caches
        rows = {}
        for label, first in (("first build", True), ("rebuild, figures kept", False)):
            walls, cpus = _times(cmd, env, run, args.repeats, first)
            rows[label] = min(walls)
            print(f"report, {label}: min {min(walls):.2f} s, median {statistics.median(walls):.2f} s "
                  f"wall over {args.repeats} runs (CPU {min(cpus):.2f}-{max(cpus):.2f} s); target <= 3 s: "
                  + ("met" if min(walls) <= 3.0 else "NOT met"))
        shutil.rmtree(run / "figures", ignore_errors=True)
        out = subprocess.run([sys.executable, "-c", SPLIT, str(run)], check=True, capture_output=True,
                             text=True, env=env, cwd=ROOT)
        res = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"split of a first build (one more fresh process), wall (CPU): imports {res['imports']:.2f} s "
              f"({res['imports_cpu']:.2f} s), build {res['build']:.2f} s ({res['build_cpu']:.2f} s)")
        for label, v in sorted(res["split"].items(), key=lambda kv: -kv[1]):
            print(f"  {label:<60s} {v:6.3f} s  ({res['cpu'][label]:.3f} s CPU)")
        shutil.rmtree(run / "figures", ignore_errors=True)
        out = subprocess.run([sys.executable, "-c", PAIR, str(run)], check=True, capture_output=True,
                             text=True, env=env, cwd=ROOT)
        pair = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"first build with the figure worker: wall {pair['wall']:.2f} s, CPU of this process "
              f"{pair['self']:.2f} s (imports included), of the worker {pair['worker']:.2f} s")
    ref.append(_refjob(args.refjob))
    if ref[0] is not None:
        best = min(ref)
        print(f"reference job: {ref[0]:.2f} s before, {ref[1]:.2f} s after; report / reference job: "
              + ", ".join(f"{label} {v / best:.2f}" for label, v in rows.items()))
    print(f"load after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
