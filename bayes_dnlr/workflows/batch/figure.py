"""The batch page's figure of E across the tests (``<out>/figures/batch_E.png``): a histogram of the
posterior means (from HISTOGRAM_MIN tests) and a forest plot of each test's mean and 90 % HDI (up to
FOREST_MAX tests), grouped by material and sorted by E within each; a test whose own checks do not
trust E's interval is drawn in amber and its label flagged."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.numbers import fmt
from bayes_dnlr.workflows.batch.groups import by_material, labelled, modulus_of_rows

FOREST_MAX = 80          # tests shown one by one in the forest plot
HISTOGRAM_MIN = 10       # fewer tests get no histogram (three means made bars of height 1 and 0)
TRUSTED, UNTRUSTED = "#1f5fa8", "#d08a00"
GROUP_COLOURS = ("#1f5fa8", "#8e44ad", "#2a9d4b", "#c0392b", "#7f8c8d", "#16a085")


def with_e(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The ok tests with a posterior mean of E: those ``e_figure`` draws."""
    return [r for r in rows if r.get("status") == "ok" and r.get("E_mean") is not None]


def e_figure(rows: list[dict[str, Any]], path: Path) -> Path | None:
    """The PNG of ``e_plot`` at ``path`` (None: no ok test with E)."""
    from bayes_dnlr.report.canvas import save_figure

    ok = with_e(rows)
    return save_figure(e_plot(ok, modulus_of_rows(ok)), path) if ok else None


def _histogram(ax, ok: list[dict[str, Any]]) -> None:
    from matplotlib.ticker import MaxNLocator

    groups = by_material(ok)
    means = np.array([r["E_mean"] for r in ok], float)
    bins = np.histogram_bin_edges(means, bins=max(5, min(40, int(math.sqrt(len(ok)) * 2))))
    several = labelled(ok) and len(groups) > 1
    for i, (label, rs) in enumerate(groups.items()):
        ax.hist([r["E_mean"] for r in rs], bins=bins, color=GROUP_COLOURS[i % len(GROUP_COLOURS)],
                alpha=0.6, label=label if several else None)
    ax.plot(means, np.zeros_like(means), "|", color="k", ms=12)
    if several:
        ax.legend(fontsize=8)
    ax.set_xlabel("posterior mean of E (MPa)")
    ax.set_ylabel("tests")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_title(f"E across {len(ok)} tests")


def _ordered(ok: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], list[tuple[int, str]]]:
    """The rows by material, sorted by E within each, and where each material starts."""
    order: list[dict[str, Any]] = []
    starts: list[tuple[int, str]] = []
    for label, rs in by_material(ok).items():
        starts.append((len(order), label))
        order += sorted(rs, key=lambda r: r["E_mean"])
    return order, starts


def _forest(ax, order: list[dict[str, Any]], starts: list[tuple[int, str]],
            points: list[tuple[float, float, float] | None], bad: np.ndarray, several: bool,
            title: str, xlabel: str, names: bool = True) -> None:
    """Each row's value and 90 % interval ``points`` (mean, lo, hi; None: none), top to bottom in
    reading order (the first material's lowest E at the top); ``bad``: drawn in amber; ``several``:
    a line between materials; ``names``: the tests' and the materials' names."""
    y = np.arange(len(order))[::-1].astype(float)
    have = np.array([p is not None for p in points])
    mu, lo, hi = (np.array([p[i] if p is not None else np.nan for p in points], float) for i in range(3))
    for flag, colour, name in ((False, TRUSTED, "trusted by its own checks"),
                               (True, UNTRUSTED, "not trusted by its own checks")):
        idx = np.flatnonzero((bad == flag) & have)
        if idx.size:
            ax.hlines(y[idx], lo[idx], hi[idx], color=colour, lw=2)
            ax.plot(mu[idx], y[idx], "o", color="#c0392b" if not flag else colour, ms=4,
                    label=name if bad[have].any() else None)
    if names:
        ax.set_yticks(y, [f"{r['name']} ⚑" if b else r["name"] for r, b in zip(order, bad, strict=True)],
                      fontsize=7)
    else:
        ax.set_yticks(y, [""] * len(order))
    if several:
        for start, label in starts:
            if start:
                ax.axhline(y[start] + 0.5, color="#999", lw=0.8)
            if not names:
                continue
            ax.annotate(label, (1.0, y[start]), xycoords=("axes fraction", "data"), xytext=(-4, 0),
                        textcoords="offset points", ha="right", va="center", fontsize=8,
                        fontweight="bold", color="#333")
    ax.set_ylim(-0.7, len(order) - 0.3)
    ax.set_xlabel(xlabel)
    ax.set_title(title)


def _e_forest(ax, ok: list[dict[str, Any]], title: str) -> None:
    order, starts = _ordered(ok)
    bad = np.array([r.get("trust_interval") is False for r in order])
    _forest(ax, order, starts, [(r["E_mean"], r["E_hdi90_lo"], r["E_hdi90_hi"]) for r in order], bad,
            labelled(ok), title, "E (MPa): posterior mean and 90 % HDI")
    truth = [(i, r["E_true"]) for i, r in enumerate(order) if r.get("E_true") is not None]
    if truth:
        y = np.arange(len(order))[::-1]
        ax.plot([t for _, t in truth], [y[i] for i, _ in truth], "x", color="#2e8b57", ms=5,
                label="true E")
    if truth or bad.any():
        ax.legend(loc="best", fontsize=7)


def _et_forest(ax, ok: list[dict[str, Any]], et: dict[str, dict[str, Any]]) -> None:
    """E(t) of each test in the E panel's order, at its material's common time (E(t) panel)."""
    order, starts = _ordered(ok)
    points = []
    for r in order:
        e = et.get(r["name"])
        hdi = (e or {}).get("hdi_90") or [None, None]
        points.append(None if e is None or None in hdi else (e["mean"], hdi[0], hdi[1]))
    bad = np.array([(et.get(r["name"]) or {}).get("trust") is False for r in order])
    times = sorted({e["t"] for e in et.values() if e.get("t") is not None})
    at = f"t = {fmt(times[0], 3)} s" if len(times) == 1 else "each material's common time"
    _forest(ax, order, starts, points, bad, labelled(ok), f"E(t) of each test ({at})",
            "E(t) (MPa): posterior mean and 90 % HDI; amber: E(t) not trusted", names=False)


def e_plot(ok: list[dict[str, Any]], et: dict[str, dict[str, Any]] | None = None):
    """Histogram of the posterior mean of E (from ``HISTOGRAM_MIN`` tests) and a forest plot (mean,
    90 % HDI) of every test (up to ``FOREST_MAX``), by material, with E(t) of each test beside it
    (``et``: name -> its E(t) entry, groups.modulus_of_rows): the matplotlib Figure."""
    from bayes_dnlr.report.figures import pyplot

    plt = pyplot()
    forest = len(ok) <= FOREST_MAX
    with_et = forest and bool(et)
    histogram = len(ok) >= HISTOGRAM_MIN or not forest
    panels = int(histogram) + int(forest) + int(with_et)
    fig, axes = plt.subplots(1, panels, figsize=({1: 6, 2: 11}.get(panels, 15),
                                                  max(3.6, 0.18 * len(ok) + 1.0) if forest else 3.6),
                             squeeze=False)
    axes = list(axes[0])
    if histogram:
        _histogram(axes.pop(0), ok)
    if forest:
        _e_forest(axes.pop(0), ok, "each test" if histogram else f"E of each of {len(ok)} tests")
    if with_et:
        _et_forest(axes.pop(0), ok, et)
    fig.tight_layout()
    return fig


def e_caption(n: int, grouped: bool = False, with_et: bool = False) -> str:
    """The caption of ``e_figure`` for ``n`` tests (``grouped``: labelled with materials;
    ``with_et``: the E(t) panel is drawn)."""
    forest = ("each test's posterior mean (dot) and 90 % HDI (bar), "
              + ("grouped by material and sorted by E within each" if grouped else "sorted")
              + "; amber and ⚑: its own checks do not trust E's interval; crosses mark the true E "
              "of synthetic tests.")
    et = (" Beside it, in the same rows: each test's E(t) at the time every test of its material "
          "resolves (the quantity that decides whether they look like one material; amber: its E(t) "
          "not trusted by its own checks)." if with_et and n <= FOREST_MAX else "")
    if n < HISTOGRAM_MIN:
        return forest[0].upper() + forest[1:] + et
    hist = "histogram of the posterior means of E (one tick per test)"
    if n > FOREST_MAX:
        return hist[0].upper() + hist[1:] + "."
    return f"Left: {hist}. Then {forest}{et}"
