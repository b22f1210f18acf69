"""The fixed CPU reference job the speed figures are quoted against: its seconds, measured in the
same run as the figure (``../shared/tools/refjob.py`` beside or above the clone, or the script
$BAYES_DNLR_REFJOB names). None when there is no such script: the figures are then printed without
their ratios."""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def script() -> Path | None:
    """The reference job's script, or None."""
    if os.environ.get("BAYES_DNLR_REFJOB"):
        path = Path(os.environ["BAYES_DNLR_REFJOB"])
        return path if path.is_file() else None
    for base in (ROOT.parent, ROOT.parents[1]):
        path = base / "shared" / "tools" / "refjob.py"
        if path.is_file():
            return path
    return None


def seconds(repeats: int = 1) -> float | None:
    """The seconds the reference job prints (the median of ``repeats`` runs: one run on a shared
    machine can take half as long again), or None without it (or when it prints no number)."""
    path = script()
    if path is None:
        return None
    times = []
    for _ in range(repeats):
        out = subprocess.run([sys.executable, str(path)], capture_output=True, text=True,
                             check=False)
        try:
            times.append(float(out.stdout.strip().split()[-1]))
        except (ValueError, IndexError):
            return None
    return statistics.median(times)


def load() -> str:
    """The load averages, to print beside a figure."""
    a, b, c = os.getloadavg()
    return f"load {a:.2f} {b:.2f} {c:.2f}"
