"""Large files: time and peak memory of reading a test (``load_test``: parse, check,
smooth the strain) and of ``fit`` with the default config, for 1e4 to 1e6 rows.

A 1 kHz tensile test of 1000 s to strain 1.9 (Table 3 parameters, strain noise 1e-4, stress noise
0.3 MPa) is written at each size; each measurement runs in a fresh process, so the peak resident
memory (VmHWM; ru_maxrss where /proc is absent) is that of one load or one fit. The baseline is
the same process on a 1000-row file, measured in the same run; the ratios show how time and
memory grow with the rows.

    .venv/bin/python benchmarks/large_files.py              # 1e4, 1e5, 1e6 rows, load and fit
    .venv/bin/python benchmarks/large_files.py --no-fit     # reading only
    .venv/bin/python benchmarks/large_files.py --full-up-to 1000000   # every row at 1e6 too (slow)

``fit`` runs with the default config, i.e. ``data.reduce: auto`` (docs/data-input.md, 1.6); up to
``--full-up-to`` rows the same fit with ``data.reduce: none`` is run beside it and the difference of E
is printed in its sd. The reference job (../shared/tools/refjob.py, or $BAYES_DNLR_REFJOB) is timed
at the start; the fits' wall time is also given in reference jobs.

Timings on a shared 2-core machine are noisy; read the ratios rather than the last digit. The CPU
time (user + system, all threads) of the measured call is printed beside the wall time: it does not
grow when other jobs share the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from reference_job import seconds as reference_job  # benchmarks/ is the script's folder

REPO = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time
from bayes_dnlr.config import load_config
from bayes_dnlr.data import load_test
cfg = load_config(sys.argv[1])
what = sys.argv[2]
if len(sys.argv) > 3:
    cfg.data.reduce = sys.argv[3] if sys.argv[3] in ("auto", "none") else int(sys.argv[3])
t0 = time.perf_counter()
use0 = resource.getrusage(resource.RUSAGE_SELF)
cpu0 = use0.ru_utime + use0.ru_stime
if what == "load":
    test = load_test(cfg)
    n = int(test.time.size)
    extra = {"note": next(x for x in test.notes if x.startswith("strain_input"))}
else:
    from bayes_dnlr.runs.fit import fit
    r = fit(cfg, write=False).only
    n = r.n_points
    d = r.discrepancy or {}
    extra = {"E": d.get("estimate", r.estimate)["E"], "sd": d.get("sd", r.sd)["E"],
             "converged": bool(r.converged),
             "reduce": next((x.split(":")[0] for x in r.data_notes if x.startswith("data.reduce")), "-")}
wall = time.perf_counter() - t0
use = resource.getrusage(resource.RUSAGE_SELF)
cpu = use.ru_utime + use.ru_stime - cpu0
rss = use.ru_maxrss / 1024.0
try:        # this process's own peak: ru_maxrss keeps the parent's size at the fork across exec
    with open("/proc/self/status") as f:
        rss = next(int(line.split()[1]) for line in f if line.startswith("VmHWM:")) / 1024.0
except (OSError, StopIteration, ValueError):
    pass
print(json.dumps({"n": n, "wall_s": wall, "cpu_s": cpu, "peak_rss_mb": rss, **extra}))
"""


def write_test(folder: Path, n: int) -> Path:
    """A 1000 s tensile test sampled n times, and its config (default settings)."""
    from bayes_dnlr.model import simulate

    rng = np.random.default_rng(n)
    t = np.linspace(0.0, 1000.0, n)
    strain = 1.9e-3 * t
    stress = simulate(t, strain, {"E": 2854.0, "G": 2.32, "tau_max": 5.79})
    eps = strain + rng.normal(0, 1e-4, n)
    force = (stress + rng.normal(0, 0.3, n)) * 24.0 * np.exp(-eps)
    path = folder / f"rows{n}.csv"
    # the bytes np.savetxt(fmt="%.10g", delimiter=",") writes, in 2/3 of its time (3.7 s at 1e6 rows)
    rows = map("%.10g,%.10g,%.10g\n".__mod__, map(tuple, np.column_stack([t, force, eps]).tolist()))
    path.write_text("t_s,F_N,eps11\n" + "".join(rows))
    cfg = folder / f"rows{n}.yaml"
    cfg.write_text(f"name: rows{n}\ndata:\n  file: {path.name}\n"
                   f"  columns: {{time: t_s, force: F_N, eps11: eps11}}\n  area0: 24.0\n"
                   f"noise: {{sigma0: 0.3}}\n")
    return cfg


def run(cfg: Path, what: str, reduce: str | None = None) -> dict:
    extra = [reduce] if reduce else []
    out = subprocess.run([sys.executable, "-c", CHILD, str(cfg), what, *extra], capture_output=True,
                         text=True, cwd=REPO, check=False)
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--no-fit", action="store_true", help="measure reading only")
    ap.add_argument("--full-up-to", type=int, default=100_000,
                    help="also fit every row (data.reduce: none) up to this size, for the E difference")
    args = ap.parse_args()
    ref = reference_job()
    print(f"reference job: {ref if ref is None else f'{ref:.3f} s'}; load {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        base_cfg = write_test(folder, 1000)
        run(base_cfg, "load")                       # warm the numba cache
        kinds = ["load"] if args.no_fit else ["load", "fit"]
        base = {k: run(base_cfg, k) for k in kinds}
        print(f"{'rows':>9} {'what':>5} {'time s':>8} {'x base':>7} {'cpu s':>8} {'cpu x base':>10} "
              f"{'peak MB':>8} {'extra MB':>9} {'MB per 1e5 rows':>16}  result")
        for k in kinds:
            b = base[k]
            print(f"{1000:>9} {k:>5} {b['wall_s']:8.2f} {1.0:7.1f} {b['cpu_s']:8.2f} {1.0:10.1f} "
                  f"{b['peak_rss_mb']:8.0f} {0:9.0f} {'':>16}  baseline")
        for n in args.sizes:
            cfg = write_test(folder, n)
            size = (folder / f"rows{n}.csv").stat().st_size / 1e6
            for k in kinds:
                r = run(cfg, k)
                if "error" in r:
                    print(f"{n:>9} {k:>5}  error: {r['error']}")
                    continue
                b = base[k]
                extra = r["peak_rss_mb"] - b["peak_rss_mb"]
                info = (r.get("note", "")[:60] if k == "load" else
                        f"E = {r['E']:.2f} ± {r['sd']:.2f} MPa, {r['reduce']}, converged {r['converged']}"
                        + (f", {r['wall_s'] / ref:.1f} reference jobs" if ref else ""))
                if k == "fit" and n <= args.full_up_to and r["reduce"] != "-":
                    f = run(cfg, "fit", "none")
                    if "error" not in f:
                        info += (f"; every row: E = {f['E']:.2f} ± {f['sd']:.2f} MPa in {f['wall_s']:.1f} s, "
                                 f"{f['peak_rss_mb']:.0f} MB: ΔE = {(r['E'] - f['E']) / f['sd']:+.4f} sd")
                print(f"{n:>9} {k:>5} {r['wall_s']:8.2f} {r['wall_s'] / b['wall_s']:7.1f} "
                      f"{r['cpu_s']:8.2f} {r['cpu_s'] / b['cpu_s']:10.1f} {r['peak_rss_mb']:8.0f} "
                      f"{extra:9.0f} {extra / (n / 1e5):16.1f}  {info}"
                      + (f" ({size:.0f} MB file)" if k == "load" else ""))


if __name__ == "__main__":
    main()
