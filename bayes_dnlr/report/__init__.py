"""Reports: figures, tables and the self-contained HTML page of a run; ``compare`` across runs.

The only package that imports matplotlib, corner and ArviZ's plotting (inside the functions).
"""

from __future__ import annotations

from pathlib import Path


def build_report(run_dir: Path | str) -> Path:
    """Write run_dir/report.html and run_dir/figures/*.png as one set (bayes_dnlr/fileset.py: a kill
    leaves the old report and figures or the new ones); return the path of report.html."""
    from bayes_dnlr.fileset import publishing
    from bayes_dnlr.report.current import REPORT_SET
    from bayes_dnlr.report.html import build_report as _build

    if not Path(run_dir).is_dir():
        return _build(run_dir)              # says what is wrong
    with publishing(Path(run_dir), "report", REPORT_SET):
        return _build(run_dir)


__all__ = ["build_report"]
