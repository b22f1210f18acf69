"""Time of the sampler-diagnostic figures: our trace plot against ArviZ's plot_trace_dist (the
baseline it replaced), and the rank plot, on synthetic walkers of the shipped example's size.

Both are timed in the same process, alternately, best of ``--repeat``; the machine may be shared,
so read ratios rather than absolute times.

    .venv/bin/python benchmarks/report_figures.py [--walkers 32] [--draws 2000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def arviz_trace(draws: dict[str, np.ndarray], path: Path, max_draws: int = 1000) -> None:
    """The trace plot the report drew before (ArviZ 1.x plot_trace_dist, no units)."""
    import arviz as az

    from bayes_dnlr.report.figures import _pooled, pyplot

    plt = pyplot()
    tree = az.from_dict({"posterior": _pooled(draws, None, max_draws, 1)})
    pc = az.plot_trace_dist(tree, sample_dims=["chain", "draw"], compact=True)
    pc.savefig(str(path), dpi=110, bbox_inches="tight")
    plt.close("all")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walkers", type=int, default=32)
    ap.add_argument("--draws", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    from bayes_dnlr.report import figures as figs

    rng = np.random.default_rng(0)
    shape = (args.walkers, args.draws)
    draws = {"E": 2854 + 13 * rng.normal(size=shape), "G": 2.32 + 0.01 * rng.normal(size=shape),
             "tau_max": 5.79 + 0.03 * rng.normal(size=shape)}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        figs.trace_plot(draws, out / "warm.png")          # imports and font cache outside the timing
        arviz_trace(draws, out / "warm2.png")
        times: dict[str, list[float]] = {"trace_plot (ours)": [], "ArviZ plot_trace_dist": [],
                                         "rank_plot": []}
        for _ in range(args.repeat):
            for name, call in (("trace_plot (ours)", lambda: figs.trace_plot(draws, out / "t.png")),
                               ("ArviZ plot_trace_dist", lambda: arviz_trace(draws, out / "a.png")),
                               ("rank_plot", lambda: figs.rank_plot(draws, out / "r.png", thin=10))):
                t0 = time.perf_counter()
                call()
                times[name].append(time.perf_counter() - t0)
    base = min(times["ArviZ plot_trace_dist"])
    print(f"{args.walkers} walkers x {args.draws} draws, 3 parameters, best of {args.repeat}")
    for name, ts in times.items():
        print(f"  {name:24s} {min(ts):6.2f} s   ratio to ArviZ trace {min(ts) / base:5.2f}")


if __name__ == "__main__":
    main()
