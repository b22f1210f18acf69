"""The pieces of the report's self-contained HTML pages: the style sheet, a figure embedded as
base64 PNG, a paragraph and a list, every text escaped.

A figure is placed by ``img`` and embedded by ``embed`` once the page is complete, so that a PNG
drawn by another process (``figure_cache.figure_session``) is read after it is written."""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

CSS = """
body{font-family:-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;color:#222;max-width:1080px;
margin:0 auto;padding:24px 28px 60px;line-height:1.45;background:#fff}
h1{font-size:1.7em;margin:0 0 4px}h2{font-size:1.3em;margin:34px 0 10px;border-bottom:1px solid #ddd;
padding-bottom:4px}h3{font-size:1.05em;margin:20px 0 6px}
.meta{color:#666;font-size:.9em;margin-bottom:18px}
.box{background:#f5f7fa;border:1px solid #dde3ea;border-radius:6px;padding:12px 16px;margin:14px 0}
.warn{background:#fff6e5;border-color:#f0c36d}.bad{color:#a61b1b;font-weight:600}.good{color:#1d6b33;font-weight:600}.ok{background:#eef8f0;border-color:#a6d8b0}
.stale{background:#fde8e8;border:2px solid #c9302c;color:#5a1010}
table{border-collapse:collapse;margin:10px 0 6px;font-size:.92em}
caption{text-align:left;font-weight:600;padding:4px 0;color:#333}
th,td{border:1px solid #d8dde3;padding:4px 9px}thead th{background:#eef1f5}
tbody th{text-align:left;font-weight:600;background:#fafbfc}
table.num td{text-align:right;font-variant-numeric:tabular-nums}
td.flag{background:#fde2d4;font-weight:600}
table.num td{white-space:nowrap}table.num td.text{white-space:normal;text-align:left}
.pair{display:flex;gap:28px;flex-wrap:wrap;align-items:flex-start}
figure{margin:14px 0 22px}figure img{max-width:100%;border:1px solid #eee}
figcaption{color:#444;font-size:.92em;margin-top:4px}
.note{color:#555;font-size:.88em;margin:2px 0 12px}
ul.flags li{margin:4px 0}code{background:#f1f3f5;padding:1px 4px;border-radius:3px}
footer{margin-top:40px;color:#888;font-size:.85em;border-top:1px solid #eee;padding-top:8px}
"""


_PNG = re.compile("\x00png:([^\x00]*)\x00")


def img(path: Path, alt: str, caption: str) -> str:
    """A figure with its caption; its PNG is embedded by ``embed``."""
    return (f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,\x00png:{path}\x00">'
            f"<figcaption>{caption}</figcaption></figure>")


def embed(page: str) -> str:
    """The page with each figure's PNG embedded as base64 (the files are read now)."""
    return _PNG.sub(lambda m: base64.b64encode(Path(m.group(1)).read_bytes()).decode("ascii"), page)


def para(text: str) -> str:
    return f"<p>{html.escape(text)}</p>"


def bullets(items: list[str], cls: str = "") -> str:
    c = f' class="{cls}"' if cls else ""
    return f"<ul{c}>" + "".join(f"<li>{html.escape(i)}</li>" for i in items) + "</ul>"
