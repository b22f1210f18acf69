"""The report's sections of one test, written once and drawn for every test of a run: fit and
residuals, model error, sensitivities, standards and cross-checks.

Each section gets the test seen as a run with one test (``RunResults.of_test``: the run's draws,
posterior and analyses under the test's own names, its data and noise) and the test's ``Part``:
its model curves (``runs.curves``), its standard moduli and where its figures go.
"""

from __future__ import annotations

import html
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.numbers import fmt
from bayes_dnlr.report import figures as figs
from bayes_dnlr.report import model_error as rn
from bayes_dnlr.report import tables as tb
from bayes_dnlr.report import views
from bayes_dnlr.report.figure_cache import drawn
from bayes_dnlr.report.page_parts import bullets, img, para
from bayes_dnlr.report.table4 import plot_points, references_of, table4, table4_plot
from bayes_dnlr.runs.curves import N_DRAWS, Curves, Discrepancy
from bayes_dnlr.runs.results import RunResults


@dataclass
class Part:
    """One test on the page: its view, curves, standard moduli and figure names."""

    name: str
    view: RunResults
    curves: Curves | None
    standards: dict[str, Any] | None     # standards.standard_results of the test's data
    heading: str                         # "" for a run with one test (its sections are the run's)
    suffix: str                          # figure names: fit{suffix}.png
    white_curve: np.ndarray | None = None
    discrepancy: Discrepancy | None = None
    run: RunResults | None = None        # the whole run (its references are the run's)

    def figure(self, figdir: Path, base: str) -> Path:
        return figdir / f"{base}{self.suffix}.png"


def _head(part: Part, topic: str = "") -> list[str]:
    return [f"<h3>{html.escape(topic + part.heading)}</h3>"] if part.heading else []


def fit_section(part: Part, figdir: Path) -> list[str]:
    """Data, model, bands and residuals (paper Figs 6-10), and the residual diagnostics."""
    run, curves = part.view, part.curves
    sec = _head(part)
    if curves is not None:
        inset = views.fit_inset(curves.x, run.test.relaxation_start)
        disc = part.discrepancy
        p = drawn(figs.fit_plot, curves.x, curves.data, part.figure(figdir, "fit"), window=curves.window,
                  median=curves.median, band=curves.band, predictive=curves.predictive,
                  gn_curve=curves.gn_curve, sigma0=run.sigma0(), xlabel=curves.xlabel,
                  inset_xmax=inset.xmax if inset else None, inset_title=inset.title if inset else None,
                  discrepancy=None if disc is None else disc.mean)
        n_used = min(N_DRAWS, next(iter(run.draws.values())).size) if run.draws else 0
        noise_txt = "model + discrepancy δ + noise σ0" if run.uses_discrepancy else "model + noise σ0"
        what = (f"the posterior median of the model over {n_used} posterior draws, its 90 % credible band "
                f"(dark) and the 90 % posterior predictive band ({noise_txt}, light)"
                if curves.median is not None else "the least-squares fit")
        if disc is not None:
            what += "; green on the residuals: the posterior mean of the model discrepancy δ"
        sec.append(img(p, f"fit and residuals{part.suffix.replace('-', ' ')}", (
            f"Data (grey dots) and {what}; the dashed blue line is the least-squares fit"
            + (f"; {inset.caption}" if inset else "") + ". Residuals "
            "(data - model) below, with ±σ0 dotted: without model bias they scatter evenly around zero "
            "(paper Figs 6-10).")))
    else:
        sec.append(para("No fit figure: the test data could not be loaded."))
    own = run.own_fit()
    fit_sigma0 = own.sigma0 if own is not None else run.sigma0()    # the white analysis' own σ0
    sec.append("<h3>Residual diagnostics of the white fit (fit.json)</h3>"
               + bullets(tb.residual_words(own, fit_sigma0)))
    return sec


def model_error_section(part: Part, figdir: Path, note: str = "", topic: str = "") -> list[str]:
    """The two analyses of E and the checks: the verdict, the intervals (``note`` under them), δ's
    hyperparameters, the ACF."""
    white_resid = None
    curves = part.curves
    if curves is not None and curves.gn_curve is not None:
        white_resid = (curves.data - part.white_curve)[curves.window]
    return _head(part, topic) + rn.noise_section(part.view, part.figure(figdir, "acf"), part.discrepancy,
                                                 white_resid, note)


def sensitivity_section(part: Part, figdir: Path) -> list[str]:
    """The normalised sensitivities (eq. 37, paper Fig. 11) and X̃(E) against X̃(τ_max) (Fig. 12)."""
    run, curves = part.view, part.curves
    if curves is None or not curves.sensitivities:
        return []
    # Fig. 12 first: the worker process draws it while this one draws Fig. 11
    view = views.xy_view(curves.sensitivities, curves.strain, run.test.time, run.test.relaxation_start)
    xy = None if view is None else drawn(
        figs.sensitivity_xy_plot, view.x_tau, view.x_e, view.colour, part.figure(figdir, "sensitivity_xy"),
        colour_label=view.colour_label, zoom=view.zoom, zoom_title=view.zoom_title, mark=view.mark,
        mark_label=view.mark_label, log_colour=view.log_colour, aside=True)
    sec = _head(part)
    p = drawn(figs.sensitivity_plot, curves.x, curves.sensitivities, part.figure(figdir, "sensitivity"),
              window=curves.window, xlabel=curves.xlabel)
    sec.append(img(p, "sensitivities", (
        "Normalised sensitivities X̃<sub>j</sub> = β<sub>j</sub> ∂σ/∂β<sub>j</sub> (eq. 37, MPa) at the "
        "least-squares estimate (paper Fig. 11). Parameters are identifiable where their curves differ "
        "in shape; proportional curves mean correlated parameters.")))
    if xy is not None:
        sec.append(img(xy, "X(E) against X(tau_max)", view.caption))
    return sec


def standards_section(part: Part, figdir: Path) -> list[str]:
    """ISO 527-1 and ASTM D638 against E (Tables 1, 4), De_max (eq. 45), and Table 4: the
    independent moduli (``reference_moduli``) beside the model's prediction at their time scales."""
    run = part.view
    sec = _head(part)
    sec.append(tb.standards_table(run, part.standards).html())
    sec.append(tb.deborah_table(run).html())
    whole = part.run or run
    t4 = table4(whole, part.name, run, part.standards)
    if t4 is not None:
        sec.append(f'<div id="table4{part.suffix}">')
        sec.append(t4.html())
        refs, _ = references_of(whole)
        curve = (whole.summary or {}).get("reference_curve")
        if curve:
            p = drawn(table4_plot, curve, plot_points(refs), part.figure(figdir, "table4"))
            sec.append(img(p, "Table 4 as a figure", (
                "The model's storage modulus E'(ω) (red) and loss modulus E''(ω) (blue) of the same "
                "modes as E(t), posterior median and 90 % band, E with its 90 % HDI (grey), and the "
                "references at their frequencies (an E(t) at f = 1/(2πt); open markers: E''). Right of "
                "the dotted line every mode is frozen: E'(ω) is E.")))
        sec.append("</div>")
    return sec


def rate_heading(name: str, view: RunResults) -> str:
    """A test's heading in a run with several: its name and strain rate."""
    return f"{name} ({fmt(view.strain_rate(), 3)} 1/s)"
