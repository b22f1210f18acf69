"""Reports: figures, tables and the self-contained HTML page of a run; ``compare`` across runs.

The only package that imports matplotlib, corner and ArviZ's plotting (inside the functions). It
imports ``runs`` and below, computes no model, and reads fit.json through ``runs.records``.

- ``html``: the page of a run with any number of tests (its numbered sections);
- ``run_sections``, ``across_tests``, ``per_test_sections``, ``headline``: the run's sections, those
  across tests, each test's, and the top of the page;
- ``tables``, ``model_error``, ``views``: tables, the model-error words, what each figure shows;
- ``figures``, ``rank``, ``figure_cache``: the figures, the rank plot's statistics, drawing only
  when inputs change (and in a worker process); ``canvas``: a figure rendered once into its PNG;
  ``corner_loader``: corner without ArviZ and scipy.ndimage; ``page_parts``: the page's pieces;
- ``current``: whether report.html is up to date; ``compare``: Tables 3/5 across runs.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path


def build_report(run_dir: Path | str, source: Path | str | None = None,
                 on_stale: Callable[[str], None] | None = None) -> Path:
    """Write run_dir/report.html and run_dir/figures/*.png as one set (bayes_dnlr/fileset.py: a kill
    leaves the old report and figures or the new ones); return the path of report.html
    (``source``: the user's config file, when known: the results are checked against it;
    ``on_stale`` is called with each result that does not belong to it, besides the page's box)."""
    from bayes_dnlr.fileset import publishing
    from bayes_dnlr.report.current import REPORT_SET, figures_current
    from bayes_dnlr.report.html import build_report as _build

    if not Path(run_dir).is_dir():
        return _build(run_dir, source=source, on_stale=on_stale)      # says what is wrong
    aside = not figures_current(Path(run_dir))
    with publishing(Path(run_dir), "report", REPORT_SET):
        return _build(run_dir, source=source, on_stale=on_stale, aside=aside)


__all__ = ["build_report"]
