"""Render a run's report.html (or any page: a batch's batch.html) in headless Chromium: a PNG of the
whole page, and what a reader of the page would meet (tables or figures wider than the window,
images that do not load, console errors, the text of the first screen).

    python docs/screenshot.py runs/hdpe-a-5e-3 [out.png] [--width 1280]
    python docs/screenshot.py runs/batch/batch.html [out.png]
    python docs/screenshot.py runs/table4-hdpe-a table4.png --part table4

The PNG is as tall as the page (a report of a real curve runs to about 10 000 px; ``--height N``
keeps its top N px), at the window's width. ``--part ID`` shows one element of the page (by its id:
``table4``, or ``table4-<test>`` in a run with several tests) with the page's style, instead of the
whole page. Builds the report first when report.html is missing. Skips (exit 0, with a message) when no
Chromium is installed (Debian: ``apt-get install chromium``).

Chromium is driven through its DevTools protocol over a pipe (``--remote-debugging-pipe``: JSON
messages ended by a NUL byte on the browser's file descriptors 3 and 4), so no port is opened and
nothing beyond the standard library is needed. tests/report/test_browser.py checks the pages the
package writes with ``open_page``.
"""

from __future__ import annotations

import argparse
import base64
import fcntl
import html
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--remote-debugging-pipe"]
FIRST_SCREEN = 800          # px: the height of a laptop's first screen below the browser's bars

# What the page holds, measured in the page: the document's width against the window's, every
# table, figure and image wider than the window or reaching past its right edge, the images that did
# not load, and the text of the first screen (each text node above FIRST_SCREEN px).
_MEASURE = """(() => {
  const W = document.documentElement.clientWidth, H = %d;
  const wide = [];
  for (const el of document.querySelectorAll('table, figure, img, pre, svg')) {
    const r = el.getBoundingClientRect();
    if (r.width > 0 && (r.right > W + 0.5 || r.left < -0.5)) {
      const cap = el.querySelector ? (el.querySelector('caption, th, figcaption') || el) : el;
      wide.push({tag: el.tagName.toLowerCase(), left: r.left, right: r.right,
                 text: (cap.textContent || el.getAttribute('alt') || '').trim().slice(0, 80)});
    }
  }
  const broken = [...document.images].filter(i => !(i.complete && i.naturalWidth > 0))
      .map(i => i.getAttribute('alt') || i.src.slice(0, 60));
  const first = [];
  const walk = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  const range = document.createRange();
  for (let n = walk.nextNode(); n; n = walk.nextNode()) {
    if (!n.textContent.trim()) continue;
    range.selectNodeContents(n);
    const r = range.getBoundingClientRect();
    if (r.height > 0 && r.top < H) first.push(n.textContent.trim());
  }
  return JSON.stringify({width: W, scroll_width: document.documentElement.scrollWidth,
                         height: document.documentElement.scrollHeight, wide: wide,
                         images: document.images.length, broken: broken,
                         first_screen: first.join(' ')});
})()"""


@dataclass
class Page:
    """What ``open_page`` found on a page at a window width."""

    width: int                          # the window's inner width, px
    scroll_width: int                   # the document's: wider than ``width`` scrolls sideways
    height: int                         # the document's full height, px
    wide: list[dict]                    # tables, figures, images past the window's edge
    images: int
    broken: list[str]                   # images that did not load
    first_screen: str                   # the text above FIRST_SCREEN px
    errors: list[str] = field(default_factory=list)   # console errors, uncaught exceptions, failed loads
    seconds: float = 0.0                # wall time of the browser, start to end


def find_chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


class _Browser:
    """One headless Chromium and one tab of it, spoken to over the DevTools pipe."""

    def __init__(self, exe: str, profile: str, timeout: float) -> None:
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()

        def fds() -> None:      # in the child: the protocol's fixed descriptors 3 and 4
            r, w = (fcntl.fcntl(fd, fcntl.F_DUPFD, 5) for fd in (to_browser_r, from_browser_w))
            os.dup2(r, 3, inheritable=True)
            os.dup2(w, 4, inheritable=True)

        self.proc = subprocess.Popen([exe, *FLAGS, f"--user-data-dir={profile}", "about:blank"],
                                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, preexec_fn=fds, close_fds=False)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.deadline = time.monotonic() + timeout
        self._buffer = b""
        self._id = 0
        self.events: list[dict] = []
        target = self.call("Target.createTarget", url="about:blank")["targetId"]
        self.session = self.call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]

    def _message(self) -> dict:
        while b"\0" not in self._buffer:
            if time.monotonic() > self.deadline:
                raise TimeoutError("Chromium did not answer in time")
            chunk = os.read(self._from_browser, 1 << 20)
            if not chunk:
                raise RuntimeError("Chromium closed its DevTools pipe")
            self._buffer += chunk
        raw, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(raw)

    def call(self, method: str, session: bool = False, **params) -> dict:
        """Send a command and wait for its answer; events met meanwhile are kept in ``events``."""
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params}
        if session:
            msg["sessionId"] = self.session
        os.write(self._to_browser, json.dumps(msg).encode() + b"\0")
        while True:
            m = self._message()
            if m.get("id") == self._id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error'].get('message')}")
                return m.get("result", {})
            self.events.append(m)

    def wait_for(self, event: str) -> None:
        while not any(e.get("method") == event for e in self.events):
            self.events.append(self._message())

    def close(self) -> None:
        try:
            self.call("Browser.close")
        except (RuntimeError, TimeoutError, OSError):
            pass
        for fd in (self._to_browser, self._from_browser):
            os.close(fd)
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def _errors(events: list[dict]) -> list[str]:
    """Console errors, uncaught exceptions and failed loads among the page's events."""
    out = []
    for e in events:
        p = e.get("params", {})
        if e.get("method") == "Runtime.consoleAPICalled" and p.get("type") == "error":
            out.append("console: " + " ".join(str(a.get("value", a.get("description", "")))
                                              for a in p.get("args", [])))
        elif e.get("method") == "Runtime.exceptionThrown":
            d = p.get("exceptionDetails", {})
            out.append("exception: " + str(d.get("exception", {}).get("description", d.get("text"))))
        elif e.get("method") == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
            out.append("log: " + p["entry"].get("text", ""))
    return out


def open_page(html_file: Path, width: int = 1280, png: Path | None = None,
              timeout: float = 120.0, height: int | None = None) -> Page | None:
    """Load ``html_file`` in a ``width`` px window, measure it (``Page``) and, with ``png``, save a
    screenshot of its full height there (its top ``height`` px when given); None when Chromium is
    missing."""
    exe = find_chromium()
    if exe is None:
        return None
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="chromium-profile-") as profile:
        b = _Browser(exe, profile, timeout)
        try:
            for domain in ("Page", "Runtime", "Log"):
                b.call(f"{domain}.enable", session=True)
            b.call("Emulation.setDeviceMetricsOverride", session=True, width=width,
                   height=FIRST_SCREEN, deviceScaleFactor=1, mobile=False)
            b.call("Page.navigate", session=True, url=html_file.resolve().as_uri())
            b.wait_for("Page.loadEventFired")
            found = json.loads(b.call("Runtime.evaluate", session=True, expression=_MEASURE % FIRST_SCREEN,
                                      returnByValue=True)["result"]["value"])
            if png is not None:
                shot = b.call("Page.captureScreenshot", session=True, format="png",
                              captureBeyondViewport=True,
                              clip={"x": 0, "y": 0, "width": max(width, found["scroll_width"]),
                                    "height": min(found["height"], height or found["height"]),
                                    "scale": 1})
                png.write_bytes(base64.b64decode(shot["data"]))
            errors = _errors(b.events)
        finally:
            b.close()
    return Page(**found, errors=errors, seconds=time.monotonic() - start)


def screenshot(html_file: Path, out: Path, width: int = 1280, timeout: float = 120.0,
               height: int | None = None) -> Path | None:
    """Screenshot the full height of ``html_file`` (its top ``height`` px when given) into ``out``;
    None when Chromium is missing."""
    return out if open_page(html_file, width, out, timeout, height) is not None else None


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
    ap.add_argument("--height", type=int, default=None, help="keep the top N px (default: the page's)")
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
    with tempfile.TemporaryDirectory(prefix="report-part-") as tmp:
        if args.part:       # figures are embedded (base64), so the part stands alone anywhere
            html_file = part_page(html_file, args.part, Path(tmp) / "part.html")
        page = open_page(html_file, args.width, out, height=args.height)
    print(f"{out} ({args.width} x {min(page.height, args.height or page.height)} px)")
    for w in page.wide:
        print(f"wider than the window: <{w['tag']}> {w['text']!r} ({w['left']:.0f}-{w['right']:.0f} px)")
    for b in page.broken:
        print(f"image not loaded: {b}")
    for e in page.errors:
        print(e)
    return 0


if __name__ == "__main__":
    sys.exit(main())
