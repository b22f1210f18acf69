"""Render a run's report.html (or any page: a batch's batch.html) in headless Chromium and save a
PNG screenshot.

    python docs/screenshot.py runs/hdpe-a-5e-3 [out.png] [--height 9000]
    python docs/screenshot.py runs/batch/batch.html [out.png]
    python docs/screenshot.py runs/table4-hdpe-a table4.png --part table4 --height 1600

``--part ID`` shows one element of the page (by its id: ``table4``, or ``table4-<test>`` in a run with
several tests) with the page's style, instead of the whole page.

Builds the report first when report.html is missing. Skips (exit 0, with a message) when no Chromium
is installed (Debian: ``apt-get install chromium``).
"""

from __future__ import annotations

import argparse
import html
import re
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


def part_page(html_file: Path, element: str, out: Path) -> Path:
    """A page with the ``<head>`` of ``html_file`` and only its element ``id="element"`` (up to the
    element's closing tag at the same depth), written to ``out``."""
    text = html_file.read_text(encoding="utf-8")
    head = re.search(r"<head>.*?</head>", text, re.S)
    start = re.search(rf'<(\w+)[^>]*\bid="{re.escape(element)}"', text)
    if start is None:
        raise SystemExit(f"error: {html_file} has no element with id {element!r}")
    tag, depth, pos = start.group(1), 0, start.start()
    for m in re.finditer(rf"<(/?){tag}\b[^>]*>", text[pos:]):
        depth += -1 if m.group(1) else 1
        if depth == 0:
            body = text[pos:pos + m.end()]
            break
    else:
        raise SystemExit(f"error: {html_file}: the element {element!r} is not closed")
    title = html.escape(f"{html_file.parent.name}: {element}")
    out.write_text(f"<!doctype html><html>{head.group(0) if head else ''}<body><p>{title}</p>{body}"
                   "</body></html>", encoding="utf-8")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path, help="a run folder, or an HTML page (batch.html)")
    ap.add_argument("out", type=Path, nargs="?", default=None,
                    help="PNG (default: run_dir/report.png, or the page's name with .png)")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=9000)
    ap.add_argument("--part", default=None, help="the id of one element of the page to show (table4)")
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
    if args.part:
        with tempfile.TemporaryDirectory(prefix="report-part-") as tmp:
            # figures are embedded (base64), so the page stands alone anywhere
            screenshot(part_page(html_file, args.part, Path(tmp) / "part.html"), out, args.width,
                       args.height)
    else:
        screenshot(html_file, out, args.width, args.height)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
