"""Reports: figures, tables and the self-contained HTML page of a run; ``compare`` across runs.

The only package that imports matplotlib, corner and ArviZ's plotting (inside the functions).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path


def build_report(run_dir: Path | str, source: Path | str | None = None,
                 on_stale: Callable[[str], None] | None = None) -> Path:
    """Write run_dir/report.html and run_dir/figures/*.png; return the path of report.html
    (``source``: the user's config file, when known: the results are checked against it;
    ``on_stale`` is called with each result that does not belong to it, besides the page's box)."""
    from bayes_dnlr.report.html import build_report as _build

    return _build(run_dir, source=source, on_stale=on_stale)


__all__ = ["build_report"]
