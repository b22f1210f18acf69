"""What a user waits for, from a file to a report, beside the reference job timed in the same run.

1. A real curve: ``init`` on the real ETFE export (specimen 1, the config init writes), then from
   an empty run folder ``sample`` (its fit included) and ``report``, each in a fresh process, as a
   user types them; then the same from an empty run folder in one process, ``sample --report``.
   Skipped when the real curves are absent (they are not shipped: ``BAYES_DNLR_REAL_DATA``, or
   ``shared/data/real`` beside or above the clone).
2. The shipped example ``runs/hdpe-a-5e-3`` (copied; the shipped folder is not touched): ``sample``
   from an empty run folder.
3. The same real curves from Python, as a notebook would: one process runs ``bd.sample`` and
   ``build_report`` on the three ETFE specimens from empty run folders, ``--repeats`` rounds; the
   first curve pays the imports and numba's first dispatch, every later one only its own work
   (``--skip-session`` leaves it out).

Each command's wall time and CPU time (user + system of the process and its threads and children) is
printed for every repeat, with the minimum and the median, and the sum of ``sample`` and ``report``
in reference jobs (``../shared/tools/refjob.py``, the median of 3 runs before and of 3 after; their
mean is the unit). The reference job is also timed once just before each measured round, and each
round's time divided by it is printed too ("paired"): on this virtual machine the reference job took
0.91-1.74 s within minutes, so the paired ratios show how far a ratio moves with it. Read their
medians: their minimum picks the round whose reference job happened to be slow. Warm numba cache:
one unmeasured run first compiles or loads what the commands need. The load average is printed
before and after: on a shared machine read the CPU times and the ratios, which do not depend on the
other jobs as much as the wall time does.

    .venv/bin/python benchmarks/user_workflow.py [--repeats 5] [--specimen 1] [--skip-shipped]
                                                 [--skip-session]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from reference_job import load, seconds  # benchmarks/ is the script's folder

ROOT = Path(__file__).resolve().parents[1]
ETFE = "ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens.csv"
OUTPUTS = ("fit.json", "chains.h5", "posterior.nc", "summary.json", "report.html", "figures",
           ".cache", "config.resolved.yaml", "sample.lock")


def real_data() -> Path | None:
    """The folder of the real curves, or None."""
    env = os.environ.get("BAYES_DNLR_REAL_DATA")
    for path in ([Path(env)] if env else [ROOT.parent / "shared" / "data" / "real",
                                          ROOT.parents[1] / "shared" / "data" / "real"]):
        if (path / ETFE).is_file():
            return path
    return None


def command(*args: str, cwd: Path | None = None) -> tuple[float, float]:
    """(wall, CPU) seconds of ``python -m bayes_dnlr args`` in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "bayes_dnlr", *args], cwd=cwd, capture_output=True,
                         text=True, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        sys.exit(f"`bayes_dnlr {' '.join(args)}` failed:\n{out.stdout}\n{out.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def empty(run: Path) -> None:
    """The run folder as before the first command: its config (and data) only."""
    for name in OUTPUTS:
        p = run / name
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()


def summary(label: str, values: list[tuple[float, float]], unit: float | None) -> str:
    walls, cpus = [v[0] for v in values], [v[1] for v in values]
    text = (f"{label:34s} wall min {min(walls):6.2f} s, median {statistics.median(walls):6.2f} s; "
            f"CPU min {min(cpus):6.2f} s, median {statistics.median(cpus):6.2f} s")
    if unit:
        text += (f"  = {min(walls) / unit:5.2f} (min) / {statistics.median(walls) / unit:5.2f} "
                 "(median) ref. jobs")
    return text


def workflow(config: Path, steps: list[tuple[str, list[str]]], repeats: int
             ) -> tuple[dict[str, list[tuple[float, float]]], list[float | None]]:
    """Every step of ``steps`` from an empty run folder, ``repeats`` times (after one unmeasured
    round that warms numba's cache); and the reference job timed just before each measured round
    (None without it), for ratios that follow the machine's speed through the run."""
    times: dict[str, list[tuple[float, float]]] = {name: [] for name, _ in steps}
    refs: list[float | None] = []
    for r in range(repeats + 1):
        empty(config.parent)
        if r:
            refs.append(seconds(1))
        row = []
        for name, args in steps:
            wall, cpu = command(*args)
            if r:
                times[name].append((wall, cpu))
                row.append(f"{name} {wall:5.2f} s ({cpu:5.2f} s CPU)")
        if r:
            ref = f"; reference job {refs[-1]:.2f} s" if refs[-1] else ""
            print(f"  run {r}: " + ", ".join(row) + ref, flush=True)
    return times, refs


SESSION = r"""
import json, sys, time
import bayes_dnlr as bd
from bayes_dnlr.report import build_report
for run in sys.argv[1:]:
    t = time.perf_counter()
    bd.sample(bd.load_config(run + "/config.yaml"), progress=False)
    s = time.perf_counter()
    build_report(run)
    print(json.dumps({"run": run, "sample": s - t, "report": time.perf_counter() - s}), flush=True)
"""


def session(tmp: Path, real: Path, repeats: int) -> list[dict]:
    """Per curve, (sample, report) seconds of the three ETFE specimens in one Python process,
    ``repeats`` rounds from empty run folders (the first curve of the process first)."""
    runs = []
    for k in (1, 2, 3):
        config = tmp / f"session-{k}" / "config.yaml"
        command("init", str(real / ETFE), "--out", str(config))
        config.write_text(config.read_text().replace("specimen: 1 ", f"specimen: {k} "))
        runs.append(config.parent)
    for run in runs:
        empty(run)
    rounds = [str(r) for _ in range(repeats) for r in runs]
    # each round again from an empty folder: a small driver empties it before its turn
    driver = SESSION.replace("    t = time.perf_counter()\n",
                             "    import shutil, pathlib\n"
                             "    for n in OUTPUTS:\n"
                             "        p = pathlib.Path(run) / n\n"
                             "        shutil.rmtree(p) if p.is_dir() else p.unlink(missing_ok=True)\n"
                             "    t = time.perf_counter()\n")
    out = subprocess.run([sys.executable, "-c", f"OUTPUTS = {OUTPUTS!r}\n" + driver, *rounds],
                         capture_output=True, text=True, check=False)
    if out.returncode != 0:
        sys.exit(f"the session failed:\n{out.stdout}\n{out.stderr}")
    return [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]


def paired(label: str, values: list[tuple[float, float]], refs: list[float | None]) -> str | None:
    """Each run's wall time over the reference job timed just before it: min and median."""
    if not refs or any(r is None for r in refs):
        return None
    ratios = [v[0] / r for v, r in zip(values, refs, strict=True)]
    return (f"{label:34s} paired with its run's reference job: {min(ratios):5.2f} (min) / "
            f"{statistics.median(ratios):5.2f} (median) ref. jobs")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--specimen", type=int, default=1, help="ETFE specimen (1-3), as init numbers them")
    ap.add_argument("--skip-shipped", action="store_true", help="only the real curve")
    ap.add_argument("--skip-session", action="store_true", help="no Python session (part 3)")
    args = ap.parse_args()

    print(load())
    ref0 = seconds(3)
    print(f"reference job: {ref0} s" if ref0 else "reference job: not found (no ratios)")
    with tempfile.TemporaryDirectory(prefix="bd-workflow-") as tmp:
        tmp = Path(tmp)
        results: dict[str, tuple[dict[str, list[tuple[float, float]]], list[float | None]]] = {}
        real = real_data()
        if real is None:
            print("real curves absent: the real-curve workflow is skipped")
        else:
            config = tmp / "etfe" / "config.yaml"
            command("init", str(real / ETFE), "--out", str(config))
            if args.specimen != 1:
                text = config.read_text().replace("specimen: 1 ", f"specimen: {args.specimen} ")
                config.write_text(text)
            print(f"real curve: {ETFE}, specimen {args.specimen} (the config init writes)")
            results["real"] = workflow(config, [("sample", ["sample", str(config)]),
                                                ("report", ["report", str(config.parent)])],
                                       args.repeats)
            print("the same in one process: sample --report")
            results["one"] = workflow(config, [("sample --report",
                                                ["sample", str(config), "--report"])], args.repeats)
        if real is not None and not args.skip_session:
            print("the three specimens in one Python session (bd.sample, build_report)")
            results["session"] = session(tmp, real, args.repeats)
        if not args.skip_shipped:
            run = tmp / "hdpe-a-5e-3"
            shutil.copytree(ROOT / "runs" / "hdpe-a-5e-3", run,
                            ignore=shutil.ignore_patterns(*OUTPUTS))
            print("shipped example runs/hdpe-a-5e-3 (copy)")
            results["shipped"] = workflow(run / "config.yaml",
                                          [("sample", ["sample", str(run / "config.yaml")])],
                                          args.repeats)
    ref1 = seconds(3)
    unit = (ref0 + ref1) / 2 if ref0 and ref1 else None
    print(f"reference job after: {ref1} s; unit {unit:.3f} s" if unit else "no reference job")
    print(load())
    lines: list[tuple[str, list[tuple[float, float]], list[float | None]]] = []
    if "real" in results:
        r, refs = results["real"]
        both = [(a[0] + b[0], a[1] + b[1]) for a, b in zip(r["sample"], r["report"], strict=True)]
        lines += [("real curve: sample (fit included)", r["sample"], refs),
                  ("real curve: report", r["report"], refs),
                  ("real curve: sample + report", both, refs)]
    if "one" in results:
        lines.append(("real curve: sample --report", results["one"][0]["sample --report"],
                      results["one"][1]))
    if "shipped" in results:
        lines.append(("shipped example: sample (empty)", results["shipped"][0]["sample"],
                      results["shipped"][1]))
    for label, values, _ in lines:
        print(summary(label, values, unit))
    for label, values, refs in lines:
        text = paired(label, values, refs)
        if text:
            print(text)
    if "session" in results:
        first, *later = results["session"]
        print(f"Python session, the first curve (the imports and numba's first dispatch in it): "
              f"sample {first['sample']:.2f} s + report {first['report']:.2f} s")
        both = [r["sample"] + r["report"] for r in later]
        ratio = (f" = {min(both) / unit:5.2f} (min) / {statistics.median(both) / unit:5.2f} "
                 "(median) ref. jobs" if unit else "")
        print(f"Python session, each later curve ({len(later)}): sample + report min "
              f"{min(both):.2f} s, median {statistics.median(both):.2f} s{ratio}; sample median "
              f"{statistics.median(r['sample'] for r in later):.2f} s, report median "
              f"{statistics.median(r['report'] for r in later):.2f} s")


if __name__ == "__main__":
    main()
