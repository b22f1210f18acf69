"""The self-contained report of a run, one test or several: run_dir/report.html (figures embedded as
base64 PNG) and run_dir/figures/.

``build_report(run_dir)`` reads what the run directory holds: with only fit.json it shows the fit part
and says that the posterior is missing; with summary.json and posterior.nc it adds the corner plot,
the posterior predictive band, the posterior/linearized comparison and the sampler diagnostics.

The page is one list of sections. The run's own (parameters, corner plot, correlations, sampler) are
written once; those that compare tests (the paper's Tables 3/5 layout, the rate question) belong to
a run with several; each test's (fit, model error, sensitivities, standards) are drawn for every
test, under the test's name when there are several. A section keeps its number whether or not it
has something to show, so that a section is found at the same place on every page of its kind.
"""

from __future__ import annotations

import datetime as _dt
import html
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from bayes_dnlr import __version__
from bayes_dnlr.diskio import own_dir
from bayes_dnlr.numbers import fmt
from bayes_dnlr.report import per_test_sections as ts
from bayes_dnlr.report import run_sections as rs
from bayes_dnlr.report.across_tests import rate_question, rate_section, tables_3_5
from bayes_dnlr.report.figure_cache import figure_session, keep_long_lived
from bayes_dnlr.report.figures import import_figure_modules
from bayes_dnlr.report.headline import headline as _headline
from bayes_dnlr.report.headline import warnings as _warnings
from bayes_dnlr.report.modulus_section import section as modulus_section
from bayes_dnlr.report.page_parts import CSS, bullets, embed
from bayes_dnlr.runs.curve_cache import report_curves
from bayes_dnlr.runs.curves import model_curves, run_white_curve
from bayes_dnlr.runs.folder import write_atomic
from bayes_dnlr.runs.layout import (
    CHAINS_FILE,
    FIGURES_DIR,
    FIT_FILE,
    POSTERIOR_FILE,
    REPORT_FILE,
    RESOLVED_CONFIG,
    SUMMARY_FILE,
)
from bayes_dnlr.runs.results import RunResults, attach_data, load_run
from bayes_dnlr.vocabulary import base_name

__all__ = ["build_report", "load_run", "model_curves"]


@dataclass
class Page:
    """What the sections draw from: the run, each test's part, the rate question, the figures."""

    run: RunResults
    parts: dict[str, ts.Part]
    rate: object
    figdir: Path
    numbers: dict[str, int]


@dataclass(frozen=True)
class Section:
    """A numbered section: its key, its title, whether it belongs to the run and what it writes."""

    key: str
    title: str
    several_tests: bool                       # compares tests: only in a run with several
    body: Callable[[Page], list[str]]
    titled: bool = True                       # False: the body writes its own heading
    title_of_tests: str = ""                  # the title in a run with several tests, when another


def _per_test(write: Callable[[ts.Part, Path], list[str]]) -> Callable[[Page], list[str]]:
    return lambda page: [h for p in page.parts.values() for h in write(p, page.figdir)]


def _model_error(page: Page) -> list[str]:
    note = ("" if page.run.layout.plain else
            f"These rows are the run's: its joint analyses and its posterior from all "
            f"{len(page.parts)} tests; the noise model, δ and the autocorrelation are this test's.")
    return [h for p in page.parts.values()
            for h in ts.model_error_section(p, page.figdir, note, "Model error: " if p.heading else "")]


def _corner(page: Page) -> list[str]:
    return rs.corner_section(page.run, page.figdir, _h2(page, "corner"))


def _correlations(page: Page) -> list[str]:
    return rs.correlation_section(page.run, page.numbers["correlations"], page.numbers["model_error"])


def _sampler(page: Page) -> list[str]:
    return rs.sampler_section(page.run, page.figdir) if page.run.draws is not None else []


def _rate(page: Page) -> list[str]:
    return rate_section(page.run, page.rate)


SECTIONS = (
    Section("parameters", "Parameters", False,
            lambda page: rs.parameters_section(page.run, page.numbers["model_error"])),
    Section("corner", "Posterior and its linearization", False, _corner, titled=False),
    Section("correlations", "Correlations", False, _correlations, titled=False),
    Section("tables_3_5", "Tables 3 and 5 of the paper, from the run's posterior", True,
            lambda page: [tables_3_5(page.run).html()]),
    Section("rate", "Is E rate-independent?", True, _rate),
    Section("modulus", "E(t): the modulus the data determine", False,
            lambda page: modulus_section(page.run, page.figdir)),
    Section("fit", "Fit and residuals", False, _per_test(ts.fit_section),
            title_of_tests="Fit and residuals of every test"),
    Section("model_error", "Model error: the two analyses and the checks", False, _model_error,
            title_of_tests="Model error of every test: the two analyses and the checks"),
    Section("sensitivities", "Sensitivities (eq. 37)", False, _per_test(ts.sensitivity_section)),
    Section("standards", "Standards, Deborah number and independent measurements", False,
            _per_test(ts.standards_section)),
    Section("sampler", "Sampler diagnostics", False, _sampler),
)


# the order in which the sections are written (the page keeps SECTIONS' order): first those whose
# figures the worker process draws (corner, trace, rank: they need neither the data nor a model
# curve, so it draws them while this process reads the data and pushes the draws through the
# model), then, once the curves are there, the sensitivities, whose Fig. 12 goes to the worker
# before this process draws the fit
FIRST = ("corner", "sampler")
AFTER_CURVES = ("sensitivities",)


def _h2(page: Page, key: str) -> str:
    s = next(s for s in SECTIONS if s.key == key)
    title = s.title_of_tests if s.title_of_tests and not page.run.layout.plain else s.title
    return f"<h2>{page.numbers[key]}. {html.escape(title)}</h2>"


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in name)


def _part(run: RunResults, test: str) -> ts.Part:
    """A test's part of the page: its view, model curves, standards and figure names."""
    from bayes_dnlr.standards import standard_results

    view = run.of_test(test)
    plain = run.layout.plain
    keep_long_lived()            # numba's first call (curves not kept) makes tens of thousands of objects
    curves, disc = report_curves(view, test) if view.test is not None else (None, None)
    part = ts.Part(test, view, curves, standard_results(view.test) if view.test is not None else None,
                   heading="" if plain else ts.rate_heading(test, view),
                   suffix="" if plain else "-" + _slug(test), discrepancy=disc, run=run)
    if curves is not None and curves.gn_curve is not None:
        part.white_curve = run_white_curve(view, curves)
    return part


def _data_file(cfg) -> str:
    """The data file as the header shows it: as the run's config names it (relative to the run
    folder) when it lies in the run folder or beside it, else its absolute path (not a chain of
    '../' up to the file system's root)."""
    name = cfg.data.file
    ups = Path(name).parts.count("..")
    return str(cfg.data_path.resolve()) if ups > 1 and not Path(name).is_absolute() else name


def _data_text(view: RunResults) -> str:
    """A test's data in the page's header: file, observable, window, points, strain rate."""
    cfg = view.cfg
    w = cfg.data.window
    window_txt = ", ".join(f"{k} {v:g}" for k, v in w.model_dump().items() if v is not None) or "whole test"
    own = view.own_fit()
    n_pts = ((own.n_points if own is not None else (view.summary or {}).get("n_points"))
             or (view.test.n_points if view.test is not None else None))
    return (f"<code>{html.escape(_data_file(cfg))}</code> · observable {cfg.data.observable} · "
            f"window: {html.escape(window_txt)} · {fmt(n_pts)} points · strain rate "
            f"{fmt(view.strain_rate(), 3)} 1/s")


def _top(run: RunResults) -> list[str]:
    """The title, the data and model line, and the notices about missing or stale results."""
    cfg, layout = run.cfg, run.layout
    tests = run.tests
    if layout.plain:
        title, data = "identification report", "Data: " + _data_text(run)
    else:
        title = f"joint identification report ({len(tests)} tests)"
        data = "Tests: " + "; ".join(f"{html.escape(t)}: {_data_text(v)}" for t, v in tests.items())
        data += (f" · one value per test: {html.escape(', '.join(layout.per_test))}" if layout.per_test
                 else " · every parameter shared by the tests")
    meta = (f"{data} · model: {cfg.model.modes} modes over {cfg.model.decades:g} decades · free "
            f"parameters: {', '.join(run.model_names)}"
            + (" (and sigma0, sampled)" if any(base_name(n) == "sigma0" for n in run.names) else ""))
    sec = [f"<h1>{html.escape(run.name)}: {title}</h1><div class='meta'>{meta}</div>"]
    if run.stale:
        sec.append('<div class="box stale"><b>Stale results: not those of the current config and '
                   "data.</b>" + bullets(run.stale) + "</div>")
    return sec


def page_html(run: RunResults, figdir: Path, t0: float) -> str:
    """The report's HTML (figures written into ``figdir``)."""
    several = not run.layout.plain
    numbers, n = {}, 0
    for s in SECTIONS:
        if several or not s.several_tests:
            n += 1
            numbers[s.key] = n
    page = Page(run, {}, rate_question(run), figdir, numbers)
    bodies = {s.key: s.body(page) for s in SECTIONS if s.key in FIRST and s.key in numbers}
    attach_data(run)
    page.parts.update({t: _part(run, t) for t in run.cfg.test_names})
    sec = _top(run)
    sec.append(_headline(run, {t: p.standards for t, p in page.parts.items()}, page.rate))
    if not run.has_posterior:
        sec.append('<div class="box warn"><b>No posterior yet.</b> This run has no summary.json/'
                   "posterior.nc: the report shows the least-squares part only. Run "
                   "<code>python -m bayes_dnlr sample "
                   f"{html.escape(str(run.run_dir))}/config.yaml</code>, then this report again.</div>")
    if run.record is None:
        sec.append('<div class="box warn"><b>No fit.json.</b> The least-squares results (estimate, '
                   "linearized covariance, residual diagnostics) are missing: run <code>python -m bayes_dnlr "
                   "fit</code>.</div>")
    warns = _warnings(run)
    if warns:
        sec.append('<div class="box warn"><b>Warnings</b>' + bullets(warns) + "</div>")
    for s in sorted(SECTIONS, key=lambda s: s.key not in AFTER_CURVES):
        if s.key in numbers and s.key not in bodies:
            bodies[s.key] = s.body(page)
    for s in SECTIONS:
        if bodies.get(s.key):
            sec += ([_h2(page, s.key)] if s.titled else []) + bodies[s.key]
    elapsed = time.perf_counter() - t0
    run_dir = run.run_dir
    files = ", ".join(f for f in (RESOLVED_CONFIG, FIT_FILE, SUMMARY_FILE, POSTERIOR_FILE, CHAINS_FILE)
                      if (run_dir / f).exists())
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    sec.append(f"<footer>bayes_dnlr {__version__} · {now} · run directory {html.escape(str(run_dir))} "
               f"({html.escape(files)}) · built in {elapsed:.1f} s · Blaise et al., eq. and figure numbers "
               "refer to the paper.</footer>")
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(run.name)} report</title><style>{CSS}</style></head><body>"
            + "\n".join(sec) + "</body></html>")


def build_report(run_dir: Path | str, source: Path | str | None = None,
                 on_stale: Callable[[str], None] | None = None, aside: bool = True) -> Path:
    """Write run_dir/report.html and run_dir/figures/*.png; return the path of report.html.
    ``source``: the user's config file, when known (the results are checked against it);
    ``on_stale``: called with each result made from another config or data (also on the page);
    ``aside``: figures may be drawn by a worker process (when a core is free)."""
    t0 = time.perf_counter()
    run_dir = Path(run_dir)
    # matplotlib and corner imported once, before the figure worker is forked: the worker starts
    # drawing at once, and neither process imports them again
    if aside:
        import_figure_modules()
    # The run is read before the figure worker is forked: with the worker's threads running, a
    # read of chains.h5 or posterior.nc can no longer be made in a child with a deadline
    # (readback.within_deadline), and a damaged file read here could hang the report.
    run = load_run(run_dir, source=source, load_data=False)     # the data: page_html
    # a figure drawn from the same inputs as before is kept
    with figure_session(aside=aside) as used:
        for note in run.stale if on_stale is not None else []:
            on_stale(note)
        figdir = own_dir(run_dir / FIGURES_DIR)
        page = page_html(run, figdir, t0)
    page = embed(page)
    for old in figdir.glob("*.png"):     # figures of an earlier report that do not apply any more
        if old not in used:
            old.unlink()
    out = run_dir / REPORT_FILE
    write_atomic(out, page)
    return out

