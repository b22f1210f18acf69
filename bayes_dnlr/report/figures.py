"""The report's figures (matplotlib, corner). Arrays in, a PNG file out; every figure is closed.

- ``corner_plot``: posterior pairs with the Gauss-Newton estimate and its linearized 1σ/2σ ellipses
  (eq. 32) and the true values of a synthetic test.
- ``fit_plot``: data, posterior-median model and 90 % bands, residuals below (paper Figs 6-10).
- ``sensitivity_plot``: normalised sensitivities X̃_j = β_j ∂σ/∂β_j (eq. 37) against strain (Fig. 11).
- ``sensitivity_xy_plot``: X̃(E) against X̃(tau_max) (Fig. 12).
- ``trace_plot``: the walkers' draws and marginal densities (names and units on every panel).
- ``rank_plot``: ArviZ's rank plot (Δ-ECDF of fractional ranks and the multi-chain uniformity test),
  computed by report/rank.py.

- ``acf_plot``: autocorrelation of the residuals (white fit, and whitened by the discrepancy).

Each figure is a ``Figure`` of its own, not pyplot's, rendered once (report/canvas.py); neither
ArviZ nor xarray is imported (docs/report.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from bayes_dnlr.report.canvas import new_figure, save_figure
from bayes_dnlr.report.corner_loader import corner_impl
from bayes_dnlr.vocabulary import QUANTITIES

SYMBOLS = {k: q.symbol for k, q in QUANTITIES.items()}
# axis labels: the symbol and its unit (the discrepancy's length is in s or in strain, by its axis)
LABELS = {k: q.symbol if k == "disc_length" else f"{q.symbol} (spectrum exponent)" if q.unit == "-"
          else f"{q.symbol} ({q.unit})" for k, q in QUANTITIES.items()}
C_DATA, C_MODEL, C_GN, C_TRUTH = "0.35", "#c0392b", "#1f5fa8", "#2e8b57"


def pyplot():
    import matplotlib

    if matplotlib.get_backend().lower() != "agg":
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def import_figure_modules() -> None:
    """matplotlib (its Figure, the Agg canvas) and corner, imported ahead of the first figure."""
    new_figure()
    corner_impl()


def ellipse_xy(mean: Sequence[float], cov: np.ndarray, k: float, n: int = 200) -> np.ndarray:
    """Points (n, 2) of the ellipse (x - m)ᵀ C⁻¹ (x - m) = k² of a 2-D Gaussian."""
    w, v = np.linalg.eigh(np.asarray(cov, dtype=float))
    w = np.clip(w, 0.0, None)
    a = np.linspace(0.0, 2.0 * math.pi, n)
    circle = np.stack([np.cos(a), np.sin(a)])
    return (np.asarray(mean, dtype=float)[:, None] + k * (v * np.sqrt(w)) @ circle).T


def _ranges(samples: np.ndarray, est: np.ndarray | None, sd: np.ndarray | None,
            truths: Sequence[float | None] | None,
            bounds: Sequence[tuple[float, float]] | None = None) -> list[tuple[float, float]]:
    """Each axis: the posterior's 99.6 %, the linearized 2.3σ and the truth, the linearized part
    clipped to the prior's support (an ellipse past a bound would squeeze the posterior)."""
    out = []
    for j in range(samples.shape[1]):
        lo, hi = np.quantile(samples[:, j], [0.002, 0.998])
        if est is not None and sd is not None and np.isfinite(sd[j]):
            a, b = est[j] - 2.3 * sd[j], est[j] + 2.3 * sd[j]
            if bounds is not None:
                a, b = max(a, bounds[j][0]), min(b, bounds[j][1])
            lo, hi = min(lo, a), max(hi, b)
        if truths is not None and truths[j] is not None:
            lo, hi = min(lo, truths[j]), max(hi, truths[j])
        pad = 0.05 * (hi - lo) if hi > lo else max(abs(lo) * 1e-3, 1e-12)
        out.append((float(lo - pad), float(hi + pad)))
    return out


def corner_plot(samples: np.ndarray, names: Sequence[str], path: Path,
                gn_estimate: Sequence[float] | None = None, gn_covariance: np.ndarray | None = None,
                truths: Sequence[float | None] | None = None,
                linearized_label: str = "Gauss-Newton",
                bounds: Sequence[tuple[float, float]] | None = None) -> Path:
    """Posterior corner plot; Gauss-Newton estimate (blue cross) with its linearized 1σ and 2σ ellipses
    (Mahalanobis distance 1 and 2 of N(β̂, Δ), eq. 32) and 1-D normal densities; truths in green.
    ``bounds``: each parameter's prior support, which the axes do not pass for the ellipses' sake.

    The posterior contours are drawn at the same two probability levels (39 % and 86 %), so a
    posterior contour on top of its ellipse means the linearization holds.
    """
    draw_corner = corner_impl()
    samples = np.asarray(samples, dtype=float)
    p = samples.shape[1]
    est = None if gn_estimate is None else np.asarray(gn_estimate, dtype=float)
    cov = None if gn_covariance is None else np.asarray(gn_covariance, dtype=float)
    sd = None if cov is None else np.sqrt(np.diag(cov))
    has_truth = truths is not None and any(t is not None for t in truths)
    ranges = _ranges(samples, est, sd, truths if has_truth else None, bounds)
    levels = (1 - math.exp(-0.5), 1 - math.exp(-2.0))
    fig = new_figure(figsize=(2.3 * p + 1.0, 2.3 * p + 1.0))
    draw_corner(samples, fig=fig, labels=[LABELS.get(n, n) for n in names], range=ranges,
                  truths=[t if t is not None else None for t in truths] if has_truth else None,
                  truth_color=C_TRUTH, levels=levels, color="0.2", bins=30, smooth=1.0,
                  plot_datapoints=False, fill_contours=True, hist_kwargs={"density": True},
                  label_kwargs={"fontsize": 11}, max_n_ticks=4)
    axes = np.array(fig.axes).reshape(p, p)
    from matplotlib.ticker import ScalarFormatter

    for ax in axes.ravel():   # no "+1e2" offsets: show the values themselves
        for axis in (ax.xaxis, ax.yaxis):
            f = axis.get_major_formatter()
            if isinstance(f, ScalarFormatter):
                f.set_useOffset(False)
    if est is not None and cov is not None:
        for i in range(p):
            ax = axes[i, i]
            x = np.linspace(*ranges[i], 300)
            if sd[i] > 0:
                ax.plot(x, np.exp(-0.5 * ((x - est[i]) / sd[i]) ** 2) / (sd[i] * math.sqrt(2 * math.pi)),
                        color=C_GN, lw=1.4)
            ax.axvline(est[i], color=C_GN, lw=1.0, ls="--")
            for j in range(i):
                ax = axes[i, j]
                sub = cov[np.ix_([j, i], [j, i])]
                for k, ls in ((1.0, "-"), (2.0, "--")):
                    xy = ellipse_xy(est[[j, i]], sub, k)
                    ax.plot(xy[:, 0], xy[:, 1], color=C_GN, lw=1.3, ls=ls)
                ax.plot(est[j], est[i], marker="x", color=C_GN, ms=7, mew=2)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color="0.2", lw=6, alpha=0.5, label="posterior (39 %, 86 % contours)")]
    if est is not None:
        lab = linearized_label
        handles += [Line2D([], [], color=C_GN, lw=1.3, label=f"{lab}: linearized 1σ"),
                    Line2D([], [], color=C_GN, lw=1.3, ls="--", label=f"{lab}: linearized 2σ"),
                    Line2D([], [], color=C_GN, marker="x", ls="", mew=2, label=f"{lab} estimate")]
    if has_truth:
        handles.append(Line2D([], [], color=C_TRUTH, lw=1.5, label="true value (synthetic test)"))
    fig.legend(handles=handles, loc="upper right", frameon=False, fontsize=10,
               bbox_to_anchor=(0.98, 0.98))
    return save_figure(fig, path)


# candidate places (axes fractions: x0, y0, width, height) for the zoom inset and the legend
INSET_SIZE = (0.35, 0.40)
INSET_SPOTS = ((0.07, 0.53), (0.33, 0.53), (0.60, 0.53), (0.60, 0.07), (0.33, 0.07), (0.60, 0.30))
LEGEND_SPOTS = {"lower right": (0.55, 0.0, 0.45, 0.30), "upper left": (0.0, 0.70, 0.45, 0.30),
                "upper right": (0.55, 0.70, 0.45, 0.30), "lower left": (0.0, 0.0, 0.45, 0.30),
                "center right": (0.55, 0.35, 0.45, 0.30)}


def _axes_fractions(ax, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Points (n, 2) of data coordinates in axes fractions (after autoscaling)."""
    ax.autoscale_view()
    pts = np.column_stack([x, y])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    return (ax.transData + ax.transAxes.inverted()).transform(pts) if pts.size else pts.reshape(0, 2)


def covered(frac: np.ndarray, box: tuple[float, float, float, float], pad: float = 0.02) -> int:
    """How many points (axes fractions) fall inside ``box`` (x0, y0, w, h) grown by ``pad``."""
    x0, y0, w, h = box
    inside = ((frac[:, 0] >= x0 - pad) & (frac[:, 0] <= x0 + w + pad)
              & (frac[:, 1] >= y0 - pad) & (frac[:, 1] <= y0 + h + pad))
    return int(inside.sum())


def _overlap(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return not (a[0] + a[2] <= b[0] or b[0] + b[2] <= a[0] or a[1] + a[3] <= b[1] or b[1] + b[3] <= a[1])


def place_inset(ax, x: np.ndarray, y: np.ndarray) -> tuple[float, float, float, float]:
    """An inset box (axes fractions) over no data: the emptiest candidate spot; when every spot
    holds data, the y-axis is extended upwards so that the top spots are empty."""
    w, h = INSET_SIZE
    frac = _axes_fractions(ax, x, y)
    spots = [(x0, y0, w, h) for x0, y0 in INSET_SPOTS]
    counts = [covered(frac, b) for b in spots]
    best = int(np.argmin(counts))
    if counts[best] > 0:
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi + (hi - lo) * (h + 0.08) / (1.0 - h - 0.08))   # the data below the top spots
        frac = _axes_fractions(ax, x, y)
        counts = [covered(frac, b) for b in spots]
        best = int(np.argmin(counts))
    return spots[best]


def place_legend(ax, x: np.ndarray, y: np.ndarray, avoid: tuple[float, ...] | None = None) -> dict:
    """Keyword arguments of ``ax.legend``: an empty corner not overlapping ``avoid``, else above the
    axes (every corner holds data)."""
    frac = _axes_fractions(ax, x, y)
    for loc, box in LEGEND_SPOTS.items():
        if (avoid is None or not _overlap(box, avoid)) and covered(frac, box, pad=0.0) == 0:
            return {"loc": loc}
    return {"loc": "lower left", "bbox_to_anchor": (0.0, 1.01), "ncol": 2, "borderaxespad": 0.0}


def fit_plot(x: np.ndarray, data: np.ndarray, path: Path, *, window: np.ndarray,
             median: np.ndarray | None = None, band: tuple[np.ndarray, np.ndarray] | None = None,
             predictive: tuple[np.ndarray, np.ndarray] | None = None,
             gn_curve: np.ndarray | None = None, sigma0: float | None = None,
             xlabel: str = r"true strain $\varepsilon_{11}$", inset_xmax: float | None = None,
             inset_title: str | None = None, discrepancy: np.ndarray | None = None) -> Path:
    """Data and model (paper Figs 6-10) with the residuals below.

    median: pointwise posterior median of the model curve; band: its 90 % credible band;
    predictive: the 90 % posterior predictive band (model + noise σ0); gn_curve: the least-squares
    fit, used for the residuals when there is no posterior. Points outside ``window`` are grey.
    ``inset_xmax``: a zoom on x <= inset_xmax, placed where it hides no data (the legend too).
    discrepancy: the posterior mean of the model discrepancy δ on the window (drawn on the residuals).
    """
    x, data = np.asarray(x), np.asarray(data)
    window = np.asarray(window, bool)
    centre = median if median is not None else gn_curve
    fig = new_figure(figsize=(9.0, 7.0))
    ax, axr = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2.2, 1.0], "hspace": 0.06})
    ax.plot(x[window], data[window], ".", color=C_DATA, ms=2.5, label="data (identification window)",
            zorder=3)
    if (~window).any():
        ax.plot(x[~window], data[~window], ".", color="0.75", ms=2.0, label="data (outside window)")
    if predictive is not None:
        ax.fill_between(x, *predictive, color=C_MODEL, alpha=0.15, lw=0, label="90 % posterior predictive")
    if band is not None:
        ax.fill_between(x, *band, color=C_MODEL, alpha=0.45, lw=0, label="90 % credible band of the model")
    if median is not None:
        ax.plot(x, median, color=C_MODEL, lw=1.2, label="posterior median model")
    if gn_curve is not None:
        ax.plot(x, gn_curve, color=C_GN, lw=1.0, ls="--", label="least-squares fit (Gauss-Newton)")
    ax.set_ylabel("true stress (MPa)")
    ax.grid(alpha=0.3)
    # what the inset and the legend must not hide: the data and the model curves
    ys = [data] + [c for c in (centre, *(predictive or ())) if c is not None]
    px, py = np.concatenate([x] * len(ys)), np.concatenate(ys)
    box = None
    sel = x <= inset_xmax if inset_xmax is not None else None
    if sel is not None and centre is not None and int(sel.sum()) >= 3:
        box = place_inset(ax, px, py)
        ins = ax.inset_axes(list(box))
        ins.plot(x[sel & window], data[sel & window], ".", color=C_DATA, ms=2.5)
        if predictive is not None:
            ins.fill_between(x[sel], predictive[0][sel], predictive[1][sel], color=C_MODEL, alpha=0.15, lw=0)
        ins.plot(x[sel], centre[sel], color=C_MODEL if median is not None else C_GN, lw=1.2)
        ins.set_xlim(x[sel].min(), inset_xmax)
        ins.tick_params(labelsize=8)
        ins.grid(alpha=0.3)
        ins.set_title(inset_title or f"zoom: x up to {inset_xmax:g}", fontsize=8)
    ax.legend(**place_legend(ax, px, py, box), fontsize=9, frameon=True, framealpha=0.85,
              edgecolor="none")
    if centre is not None:
        r = data - centre
        axr.plot(x[window], r[window], ".", color=C_DATA, ms=2.0, zorder=3)
        if predictive is not None:
            axr.fill_between(x, predictive[0] - centre, predictive[1] - centre, color=C_MODEL, alpha=0.15,
                             lw=0, label="90 % predictive")
        if band is not None:
            axr.fill_between(x, band[0] - centre, band[1] - centre, color=C_MODEL, alpha=0.45, lw=0)
        if sigma0 is not None:
            for s in (-sigma0, sigma0):
                axr.axhline(s, color=C_GN, lw=0.8, ls=":")
        axr.axhline(0.0, color="k", lw=0.8)
        if discrepancy is not None:
            axr.plot(x[window], discrepancy, color=C_TRUTH, lw=1.0, alpha=0.9, zorder=2,
                     label="posterior mean of δ")
            axr.legend(loc="lower right", fontsize=8, frameon=False)
        lim = np.nanquantile(np.abs(r[window]), 0.995) * 1.3 if window.any() else 1.0
        if np.isfinite(lim) and lim > 0:
            axr.set_ylim(-lim, lim)
    axr.set_ylabel("residual (MPa)")
    axr.set_xlabel(xlabel)
    axr.grid(alpha=0.3)
    if sigma0 is not None:
        axr.text(0.01, 0.95, f"dotted: ±σ0 = ±{sigma0:.3g} MPa", transform=axr.transAxes, fontsize=8,
                 va="top")
    return save_figure(fig, path)


def acf_plot(lags: np.ndarray, series: Mapping[str, np.ndarray], n: int, path: Path,
             xlabel: str = "lag (s)") -> Path:
    """Autocorrelation of residual series against the lag, with the ±1.96/√n band of white noise.

    series: label -> autocorrelation at ``lags`` (the same length)."""
    fig = new_figure(figsize=(9.0, 3.4))
    ax = fig.subplots()
    colors = (C_DATA, C_TRUTH, C_MODEL)
    for (label, acf), c in zip(series.items(), colors, strict=False):
        ax.plot(lags, acf, color=c, lw=1.3, label=label)
    band = 1.96 / math.sqrt(max(n, 1))
    ax.fill_between(lags, -band, band, color=C_GN, alpha=0.15, lw=0, label="white noise, 95 %")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_ylim(-1.05, 1.05)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("autocorrelation")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8, frameon=False)
    return save_figure(fig, path)


def sensitivity_plot(strain: np.ndarray, sens: Mapping[str, np.ndarray], path: Path,
                     window: np.ndarray | None = None,
                     xlabel: str = r"true strain $\varepsilon_{11}$") -> Path:
    """Normalised sensitivities X̃_j = β_j ∂σ/∂β_j in MPa (eq. 37) against strain (Fig. 11)."""
    fig = new_figure(figsize=(9.0, 4.8))
    ax = fig.subplots()
    for name, s in sens.items():
        ax.plot(strain, s, lw=1.4, label=rf"$\tilde X$({SYMBOLS.get(name, name)})")
    if window is not None and not np.all(window):
        w = np.asarray(window, bool)
        ax.axvspan(np.min(strain[w]), np.max(strain[w]), color="0.9", zorder=0, label="identification window")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(r"$\beta_j\,\partial\sigma/\partial\beta_j$ (MPa)")
    ax.legend(fontsize=9, frameon=False)
    ax.grid(alpha=0.3)
    return save_figure(fig, path)


def sensitivity_xy_plot(x_tau: np.ndarray, x_e: np.ndarray, colour: np.ndarray, path: Path, *,
                        colour_label: str = r"strain $\varepsilon_{11}$", zoom: np.ndarray | None = None,
                        zoom_title: str = "", mark: int | None = None, mark_label: str = "",
                        log_colour: bool = False) -> Path:
    """X̃(E) against X̃(tau_max) coloured by ``colour`` (strain or time, ``log_colour``: on a log
    scale; Fig. 12); a straight line
    through the origin would mean E and tau_max cannot be told apart. The sample ``mark`` (an
    index) is circled; a right panel zooms on the samples where ``zoom`` is True (the paper's
    insert: the part of the test where the two sensitivities part), when it holds 3 or more."""
    from matplotlib.colors import LogNorm, Normalize

    x_tau, x_e, colour = (np.asarray(v, dtype=float) for v in (x_tau, x_e, colour))
    positive = colour[colour > 0]
    log_colour = log_colour and positive.size > 0
    if log_colour:                    # a time axis starting at 0: the first sample at the next one
        colour = np.maximum(colour, positive.min())
    n = colour.size
    panels = [(np.ones(n, bool), "whole window" if zoom is not None else "")]
    if zoom is not None and int(np.count_nonzero(zoom)) >= 3:
        panels.append((np.asarray(zoom, bool), zoom_title))
    fig = new_figure(figsize=(5.25 * len(panels), 4.4))
    axes = fig.subplots(1, len(panels), gridspec_kw={"wspace": 0.45}, squeeze=False)
    for k, (ax, (sel, title)) in enumerate(zip(axes[0], panels, strict=True)):
        lo, hi = float(np.min(colour[sel])), float(np.max(colour[sel]))
        norm = (LogNorm if log_colour else Normalize)(lo, hi if hi > lo else lo * 2.0 + 1.0)
        sc = ax.scatter(x_tau[sel], x_e[sel], c=colour[sel], s=4, cmap="viridis", norm=norm)
        fig.colorbar(sc, ax=ax, label=colour_label, shrink=0.9, pad=0.02)
        if mark is not None and 0 <= mark < n and sel[mark]:
            ax.plot(x_tau[mark], x_e[mark], "o", mfc="none", mec=C_MODEL, ms=9, mew=1.5)
            left = x_tau[mark] <= np.median(x_tau[sel])
            low = x_e[mark] <= np.median(x_e[sel])
            ax.annotate(mark_label, (x_tau[mark], x_e[mark]), textcoords="offset points",
                        xytext=(9 if left else -9, 8 if low else -14), color=C_MODEL, fontsize=9,
                        ha="left" if left else "right")
        if k == 0:
            ax.axhline(0, color="k", lw=0.5)
            ax.axvline(0, color="k", lw=0.5)
        ax.set_xlabel(r"$\tilde X(\tau_{max})$ (MPa)")
        ax.set_ylabel(r"$\tilde X(E)$ (MPa)")
        ax.grid(alpha=0.3)
        if title:
            ax.set_title(title, fontsize=10)
    return save_figure(fig, path)


def stairs(ax, values: np.ndarray, edges: np.ndarray, fill: bool = False, **kwargs):
    """``ax.stairs(values, edges, **kwargs)`` down to a baseline at 0 (call ``ax.autoscale_view``
    after the last one). The same StepPatch, added without Axes.stairs' bounding of its path
    segment by segment as Bézier curves (10 ms a patch, a third of the trace plot's building):
    its box is the edges by 0 and the highest value."""
    from matplotlib.patches import StepPatch

    patch = ax.add_artist(StepPatch(values, edges, baseline=0.0, fill=fill, **kwargs))
    patch.sticky_edges.y.append(0.0)
    ax.update_datalim([(edges[0], 0.0), (edges[-1], float(np.max(np.nan_to_num(values), initial=0.0)))])
    return patch


def _pooled(draws: Mapping[str, np.ndarray], max_chains: int | None, max_draws: int,
            thin: int = 1) -> dict[str, np.ndarray]:
    """{name: (chain, draw)} arrays for the rank plot from {name: (walker, draw)} arrays.

    Each walker is thinned by ``thin`` (e.g. its autocorrelation time); with ``max_chains``, walkers
    are then pooled into that many groups (the rank ECDF of a group does not depend on the order of
    its draws); at most ``max_draws`` draws per chain are kept, evenly spaced."""
    out = {}
    for k, v in draws.items():
        v = np.asarray(v, dtype=float)[:, :: max(1, int(thin))]
        if max_chains is not None and v.shape[0] > max_chains:
            groups = np.array_split(np.arange(v.shape[0]), max_chains)
            n = min(len(g) for g in groups) * v.shape[1]
            v = np.stack([v[g].T.reshape(-1)[:n] for g in groups])
        step = max(1, int(math.ceil(v.shape[1] / max_draws)))
        out[k] = v[:, ::step]
    return out


def trace_plot(draws: Mapping[str, np.ndarray], path: Path, max_draws: int = 1000, groups: int = 8,
               step: float = 1.0) -> Path:
    """Trace plot of every walker (right) and the marginal density (left), one row per parameter,
    with names and units on every panel.

    Left: the density of all kept draws (grey) and of the walkers pooled into ``groups`` groups
    (thin lines): groups that disagree mean the chain is not converged. Right: each walker's kept
    draws against the step after burn-in (thinned to at most ``max_draws`` per walker; ``step``:
    steps between stored draws)."""
    from matplotlib import colormaps
    from matplotlib.collections import LineCollection

    names = list(draws)
    fig = new_figure(figsize=(11.0, 2.3 * len(names) + 0.6))
    axes = fig.subplots(len(names), 2, squeeze=False,
                        gridspec_kw={"width_ratios": [1.0, 1.6], "hspace": 0.55, "wspace": 0.22})
    cmap = colormaps["tab10"]
    for row, name in zip(axes, names, strict=True):
        v = np.asarray(draws[name], dtype=float)          # (walker, draw)
        label = LABELS.get(name, name)
        unit = label[label.rfind("(") + 1: label.rfind(")")] if "(" in label else ""
        ad, at = row
        flat = v[np.isfinite(v)]
        lo, hi = (float(np.min(flat)), float(np.max(flat))) if flat.size else (0.0, 1.0)
        if not hi > lo:
            lo, hi = lo - max(abs(lo) * 1e-6, 1e-12), hi + max(abs(hi) * 1e-6, 1e-12)
        parts = np.array_split(np.arange(v.shape[0]), min(groups, v.shape[0]))
        per_group = min(idx.size for idx in parts) * v.shape[1]
        bins = int(np.clip(np.sqrt(per_group), 8, 40))       # a group's histogram is not all noise
        edges = np.linspace(lo, hi, bins + 1)
        h, _ = np.histogram(flat, bins=edges, density=True)     # one filled outline, not a bar each
        stairs(ad, h, edges, fill=True, facecolor="0.8", lw=0, label="all walkers")
        for g, idx in enumerate(parts):
            h, _ = np.histogram(v[idx].ravel(), bins=edges, density=True)
            stairs(ad, h, edges, edgecolor=cmap(g % 10), lw=0.9, alpha=0.9)
        ad.autoscale_view()
        ad.set_xlabel(label)
        ad.set_ylabel(f"density (1/{unit})" if unit else "density")
        ad.grid(alpha=0.3)
        thin = max(1, int(math.ceil(v.shape[1] / max_draws)))
        vt = v[:, ::thin]
        xs = np.arange(vt.shape[1]) * thin * step
        walkers = LineCollection([np.column_stack([xs, vt[w]]) for w in range(vt.shape[0])], lw=0.5,
                                 alpha=0.45, colors=[cmap(w % 10) for w in range(vt.shape[0])])
        at.add_collection(walkers)          # one artist for all walkers: drawn in one pass
        at.autoscale_view()
        at.set_ylabel(label)
        at.set_xlabel("step after burn-in")
        at.grid(alpha=0.3)
    axes[0, 0].set_title(f"marginal density: all walkers (grey), {len(parts)} walker groups (lines)",
                         fontsize=9)
    axes[0, 1].set_title("kept draws of every walker", fontsize=9)
    return save_figure(fig, path)


def rank_plot(draws: Mapping[str, np.ndarray], path: Path, groups: int = 8, max_draws: int = 400,
              thin: int = 1) -> Path:
    """Rank plot (ArviZ's ``plot_rank``, computed by report/rank.py without importing ArviZ): per
    walker group, the ECDF of the fractional ranks minus the uniform one, with ArviZ's multi-chain
    uniformity test (its p-value against α, and the ranks that deviate most marked). Walkers are
    thinned by ``thin`` (pass the autocorrelation time), pooled into ``groups`` groups, and at most
    ``max_draws`` draws per group are kept."""
    from matplotlib import colormaps

    from bayes_dnlr.report import rank

    pooled = _pooled(draws, groups, max_draws, thin)
    names = list(pooled)
    cols = min(4, len(names))
    rows = math.ceil(len(names) / cols)
    fig = new_figure(figsize=(3.6 * cols, 2.9 * rows + 0.3))
    grid = fig.add_gridspec(rows, cols)
    axes = []
    for i in range(len(names)):      # no axes for the empty places of the grid: they cost as much
        ax = fig.add_subplot(grid[i // cols, i % cols], sharex=axes[0] if axes else None)
        if i // cols < rows - 1:     # as subplots(sharex=True): x tick labels on the bottom row only
            ax.tick_params(axis="x", which="both", labelbottom=False)
            ax.xaxis.offsetText.set_visible(False)
        axes.append(ax)
    cmap = colormaps["tab10"]
    alpha = 1.0 - rank.ENVELOPE_PROB
    for ax, name in zip(axes, names, strict=True):
        ranks = rank.fractional_ranks(pooled[name])
        n = ranks.shape[1]
        x, d = rank.delta_ecdf(ranks, n)
        p, b_sh, w_sh = rank.mchain_uniformity_test(ranks)
        marked = rank.suspicious(p, b_sh, w_sh)
        for j in range(d.shape[0]):
            ax.plot(x, d[j], color=cmap(j % 10), lw=1.0)
            if marked[:, j].any():
                ax.plot(x[marked[:, j]], d[j][marked[:, j]], ls="", marker="o", ms=3, color="0.15")
        # ArviZ's y-range: the Dvoretzky-Kiefer-Wolfowitz bound plus padding, or the data
        eps = max(math.sqrt(math.log(2.0 / alpha) / (2.0 * n)) * 1.3, float(np.max(np.abs(d))))
        ax.set_ylim(-eps, eps)
        ax.text(0.0, 0.85 * eps, f"p={p:.2f}(α={alpha:.2f}) ", ha="left", va="center", fontsize=9)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("Fractional ranks")
        ax.grid(alpha=0.3)
    return save_figure(fig, path)
