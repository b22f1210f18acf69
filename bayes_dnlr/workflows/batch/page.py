"""The batch page: ``<out>/batch.html`` (self-contained) and ``<out>/figures/batch_E.png``.

What it shows: how many tests ran, failed or were reused, and how many of them their own checks
trust ("k of N trusted"); E (and E(t)) by material, with the spread between tests beside the
typical uncertainty within one (workflows/batch/groups.py); the figure of E across the tests
(workflows/batch/figure.py); the population of each material (workflows/batch/population_step.py);
the failing tests with their error; the untrusted tests with their verdict; the tests' warnings;
and a table of every test, green or amber, linking to its own report.

``run_campaign`` is what ``python -m bayes_dnlr batch`` calls: the batch runner of the run layer
(``pipeline.batch``) with this layer's per-test report, then this page.
"""

from __future__ import annotations

import base64
import dataclasses
import html
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
from bayes_dnlr.workflows.batch.figure import e_caption, e_figure, with_e
from bayes_dnlr.workflows.batch.groups import (
    by_material,
    labelled,
    modulus_compared,
    modulus_of_rows,
    spread,
    trust_counts,
)
from bayes_dnlr.workflows.batch.manifest import (
    BatchError,
    default_out,
    expand_inputs,
    jobs_from_configs,
    jobs_from_manifest,
)
from bayes_dnlr.workflows.batch.pooling import PopulationStep
from bayes_dnlr.workflows.batch.population_step import groups_of, population_step, section
from bayes_dnlr.workflows.batch.run import BATCH_SET, BatchResult, run_batch, write_table
from bayes_dnlr.workflows.batch.shared_warnings import group
from bayes_dnlr.workflows.population.page import listed

PAGE = "batch.html"
FIGURE = "batch_E.png"


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
        if len(inputs) > 1:
            raise BatchError(f"--manifest takes one template config (or none, with a config column), "
                             f"got {len(inputs)}: {' '.join(inputs)}")
        out = Path(out) if out is not None else default_out([], Path(manifest))
        jobs = jobs_from_manifest(Path(inputs[0]) if inputs else None, Path(manifest), out)
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


# ---------------------------------------------------------------- page

def _img(path: Path, alt: str, caption: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return (f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{caption}</figcaption></figure>")


def _pm(r: dict[str, Any], p: str) -> str:
    m, s = r.get(f"{p}_mean"), r.get(f"{p}_sd")
    return "–" if m is None else pm(m, s)


def _named(r: dict[str, Any], out: Path) -> str:
    """The test's name, a link to its report when it has one (a column of its own, last, was cut off
    at the right of a 1280 px window)."""
    rep = r.get("report")
    if not rep:
        return _e(r["name"])
    rel = os.path.relpath(rep, out)
    return f'<a href="{html.escape(rel)}" title="its report">{_e(r["name"])}</a>'


def _cell(text: str) -> str:
    """A ``value ± sd`` cell that may break before its ± and nowhere else, so that the table of all
    tests fits the window."""
    return text.replace("± ", "±\u00a0")


# The table of all tests is as wide as its columns (a parameter's mean ± sd each): it fits a 1280 px
# window when its cells may break (a name anywhere, a number before its ±) and the page is as wide
# as the window (tests/report/test_browser.py measures it in Chromium).
WIDE_CSS = ("body{max-width:none}table.all td{white-space:normal}table.all th,table.all td{padding:4px 6px}"
            "table.all tbody th{overflow-wrap:anywhere;min-width:6em}")


def _e(text: Any) -> str:
    return html.escape("" if text is None else str(text))


def _trust_mark(r: dict[str, Any]) -> str:
    """A test's trust as a cell: its own checks' decision on E's interval."""
    flag = r.get("trust_interval")
    if flag is None:
        return "<td>–</td>"
    return "<td class='text'>yes</td>" if flag else "<td class='flag'>no ⚑</td>"


def _spread_text(pop: dict[str, float] | None, what: str = "tests") -> str:
    if pop is None:
        return "No test gave a posterior of E."
    if pop["n"] < 2:
        return f"One test: E = {fmt(pop['mean'])} MPa (posterior sd {fmt(pop['within_sd'], 3)} MPa)."
    return (f"E over {pop['n']} {what}: mean of the posterior means {fmt(pop['mean'])} MPa, median "
            f"{fmt(pop['median'])}, range {fmt(pop['min'])}–{fmt(pop['max'])} MPa. Spread between tests "
            f"(sd of the means) {fmt(pop['between_sd'], 3)} MPa against a typical uncertainty within a "
            f"test (median posterior sd) of {fmt(pop['within_sd'], 3)} MPa: ratio "
            f"{fmt(pop['ratio'], 3)}.")


RATIO_WORDS = ("A ratio near 1 means the tests agree within their own uncertainty; well above 1, the "
               "specimens (or the conditions, or the materials) really differ, or the within-test "
               "uncertainty is too small (model error: see docs/model-error.md).")


def _not_one_material(step: PopulationStep | None) -> str:
    """A sentence for the first box when a population's tests do not look like one material."""
    if step is None or step.data is None:
        return ""
    try:
        bad = [(m, g["heterogeneity"]) for m, g in groups_of(step.data)
               if (g.get("heterogeneity") or {}).get("passed") is False]
    except (AttributeError, KeyError, TypeError):      # a population.json the section reports on
        return ""
    return "".join(f" <b>The tests{f' labelled {_e(m)}' if m else ''} do not look like one "
                   f"material</b> (standing out: {_e(', '.join(h.get('stand_out') or []))}; the "
                   "population below)." for m, h in bad)


def _trust_text(t: dict[str, Any]) -> str:
    if not t["n"]:
        return "no verdict (runs of an earlier version)"
    text = f"<b>{t['k']} of {t['n']} trusted</b>"
    if t["untrusted"]:
        text += f" (not: {_e(listed(t['untrusted']))})"
    if t["et_n"]:
        text += f"; E(t): {t['et_k']} of {t['et_n']} trusted"
    return text


def _agreement_cell(c: dict[str, Any] | None) -> str:
    """Whether a material's tests agree on E(t) (the test that decides "one material")."""
    a = (c or {}).get("agreement")
    if a is None:
        return "<td>–</td>"
    if a.agree:
        return f"<td class='text'>agree ({_e(a.figures())})</td>"
    return (f"<td class='flag text'>differ ({_e(a.figures())}; furthest apart: {_e(a.pair_text())})"
            "</td>")


def _pooled_et(c: dict[str, Any]) -> str:
    """A material's E(t) at its common time: pooled ± sd (one test: its value), and the range."""
    a = c.get("agreement")
    value = fmt(c["mean"]) if a is None else pm(a.re_mean, a.re_sd)
    return f"{value} ({fmt(c['min'])}–{fmt(c['max'])}) at t = {fmt(c['t_s'], 3)} s"


def _materials_table(rows: list[dict[str, Any]], with_et: bool) -> str:
    """One row per material: its tests, how many its checks trust, E across them and E(t) at the
    time every one resolves, with whether they agree there; a cell drawn from tests that are not
    all trusted is amber, never plain."""
    body, notes = "", []
    for label, rs in by_material(rows).items():
        t = trust_counts(rs)
        pop = spread(rs)
        c = modulus_compared(rs) if with_et else None
        all_trusted = t["n"] > 0 and t["k"] == t["n"]
        cls = "" if all_trusted else " class='flag'"
        e_cell = ("–" if pop is None else
                  f"{fmt(pop['mean'])} ({fmt(pop['min'])}–{fmt(pop['max'])})")
        ratio = "–" if pop is None or pop["n"] < 2 else fmt(pop["ratio"], 3)
        if c is not None and c["t_s"] is None:
            notes.append(f"{label}: E(t) not compared: {c['why']}.")
        et_cell = "–" if c is None or c["t_s"] is None else _pooled_et(c)
        trusted_et = c is not None and all((e.get("trust") is True) for e in c["entries"].values())
        et_cls = "" if c is None or c["t_s"] is None or trusted_et else " class='flag'"
        body += (f"<tr><th>{_e(label)}</th><td>{t['ok']}</td><td class='text'>{_trust_text(t)}</td>"
                 f"<td{cls}>{e_cell}</td><td>{ratio}</td>"
                 + (f"<td{et_cls}>{et_cell}</td>{_agreement_cell(c)}" if with_et else "") + "</tr>")
    head = ("<tr><th>material</th><th>ok tests</th><th>trusted (own checks)</th><th>E (MPa): mean of "
            "the means (range)</th><th>between / within</th>"
            + ("<th>E(t) (MPa) at the time every test resolves: pooled (range)</th><th>one "
               "material? (their E(t) agree within their uncertainty)</th>" if with_et else "")
            + "</tr>")
    if with_et:
        notes.insert(0, "E(t) pooled: the random-effects mean of the tests' E(t), whose sd holds the "
                        "spread between them beyond their own uncertainty (the population's pooled E(t), "
                        "docs/population.md).")
    note = "".join(f"<p class='note'>{_e(n)}</p>" for n in notes)
    return f"<table class='num'><thead>{head}</thead><tbody>{body}</tbody></table>{note}"


def _warnings_html(warned: list[dict[str, Any]], n_ok: int) -> str:
    """The tests' warnings: one line for each warning that several tests share, word for word but
    for its numbers (the fit's note on G held at 0 for every window that ends at yield, docs/batch.md;
    workflows/batch/shared_warnings.py), then each test's own."""
    if not warned:
        return "<p>None.</p>"
    own = {r["name"]: [w for w in str(r.get("warnings") or "").split(" | ") if w] for r in warned}
    groups = group(own)
    shared = [g for g in groups if len(g.tests) > 1]
    alone = {g.tests[0]: [] for g in groups}
    for g in groups:
        if len(g.tests) == 1:
            alone[g.tests[0]].append(g.text())
    parts = []
    if shared:
        items = "".join(f"<li><b>{len(g.tests)} of {n_ok} tests</b>: {_e(g.text())}</li>" for g in shared)
        parts.append(f"<p>Shared by several tests (each listed once):</p><ul class='flags'>{items}</ul>")
    body = ""
    for r in warned:
        mine = alone.get(r["name"], [])
        if mine or r.get("converged") is False:
            body += (f"<tr><th>{_e(r['name'])}</th><td>{'no' if r.get('converged') is False else 'yes'}"
                     f"</td><td class='text'>{_e(' | '.join(mine))}</td></tr>")
    if body:
        parts.append("<table class='num'><thead><tr><th>test</th><th>converged</th><th>"
                     + ("its other warnings" if shared else "warnings")
                     + f"</th></tr></thead><tbody>{body}</tbody></table>")
    return "".join(parts)


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
    trust = trust_counts(rows)
    grouped = labelled(rows)
    with_et = any(r.get("Et_mean") is not None for r in ok)
    sec = [f"<h1>Batch: {len(rows)} tests</h1>",
           f"<div class='meta'>{_e(out)} · {_e(result.backend)} · {result.elapsed_s:.0f} s this run · "
           f"bayes_dnlr {__version__}</div>"]
    all_trusted = trust["n"] == len(ok) and trust["k"] == trust["n"]
    cls = "ok" if not failed and not pending and all_trusted else "warn"
    sec.append(f"<div class='box {cls}'><b>{len(ok)} ok</b> ({result.reused} reused from an earlier "
               f"run), <b>{len(failed)} failed</b>, {len(pending)} not run, {len(warned)} with "
               f"warnings. E's interval: {_trust_text(trust)} by their own checks"
               + ("" if all_trusted else " (amber rows below: read that test's verdict before using "
                  "its interval)")
               + f".{_not_one_material(step)} The numbers of every test, with its verdict, are in "
               "<code>results.csv</code> and <code>results.parquet</code> beside this page.</div>")
    if grouped:
        sec.append("<h2>E by material</h2>")
        sec.append(_materials_table(rows, with_et))
        sec.append(f"<p class='note'>Between / within: the sd of the posterior means of a material's "
                   f"tests over their median posterior sd. {RATIO_WORDS}</p>")
    else:
        sec.append("<h2>E across the tests</h2>")
        sec.append(f"<p>{_spread_text(spread(rows))} {RATIO_WORDS}</p>")
        if with_et:
            sec.append(_materials_table(rows, with_et))
    if fig is not None:
        sec.append(_img(fig, "E across tests", e_caption(len(with_e(rows)), grouped,
                                                          bool(modulus_of_rows(with_e(rows))))))
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
    sec.append("<h2>Verdicts</h2>")
    untrusted = [r for r in ok if r.get("trust_interval") is False]
    if untrusted:
        body = "".join(f"<tr class='warn'><th>{_e(r['name'])}</th><td class='text'>{_e(r.get('verdict'))}"
                       f"</td><td class='text'>{_e(r.get('checks_fired'))}</td></tr>" for r in untrusted)
        sec.append("<p>The tests whose own checks do not trust E's interval (each test's report says "
                   "why and what to do):</p><table class='num'><thead><tr><th>test</th><th>verdict</th>"
                   f"<th>checks that fired</th></tr></thead><tbody>{body}</tbody></table>")
    else:
        sec.append("<p>Every test's own checks trust its E interval.</p>" if trust["n"] else
                   "<p>No verdicts (runs of an earlier version).</p>")
    sec.append("<h2>Tests with warnings</h2>")
    sec.append(_warnings_html(warned, len(ok)))
    sec.append("<h2>All tests</h2>")
    head = "".join(f"<th>{p} (mean ± sd)</th>" for p in params)
    et_of = modulus_of_rows(rows) if with_et else {}
    times = {e["t"] for e in et_of.values()}
    # the column says the time its values are at: in its head when they share one, else in each cell
    one_time = next(iter(times)) if len(times) == 1 else None
    et_head = ("" if not et_of else f"<th>E(t = {fmt(one_time, 3)} s) (MPa)</th>" if one_time else
               "<th>E(t) (MPa), at t</th>")
    body = ""
    for r in rows:
        vals = "".join(f"<td>{_cell(_pm(r, p))}</td>" for p in params)
        et = ""
        if et_head:
            e = et_of.get(r["name"])
            flag = " class='flag'" if e is not None and e.get("trust") is False else ""
            cell = "–" if e is None else pm(e["mean"], e.get("sd"))
            if e is not None and one_time is None:
                cell += f" at {fmt(e['t'], 3)} s"
            et = f"<td{flag}>{cell}</td>"
        row_cls = " class='warn'" if r.get("trust_interval") is False else ""
        body += (f"<tr{row_cls}><th>{_named(r, out)}</th>"
                 + (f"<td class='text'>{_e(r.get('material'))}</td>" if grouped else "")
                 + f"<td class='text'>{_e(r.get('status'))}</td>{_trust_mark(r)}{vals}{et}"
                 f"<td>{fmt(r.get('r_hat_max'), 4)}</td><td>{fmt(r.get('ess_min'), 3)}</td>"
                 f"<td>{fmt(r.get('iso527_1'))}</td><td>{fmt(r.get('n_warnings'))}</td></tr>")
    sec.append("<table class='num all'><thead><tr><th>test (its report)</th>"
               + ("<th>material</th>" if grouped else "")
               + f"<th>status</th><th>trusted</th>{head}{et_head}<th>max R-hat</th>"
               "<th>min ESS</th><th>ISO 527-1 (MPa)</th><th>warnings</th></tr></thead>"
               f"<tbody>{body}</tbody></table>")
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>batch: {len(rows)} tests</title><style>{CSS}{WIDE_CSS}</style></head><body>"
            + "\n".join(sec) + "<footer>python -m bayes_dnlr batch · docs/batch.md</footer></body></html>")
    path = out / PAGE
    tmp = out / f".{PAGE}.{os.getpid()}.tmp"
    tmp.write_text(page, encoding="utf-8")
    os.replace(tmp, path)
    return path
