"""What `sample` and `report` pay before any work of their own, beside the reference job.

A user types two commands, so two fresh processes each start the interpreter and import what
their command needs; `sample` also pays numba's first dispatch (its target's registries and a
cached function loaded, whatever the function). These costs do not depend on the test. Each is
timed in a fresh process, ``--repeats`` times (the median is printed), in this order:

- the interpreter (``python -c pass``);
- `sample`'s third-party imports: numpy, scipy.optimize, numba, h5py, pydantic, yaml, tqdm and
  emcee (without scipy.stats, as the package imports it);
- the same, then numba's first dispatch of a cached function of the package (``kalman.valid``);
- `sample`'s own imports as the command makes them (``bayes_dnlr.runs.sample``, ``runs.fit``);
- `report`'s third-party imports: numpy, h5py, pydantic, yaml, matplotlib's Figure and Agg canvas;
- `report`'s own imports and ``import_figure_modules`` (matplotlib and corner, as the command does).

The sum for both commands is set against the budget of 3 reference jobs (the median of 3 runs
before and of 3 after), and what the budget leaves for the work itself is printed: on the real ETFE
curve the work measured 0.13 s for the warm fit, 0.45-0.53 s for the sampling loop and 1.4 s of
CPU for the report's figures (benchmarks/user_workflow.py splits it).

    .venv/bin/python benchmarks/workflow_floor.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

from reference_job import load, seconds  # benchmarks/ is the script's folder

# emcee as the package imports it: without scipy.stats (inference/mcmc/emcee_import.py)
SAMPLE_THIRD = ("import numpy, scipy.optimize, numba, h5py, pydantic, yaml, tqdm; "
                "from bayes_dnlr.inference.mcmc.emcee_import import load_emcee; load_emcee()")
FIRST_DISPATCH = ("from bayes_dnlr.inference.discrepancy.kalman import valid; "
                  "valid(1.0, 1.0, 1.0)")
REPORT_THIRD = ("import numpy, h5py, pydantic, yaml, matplotlib.figure, "
                "matplotlib.backends.backend_agg")
STEPS = [
    ("interpreter", "pass"),
    ("sample: third-party imports", SAMPLE_THIRD),
    ("sample: + numba's first dispatch", f"{SAMPLE_THIRD}; {FIRST_DISPATCH}"),
    ("sample: the command's imports + dispatch",
     f"import bayes_dnlr.cli, bayes_dnlr.runs.sample, bayes_dnlr.runs.fit; {FIRST_DISPATCH}"),
    ("report: third-party imports", REPORT_THIRD),
    ("report: the command's imports",
     "import bayes_dnlr.cli, bayes_dnlr.report; "
     "from bayes_dnlr.report.figures import import_figure_modules; import_figure_modules()"),
]


def fresh(code: str) -> float:
    """Wall seconds of ``python -c code`` in a fresh process."""
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print(load())
    ref0 = seconds(3)
    for _, code in STEPS:        # unmeasured: the page cache and numba's cache are warm
        fresh(code)
    times = {label: [] for label, _ in STEPS}
    for _ in range(args.repeats):   # interleaved, so that a slow minute touches every step alike
        for label, code in STEPS:
            times[label].append(fresh(code))
    ref1 = seconds(3)
    unit = (ref0 + ref1) / 2 if ref0 and ref1 else None
    med = {label: statistics.median(v) for label, v in times.items()}
    for label, v in times.items():
        ratio = f" = {med[label] / unit:5.2f} ref. jobs" if unit else ""
        print(f"{label:42s} median {med[label]:5.2f} s (min {min(v):5.2f}){ratio}")
    floor = med["sample: the command's imports + dispatch"] + med["report: the command's imports"]
    print(f"both commands before any work: {floor:.2f} s")
    if unit:
        budget = 3 * unit
        print(f"reference job {ref0:.3f} s before, {ref1:.3f} s after; budget 3 x {unit:.3f} = "
              f"{budget:.2f} s; the floor takes {floor / unit:.2f} of the 3 reference jobs and leaves "
              f"{budget - floor:.2f} s for the fit, the sampling and the figures")
    print(load())


if __name__ == "__main__":
    main()
