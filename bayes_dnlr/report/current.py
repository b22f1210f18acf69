"""Is a run's report current? report.html newer than everything it is built from (the
re-run of a finished ``make demo`` rebuilt an unchanged report, 17 s for nothing)."""

from __future__ import annotations

from pathlib import Path

from bayes_dnlr.runs.folder import find_config
from bayes_dnlr.runs.layout import (
    FIGURES_DIR,
    REPORT_FILE,
    RESOLVED_CONFIG,
    RESOLVED_CONFIG_BESIDE_SOURCE,
    RESULT_FILES,
)

REPORT_SET = [REPORT_FILE, f"{FIGURES_DIR}/*.png"]       # published together (bayes_dnlr/fileset.py)


def report_inputs(run_dir: Path) -> list[Path]:
    """The files report.html is built from: the run's configs, its data file(s) (a DMA sweep of
    ``reference_moduli`` included) and results."""
    from bayes_dnlr.config import load_config

    run_dir = Path(run_dir)
    paths = [run_dir / n for n in (RESOLVED_CONFIG, RESOLVED_CONFIG_BESIDE_SOURCE, *RESULT_FILES)]
    try:
        cfg = load_config(find_config(run_dir))
        paths += [t.data_path for t in cfg.test_configs()]
        paths += [cfg.base_dir / r.file for r in cfg.reference_moduli or [] if r.file]
    except Exception:  # noqa: BLE001 - an unreadable config: build_report will say what is wrong
        return []
    return [p for p in paths if p.is_file()]


def stale_inputs(run_dir: Path) -> list[Path] | None:
    """None when report.html is missing or cannot be judged (build it); else the inputs newer than
    it (an empty list: the report is current). A report whose writer was killed is rolled back
    first (the one before it is judged)."""
    from bayes_dnlr.fileset import recover

    recover(Path(run_dir), "report", REPORT_SET)
    report = Path(run_dir) / REPORT_FILE
    inputs = report_inputs(run_dir)
    if not report.is_file() or not inputs:
        return None
    built = report.stat().st_mtime_ns
    return [p for p in inputs if p.stat().st_mtime_ns >= built]


def figures_current(run_dir: Path) -> bool:
    """report.html is current and its figures are there: a rebuild (``report --force``) most
    likely keeps every figure, and draws none beside the page (no worker process)."""
    return stale_inputs(run_dir) == [] and any((Path(run_dir) / FIGURES_DIR).glob("*.png"))
