"""`sample`, `report --force` and `export` on a finished run whose chains.h5 is damaged: 10 strides
and offsets of flipped bytes, cuts, metadata zeroed, the global heap zeroed
(tests/support/damage.py). Each command runs in its own process, with the package's deadline;
prints its exit status, its time and the first words of its error, then the slowest time of each
command beside its time on the intact run, measured in the same run (the baseline).

    .venv/bin/python benchmarks/damaged_chains.py [--only NAME,...]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO / "tests"))

from support.damage import CHAIN_DAMAGES, damage_file  # noqa: E402
from support.finished_run import make_finished_run  # noqa: E402

COMMANDS = {
    "sample": lambda run: ["sample", str(run / "config.yaml"), "--quiet"],
    "report": lambda run: ["report", str(run), "--force"],
    "export": lambda run: ["export", str(run), "--format", "abaqus", "--force"],
}


def timed(run: Path, command: str) -> tuple[int, float, str]:
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "bayes_dnlr", *COMMANDS[command](run)],
                         capture_output=True, text=True, timeout=600, cwd=REPO)
    dt = time.perf_counter() - t0
    traceback = "TRACEBACK " if "Traceback" in out.stderr else ""
    last = (out.stderr.strip().splitlines() or [""])[-1]
    return out.returncode, dt, traceback + last


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", default=None, help="damages to run, comma-separated (default: all)")
    args = ap.parse_args()
    names = args.only.split(",") if args.only else list(CHAIN_DAMAGES)
    print(f"load: {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        pristine = make_finished_run(Path(tmp) / "made")
        base = {}
        for command in COMMANDS:
            run = Path(shutil.copytree(pristine, Path(tmp) / "intact" / command / "tiny"))
            rc, dt, _ = timed(run, command)
            base[command] = dt
            print(f"{'intact':18s} {command:7s} exit {rc}  {dt:5.2f} s")
        slowest = dict.fromkeys(COMMANDS, (0.0, ""))
        tracebacks = 0
        for name in names:
            for command in COMMANDS:
                run = Path(shutil.copytree(pristine, Path(tmp) / name / command / "tiny"))
                damage_file(run / "chains.h5", CHAIN_DAMAGES[name])
                rc, dt, last = timed(run, command)
                tracebacks += last.startswith("TRACEBACK")
                if dt > slowest[command][0]:
                    slowest[command] = (dt, name)
                shown = last.replace(str(run), "RUN")[:110]
                print(f"{name:18s} {command:7s} exit {rc}  {dt:5.2f} s  {shown}", flush=True)
    print(f"\n{len(names)} damages x {len(COMMANDS)} commands; tracebacks: {tracebacks}")
    for command, (dt, name) in slowest.items():
        print(f"slowest {command:7s} {dt:5.2f} s ({name}); intact run {base[command]:5.2f} s; "
              f"ratio {dt / base[command]:.2f}")


if __name__ == "__main__":
    main()
