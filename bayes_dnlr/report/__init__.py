"""Reports: figures, tables and the self-contained HTML page of a run; ``compare`` across runs.

The only package that imports matplotlib, corner and ArviZ's plotting (inside the functions).
"""

from __future__ import annotations

from pathlib import Path


def build_report(run_dir: Path | str, source: Path | str | None = None) -> Path:
    """Write run_dir/report.html and run_dir/figures/*.png; return the path of report.html
    (``source``: the user's config file, when known: the results are checked against it)."""
    from bayes_dnlr.report.html import build_report as _build

    return _build(run_dir, source=source)


__all__ = ["build_report"]
