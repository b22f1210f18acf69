"""The figure of a design (``python -m bayes_dnlr design``): predicted Err(E) against the strain rate,
one line per maximum strain, at the recommended sampling, hold and window."""

from __future__ import annotations

import math
from pathlib import Path

from bayes_dnlr.fileset import publishing
from bayes_dnlr.report.canvas import save_figure
from bayes_dnlr.report.figures import pyplot
from bayes_dnlr.workflows.design.config import DesignConfig
from bayes_dnlr.workflows.design.run import (
    FIGURE_FILE,
    MARKDOWN_FILE,
    RESULT_FILE,
    TABLE_FILE,
    DesignResult,
    run_design,
)


def err_figure(res: DesignResult, path: Path, parameter: str = "E") -> Path:
    """Err(parameter) in % against the strain rate (log-log), one line per strain_max; open markers
    outside the constraints; a star at the recommendation."""
    plt = pyplot()
    r = res.recommended.candidate
    same = [p for p in res.predictions
            if p.candidate.sample_rate == r.sample_rate and p.candidate.n_points == r.n_points
            and p.candidate.hold == r.hold and p.candidate.window == r.window]
    fig, ax = plt.subplots(figsize=(7.0, 4.6))
    cmap = plt.get_cmap("viridis")
    levels = sorted({p.candidate.strain_max for p in same})
    for i, emax in enumerate(levels):
        pts = sorted((p for p in same if p.candidate.strain_max == emax),
                     key=lambda p: p.candidate.strain_rate)
        xs = [p.candidate.strain_rate for p in pts]
        ys = [100 * p.err.get(parameter, math.nan) for p in pts]
        color = cmap(i / max(1, len(levels) - 1))
        ax.plot(xs, ys, "-", color=color, lw=1.4, label=f"strain to {emax:g}")
        ax.plot([x for x, p in zip(xs, pts, strict=True) if p.feasible],
                [y for y, p in zip(ys, pts, strict=True) if p.feasible], "o", color=color, ms=4)
        ax.plot([x for x, p in zip(xs, pts, strict=True) if not p.feasible],
                [y for y, p in zip(ys, pts, strict=True) if not p.feasible], "o", mfc="white", color=color,
                ms=4)
    best = res.recommended
    ax.plot([r.strain_rate], [100 * best.err.get(parameter, math.nan)], "*", color="#c0392b", ms=14,
            label="recommended", zorder=5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("strain rate (1/s)")
    ax.set_ylabel(f"predicted Err({parameter}) (%)")
    samp = f"{r.sample_rate:g} Hz" if r.sample_rate is not None else f"{r.n_points} points"
    ax.set_title(f"{res.cfg.name}: {samp}, hold {r.hold:g} s, window {r.window}\n{res.noise_text()}",
                 fontsize=9)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=8, title="open: outside the constraints", title_fontsize=7)
    return save_figure(fig, path)


def design_with_figure(cfg: DesignConfig, *, overwrite: bool = False) -> DesignResult:
    """run_design, then the figure next to the tables."""
    # the tables and the figure as one set: a kill leaves the old design or the new one
    with publishing(cfg.out_dir, "design", [TABLE_FILE, MARKDOWN_FILE, RESULT_FILE, FIGURE_FILE]):
        res = run_design(cfg, overwrite=overwrite)
        res.files.append(err_figure(res, res.out_dir / FIGURE_FILE))
    return res
