"""The run folder's file names: the one place that spells them (docs/sampling.md, "The run folder").

    <run_dir>/
        config.yaml            the resolved config (config.resolved.yaml beside a user's own config)
        fit.json               least squares and the paper's stochastic analysis (``fit``)
        chains.h5              the chain, in checkpoints (``sample``)
        posterior.nc           the kept draws, ArviZ-readable (``sample``)
        summary.json           the posterior's numbers and checks (``sample``)
        report.html, figures/  the report (``report``)
        export/                FE material cards (``export``)
        sample.lock            while a ``sample`` runs
        .cache/                the smoothed strain of each command's data, by the digest of its
                               inputs (data/smoothing.py): safe to delete
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

RESOLVED_CONFIG = "config.yaml"
RESOLVED_CONFIG_BESIDE_SOURCE = "config.resolved.yaml"
FIT_FILE = "fit.json"
CHAINS_FILE = "chains.h5"
POSTERIOR_FILE = "posterior.nc"
SUMMARY_FILE = "summary.json"
REPORT_FILE = "report.html"
FIGURES_DIR = "figures"
EXPORT_DIR = "export"
SAMPLE_LOCK = "sample.lock"
SMOOTHING_CACHE = ".cache"
RESULT_FILES = (FIT_FILE, SUMMARY_FILE, POSTERIOR_FILE)     # what a report is built from


@dataclass(frozen=True)
class RunFiles:
    """The paths of one run folder's files."""

    run_dir: Path

    @property
    def fit(self) -> Path:
        return self.run_dir / FIT_FILE

    @property
    def chains(self) -> Path:
        return self.run_dir / CHAINS_FILE

    @property
    def posterior(self) -> Path:
        return self.run_dir / POSTERIOR_FILE

    @property
    def summary(self) -> Path:
        return self.run_dir / SUMMARY_FILE

    @property
    def report(self) -> Path:
        return self.run_dir / REPORT_FILE

    @property
    def figures(self) -> Path:
        return self.run_dir / FIGURES_DIR

    @property
    def export(self) -> Path:
        return self.run_dir / EXPORT_DIR


def files(run_dir: str | Path) -> RunFiles:
    return RunFiles(Path(run_dir))
