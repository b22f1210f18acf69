"""The batch page: ``<out>/batch.html`` (self-contained) and ``<out>/figures/batch_E.png``.

What it shows: how many tests ran, failed or were reused; E across the tests (a histogram of the
posterior means and a forest plot of each test's mean and 90 % HDI); the spread of E between tests
beside the typical uncertainty within a test; the failing tests with their error; the tests with
warnings; and a table of every test linking to its own report.

``run_campaign`` is what ``python -m bayes_dnlr batch`` calls: the batch runner of the run layer
(``pipeline.batch``) with this layer's per-test report, then this page.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import math
import os
import threading
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr import __version__
from bayes_dnlr.diskio import own_dir
from bayes_dnlr.fileset import publishing
from bayes_dnlr.numbers import fmt, pm
from bayes_dnlr.report.page_parts import CSS
from bayes_dnlr.runs.layout import FIGURES_DIR
from bayes_dnlr.vocabulary import PARAMETER_NAMES
from bayes_dnlr.workflows.batch.manifest import (
    BatchError,
    default_out,
    expand_inputs,
    jobs_from_configs,
    jobs_from_manifest,
)
from bayes_dnlr.workflows.batch.pooling import PopulationStep
from bayes_dnlr.workflows.batch.population_step import population_step, section
from bayes_dnlr.workflows.batch.run import BATCH_SET, BatchResult, run_batch, write_table

PAGE = "batch.html"
FIGURE = "batch_E.png"
FOREST_MAX = 80          # tests shown one by one in the forest plot
HISTOGRAM_MIN = 10       # fewer tests get no histogram (three means made bars of height 1 and 0)


def _warm_up_the_end() -> None:
    """While the workers sample, this process only waits: load what the population step and the
    page need (matplotlib, the compiled grid likelihood, the netCDF reader) so that the end of a
    batch does not wait for it (1.3 s after the last result of 8 tests before, 0.6 s when warm)."""
    try:
        from bayes_dnlr.inference.analyses.population import add_log_mean_weight
        from bayes_dnlr.report.figures import pyplot
        from bayes_dnlr.runs import draws  # noqa: F401 - posterior.nc reader

        pyplot()
        add_log_mean_weight(np.zeros(1), np.zeros(1), np.zeros(1), np.ones(1), np.zeros((1, 1)))
    except Exception:  # noqa: BLE001 - a warm-up only: the step itself reports any real problem
        pass


def run_campaign(inputs: list[str], *, manifest: Path | None = None, out: Path | None = None,
                 n_jobs: int = -1, scheduler: str | None = None, report: bool = True,
                 progress: bool = True, population: bool = True, restart: bool = False) -> BatchResult:
    """Configs (paths or globs), or one template config plus a manifest: run the batch, write the
    results table, the population of its tests (unless ``population`` is False) and the batch page.
    ``restart``: a test whose fit or chain was made from another config or data starts again
    (``sample --restart``) instead of failing; current and interrupted tests are kept.
    See docs/batch.md."""
    if manifest is not None:
        if len(inputs) != 1:
            raise BatchError(f"--manifest takes exactly one template config, got {len(inputs)}: "
                             f"{' '.join(inputs)}")
        out = Path(out) if out is not None else default_out([], Path(manifest))
        jobs = jobs_from_manifest(Path(inputs[0]), Path(manifest), out)
    else:
        paths = expand_inputs(inputs)
        if not paths:
            raise BatchError("no config files given")
        out = Path(out) if out is not None else default_out(paths, None)
        jobs = jobs_from_configs(paths)
    if restart:
        jobs = [dataclasses.replace(job, restart=True) for job in jobs]
    if population and scheduler is None:
        threading.Thread(target=_warm_up_the_end, daemon=True).start()
    from bayes_dnlr.report import build_report

    def publish(result: BatchResult, interrupted: bool) -> list[Path]:
        """The table, the population and the page as one set (after Ctrl-C: the table of what
        finished and its page, the population left as it was)."""
        with publishing(result.out, "batch", BATCH_SET):
            written = write_table(result.rows, result.out)
            step = None
            if not interrupted:
                step = population_step(result, enabled=population)
                result.notes.append(step.line())
                written += [f for f in step.files if step.status == "done"]
            written.append(write_page(result, step))
        return written

    return run_batch(jobs, out, n_jobs=n_jobs, scheduler=scheduler,
                     report=build_report if report else None, progress=progress, publish=publish)


# ---------------------------------------------------------------- numbers

def population(rows: list[dict[str, Any]], p: str = "E") -> dict[str, float] | None:
    """E across the tests: mean and sd of the posterior means (between tests), the median posterior
    sd (within a test) and their ratio; None with fewer than one test."""
    pts = [(r[f"{p}_mean"], r[f"{p}_sd"]) for r in rows
           if r.get("status") == "ok" and r.get(f"{p}_mean") is not None]
    if not pts:
        return None
    m = np.array([a for a, _ in pts], float)
    s = np.array([b for _, b in pts], float)
    between = float(m.std(ddof=1)) if m.size > 1 else float("nan")
    within = float(np.median(s))
    return {"n": int(m.size), "mean": float(m.mean()), "between_sd": between, "within_sd": within,
            "ratio": between / within if within > 0 else float("nan"), "min": float(m.min()),
            "max": float(m.max()), "median": float(np.median(m))}


# ---------------------------------------------------------------- figure

def _with_e(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The ok tests with a posterior mean of E: those ``e_figure`` draws."""
    return [r for r in rows if r.get("status") == "ok" and r.get("E_mean") is not None]


def e_figure(rows: list[dict[str, Any]], path: Path) -> Path | None:
    """The PNG of ``e_plot`` at ``path`` (None: no ok test with E)."""
    from bayes_dnlr.report.canvas import save_figure

    ok = _with_e(rows)
    return save_figure(e_plot(ok), path) if ok else None


def e_plot(ok: list[dict[str, Any]]):
    """Histogram of the posterior mean of E (from ``HISTOGRAM_MIN`` tests) and a forest plot (mean,
    90 % HDI) of every test (up to ``FOREST_MAX``): the matplotlib Figure."""
    from bayes_dnlr.report.figures import pyplot

    plt = pyplot()
    forest = len(ok) <= FOREST_MAX
    histogram = len(ok) >= HISTOGRAM_MIN or not forest
    panels = int(histogram) + int(forest)
    fig, axes = plt.subplots(1, panels, figsize=(11 if panels == 2 else 6,
                                                  max(3.6, 0.18 * len(ok)) if forest else 3.6),
                             squeeze=False)
    axes = list(axes[0])
    if histogram:
        ax = axes.pop(0)
        means = np.array([r["E_mean"] for r in ok], float)
        bins = max(5, min(40, int(math.sqrt(len(ok)) * 2)))
        ax.hist(means, bins=bins, color="#1f5fa8", alpha=0.75)
        ax.plot(means, np.zeros_like(means), "|", color="k", ms=12)
        ax.set_xlabel("posterior mean of E (MPa)")
        ax.set_ylabel("tests")
        from matplotlib.ticker import MaxNLocator

        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_title(f"E across {len(ok)} tests")
    if forest:
        ax2 = axes.pop(0)
        order = sorted(ok, key=lambda r: r["E_mean"])
        y = np.arange(len(order))
        lo = np.array([r["E_hdi90_lo"] for r in order], float)
        hi = np.array([r["E_hdi90_hi"] for r in order], float)
        mu = np.array([r["E_mean"] for r in order], float)
        ax2.hlines(y, lo, hi, color="#1f5fa8", lw=2)
        ax2.plot(mu, y, "o", color="#c0392b", ms=4)
        truth = [(i, r["E_true"]) for i, r in enumerate(order) if r.get("E_true") is not None]
        if truth:
            ax2.plot([t for _, t in truth], [i for i, _ in truth], "x", color="#2e8b57", ms=5,
                     label="true E")
            ax2.legend(loc="lower right", fontsize=8)
        ax2.set_yticks(y, [r["name"] for r in order], fontsize=7)
        ax2.set_xlabel("E (MPa): posterior mean and 90 % HDI")
        ax2.set_title("each test" if histogram else f"E of each of {len(ok)} tests")
    fig.tight_layout()
    return fig


def e_caption(n: int) -> str:
    """The caption of ``e_figure`` for ``n`` tests."""
    forest = ("each test's posterior mean (dot) and 90 % HDI (bar), sorted; crosses mark the true E "
              "of synthetic tests.")
    if n < HISTOGRAM_MIN:
        return forest[0].upper() + forest[1:]
    hist = "histogram of the posterior means of E (one tick per test)"
    if n > FOREST_MAX:
        return hist[0].upper() + hist[1:] + "."
    return f"Left: {hist}. Right: {forest}"


# ---------------------------------------------------------------- page

def _img(path: Path, alt: str, caption: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return (f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{caption}</figcaption></figure>")


def _pm(r: dict[str, Any], p: str) -> str:
    m, s = r.get(f"{p}_mean"), r.get(f"{p}_sd")
    return "–" if m is None else pm(m, s)


def _link(r: dict[str, Any], out: Path) -> str:
    rep = r.get("report")
    if not rep:
        return "–"
    rel = os.path.relpath(rep, out)
    return f'<a href="{html.escape(rel)}">report</a>'


def _e(text: Any) -> str:
    return html.escape("" if text is None else str(text))


def _population_text(pop: dict[str, float] | None) -> str:
    if pop is None:
        return "<p>No test gave a posterior of E.</p>"
    if pop["n"] < 2:
        return (f"<p>One test: E = {fmt(pop['mean'])} MPa (posterior sd {fmt(pop['within_sd'], 3)} MPa)."
                "</p>")
    return (f"<p>E over {pop['n']} tests: mean of the posterior means {fmt(pop['mean'])} MPa, median "
            f"{fmt(pop['median'])}, range {fmt(pop['min'])}–{fmt(pop['max'])} MPa. Spread between tests "
            f"(sd of the means) {fmt(pop['between_sd'], 3)} MPa against a typical uncertainty within a "
            f"test (median posterior sd) of {fmt(pop['within_sd'], 3)} MPa: ratio "
            f"{fmt(pop['ratio'], 3)}. A ratio near 1 means the tests agree within their own "
            "uncertainty; well above 1, the specimens (or the conditions) really differ, or the "
            "within-test uncertainty is too small (model error: see docs/model-error.md).</p>")


def write_page(result: BatchResult, step: PopulationStep | None = None) -> Path:
    """Write ``<out>/batch.html`` (figures embedded; the population step's section when given) and
    return its path."""
    out = result.out
    rows = result.rows
    fig = e_figure(rows, own_dir(out / FIGURES_DIR) / FIGURE)
    ok = [r for r in rows if r.get("status") == "ok"]
    failed = [r for r in rows if r.get("status") == "failed"]
    pending = [r for r in rows if r.get("status") == "pending"]
    warned = [r for r in ok if r.get("n_warnings") or r.get("converged") is False]
    params = [p for p in PARAMETER_NAMES if any(r.get(f"{p}_mean") is not None for r in ok)]
    sec = [f"<h1>Batch: {len(rows)} tests</h1>",
           f"<div class='meta'>{_e(out)} · {_e(result.backend)} · {result.elapsed_s:.0f} s this run · "
           f"bayes_dnlr {__version__}</div>"]
    cls = "ok" if not failed and not pending else "warn"
    sec.append(f"<div class='box {cls}'><b>{len(ok)} ok</b> ({result.reused} reused from an earlier "
               f"run), <b>{len(failed)} failed</b>, {len(pending)} not run, {len(warned)} with "
               "warnings. The numbers of every test are in <code>results.csv</code> and "
               "<code>results.parquet</code> beside this page.</div>")
    sec.append("<h2>E across the tests</h2>")
    sec.append(_population_text(population(rows)))
    if fig is not None:
        sec.append(_img(fig, "E across tests", e_caption(len(_with_e(rows)))))
    sec.append(section(step, _img))
    sec.append("<h2>Failing tests</h2>")
    if failed or pending:
        body = "".join(f"<tr><th>{_e(r['name'])}</th><td class='text'>{_e(r.get('origin'))}</td>"
                       f"<td class='text'>{_e(r.get('error'))}</td></tr>" for r in failed + pending)
        sec.append("<table class='num'><thead><tr><th>test</th><th>input</th><th>error</th></tr>"
                   f"</thead><tbody>{body}</tbody></table>")
        sec.append("<p class='note'>Fix the input and run the same batch command again: finished "
                   "tests are skipped, failed and unfinished ones run again.</p>")
    else:
        sec.append("<p>None.</p>")
    sec.append("<h2>Tests with warnings</h2>")
    if warned:
        body = "".join(f"<tr><th>{_e(r['name'])}</th><td>{'no' if r.get('converged') is False else 'yes'}"
                       f"</td><td class='text'>{_e(r.get('warnings'))}</td></tr>" for r in warned)
        sec.append("<table class='num'><thead><tr><th>test</th><th>converged</th><th>warnings</th></tr>"
                   f"</thead><tbody>{body}</tbody></table>")
    else:
        sec.append("<p>None.</p>")
    sec.append("<h2>All tests</h2>")
    head = "".join(f"<th>{p} (mean ± sd)</th>" for p in params)
    body = ""
    for r in rows:
        vals = "".join(f"<td>{_pm(r, p)}</td>" for p in params)
        body += (f"<tr><th>{_e(r['name'])}</th><td class='text'>{_e(r.get('status'))}</td>{vals}"
                 f"<td>{fmt(r.get('r_hat_max'), 4)}</td><td>{fmt(r.get('ess_min'), 3)}</td>"
                 f"<td>{fmt(r.get('iso527_1'))}</td><td>{fmt(r.get('n_warnings'))}</td>"
                 f"<td class='text'>{_link(r, out)}</td></tr>")
    sec.append(f"<table class='num'><thead><tr><th>test</th><th>status</th>{head}<th>max R-hat</th>"
               "<th>min ESS</th><th>ISO 527-1 (MPa)</th><th>warnings</th><th></th></tr></thead>"
               f"<tbody>{body}</tbody></table>")
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>batch: {len(rows)} tests</title><style>{CSS}</style></head><body>"
            + "\n".join(sec) + "<footer>python -m bayes_dnlr batch · docs/batch.md</footer></body></html>")
    path = out / PAGE
    tmp = out / f".{PAGE}.{os.getpid()}.tmp"
    tmp.write_text(page, encoding="utf-8")
    os.replace(tmp, path)
    return path
