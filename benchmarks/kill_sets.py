"""Kill `export --draws 2000` and `batch` (with reports) at 20 instants each and count the output
sets found old, new or mixed after each kill, and the temporaries left after the next run
(bayes_dnlr/fileset.py; tests/test_fileset.py runs a few instants of the same).

    .venv/bin/python benchmarks/kill_sets.py [--instants 20] [--draws 2000] [--tests 3] [--only export|batch]

Prints one line per command and the wall time of the whole, as a ratio to the reference job
(benchmarks/reference_job.py, when present) measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from reference_job import seconds as refjob  # benchmarks/ is the script's folder

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from support.finished_run import make_finished_run  # noqa: E402
from support.kill import batch_kills, campaign, export_kills  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--instants", type=int, default=20)
    ap.add_argument("--draws", type=int, default=2000)
    ap.add_argument("--tests", type=int, default=3)
    ap.add_argument("--only", choices=["export", "batch"], default=None)
    args = ap.parse_args()
    ref = refjob()
    print(f"load: {os.getloadavg()[0]:.1f}; reference job: {ref if ref is None else f'{ref:.2f} s'}")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        if args.only in (None, "export"):
            t0 = time.monotonic()
            run = make_finished_run(root / "runs")
            tally = export_kills(run, root / "export", args.draws, args.instants)
            dt = time.monotonic() - t0
            print(tally.line(f"export --draws {args.draws}") + f"; {dt:.0f} s"
                  + (f" ({dt / ref:.1f} reference jobs)" if ref else ""))
            for m in tally.mixed + tally.left_after_next_run:
                print(f"  {m}")
        if args.only in (None, "batch"):
            t0 = time.monotonic()
            folder, batch_args, _ = campaign(root / "campaign", args.tests)
            tally = batch_kills(folder, batch_args, root / "batch", args.instants)
            dt = time.monotonic() - t0
            print(tally.line(f"batch of {args.tests} tests with reports") + f"; {dt:.0f} s"
                  + (f" ({dt / ref:.1f} reference jobs)" if ref else ""))
            for m in tally.mixed + tally.left_after_next_run:
                print(f"  {m}")


if __name__ == "__main__":
    main()
