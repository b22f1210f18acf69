"""Render a run's report.html (or any page: a batch's batch.html) in headless Chromium and save a
PNG screenshot.

    python docs/screenshot.py runs/hdpe-a-5e-3 [out.png] [--height 9000]
    python docs/screenshot.py runs/batch/batch.html [out.png]

Builds the report first when report.html is missing. Skips (exit 0, with a message) when no Chromium
is installed (Debian: ``apt-get install chromium``).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars"]


def find_chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def screenshot(html_file: Path, out: Path, width: int = 1280, height: int = 9000,
               timeout: float = 120.0) -> Path | None:
    """Screenshot ``html_file`` into ``out``; None when Chromium is missing."""
    exe = find_chromium()
    if exe is None:
        return None
    with tempfile.TemporaryDirectory(prefix="chromium-profile-") as profile:
        cmd = [exe, *FLAGS, f"--user-data-dir={profile}", f"--screenshot={out.resolve()}",
               f"--window-size={width},{height}", html_file.resolve().as_uri()]
        subprocess.run(cmd, check=True, timeout=timeout, capture_output=True)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path, help="a run folder, or an HTML page (batch.html)")
    ap.add_argument("out", type=Path, nargs="?", default=None,
                    help="PNG (default: run_dir/report.png, or the page's name with .png)")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=9000)
    args = ap.parse_args(argv)
    if find_chromium() is None:
        print("skipped: no chromium found (apt-get install chromium)")
        return 0
    if args.run_dir.is_file():
        html_file = args.run_dir
        out = args.out or html_file.with_suffix(".png")
    else:
        html_file = args.run_dir / "report.html"
        if not html_file.is_file():
            from bayes_dnlr.report import build_report

            build_report(args.run_dir)
        out = args.out or args.run_dir / "report.png"
    screenshot(html_file, out, args.width, args.height)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
