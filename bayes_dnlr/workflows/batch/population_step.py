"""The population step of a batch and its section of the batch page.

``population_step`` runs the ``population`` command's code (workflows/population/page.py: population.json,
.md and .png) over the batch's usable tests (workflows/batch/pooling.py) into the batch folder; a
re-run with the same runs and posteriors (and package version) reuses population.json (the
command's currency check).
It never raises: a failure is a note on the page. ``section`` is the page's HTML for it.
"""

from __future__ import annotations

import html
import time
from pathlib import Path
from typing import Any

from bayes_dnlr import __version__
from bayes_dnlr.numbers import fmt, interval, pm
from bayes_dnlr.workflows.batch.pooling import (
    MIN_TESTS,
    PARAMETER,
    PopulationStep,
    group_sizes,
    select,
)
from bayes_dnlr.workflows.batch.run import BatchResult
from bayes_dnlr.workflows.population.page import (
    FIGURE,
    MARKDOWN,
    modulus_line,
    pooled_label,
    population_report,
    trust_words,
)
from bayes_dnlr.workflows.population.run import (
    NOT_ONE,
    POPULATION_FILE,
    UNLABELLED,
    current_population,
    read_existing,
)

MADE_BY = "batch"


def _earlier(out: Path) -> str:
    """A sentence about a population.json left in ``out`` by an earlier run, or ''."""
    old = read_existing(out / POPULATION_FILE)
    if not old:
        return ""
    names = old.get("specimens") or []
    return (f" The {POPULATION_FILE} in this folder is from an earlier run ({len(names)} tests: "
            f"{', '.join(map(str, names))}) and was not updated: it does not describe this batch.")


def population_step(result: BatchResult, enabled: bool = True) -> PopulationStep:
    """Pool the batch's usable tests (≥ MIN_TESTS) into ``<out>/population.json`` (.md, .png)."""
    out = result.out
    t0 = time.perf_counter()
    try:
        used, excluded = select(result.rows)
    except Exception as err:  # noqa: BLE001 - the batch must not fail because of its population
        return PopulationStep("failed", f"the tests could not be read ({type(err).__name__}: {err})."
                              + _earlier(out))
    step = PopulationStep("skipped", "", used, excluded)
    if not enabled:
        step.status, step.note = "off", "turned off with --no-population." + _earlier(out)
        return step
    sizes = group_sizes(result.rows, used)
    if max(sizes.values(), default=0) < MIN_TESTS:
        per = ("" if len(sizes) < 2 else " of one material ("
               + ", ".join(f"{k}: {v}" for k, v in sizes.items()) + ")")
        step.note = (f"{len(used)} usable test{'s' if len(used) != 1 else ''} (ok, one "
                     f"specimen each, {PARAMETER} sampled); the population needs at least "
                     f"{MIN_TESTS}{per}." + _earlier(out))
        return step
    files = [out / POPULATION_FILE, out / MARKDOWN, out / FIGURE]
    dirs = list(used.values())
    try:
        done = current_population(dirs, parameter=PARAMETER, out=out)
        if (done is not None and done.get("version") == __version__
                and all(f.is_file() for f in files)):
            step.status, step.data, step.files = "reused", done, files
            step.note = (f"{len(used)} tests, made earlier from these very runs and posteriors "
                         f"({POPULATION_FILE} is current).")
            return step
        old = read_existing(out / POPULATION_FILE)
        if old and old.get("made_by") != MADE_BY and done is None:
            step.status = "failed"
            step.note = (f"{out / POPULATION_FILE} was made by the population command from other runs "
                         "and is left as it is; move it away, or give the batch another --out.")
            return step
        pr = population_report(dirs, parameter=PARAMETER, out=out, force=True, made_by=MADE_BY,
                               min_group=MIN_TESTS)
    except Exception as err:  # noqa: BLE001 - the batch must not fail because of its population
        step.status = "failed"
        step.note = f"{type(err).__name__}: {err}." + _earlier(out)
        return step
    step.status, step.data, step.files = "done", pr.to_dict(), pr.written
    step.note = f"{len(used)} tests pooled in {time.perf_counter() - t0:.1f} s."
    if old and (done is None or done.get("version") != __version__):
        before = [str(n) for n in old.get("specimens") or []]
        what = (f"by bayes_dnlr {old.get('version')}" if done is not None else
                "from other posteriors of these tests" if before == list(used) else
                f"from {len(before)} tests: {', '.join(before)}")
        step.note += f" It replaces the batch's earlier {POPULATION_FILE}, made {what}."
    step.wall_time_s = time.perf_counter() - t0
    return step


# ---------------------------------------------------------------- the page's section

def _e(text: Any) -> str:
    return html.escape("" if text is None else str(text))


def _hdi(v: list[float] | None, sd: float | None) -> str:
    """An interval at the decimals of the sd of the value it is about."""
    return "–" if not v else interval(v[0], v[1], sd)


def _g(x: Any, spec: str) -> str:
    return "–" if x is None else format(float(x), spec)


def _excluded_html(step: PopulationStep) -> str:
    if not step.excluded:
        return ""
    items = "".join(f"<li><b>{_e(k)}</b>: {_e(v)}</li>" for k, v in step.excluded.items())
    return f"<p>Left out of the population ({len(step.excluded)}):</p><ul>{items}</ul>"


def section(step: PopulationStep | None, img) -> str:
    """The batch page's "Population" section; ``img(path, alt, caption)`` embeds a figure. A
    population.json it cannot read becomes a note: the page is always written."""
    if step is None:
        return ""
    try:
        return _section(step, img)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError, OSError) as err:
        note = PopulationStep("failed", f"{POPULATION_FILE} could not be shown ({type(err).__name__}: "
                              f"{err}); run the batch again with it moved away", excluded=step.excluded)
        return _section(note, img)


def groups_of(data: dict[str, Any]) -> list[tuple[str | None, dict[str, Any]]]:
    """population.json's populations as (material, its entry): one per material with several
    materials (``groups``), else the file itself."""
    if isinstance(data.get("groups"), dict):
        return [(label, g) for label, g in data["groups"].items()]
    return [(data.get("material"), data)]


def _trusted_line(g: dict[str, Any]) -> str:
    return _e(trust_words(g.get("trusted") or {}, str(g.get("parameter", PARAMETER))))


def _group_box(material: str | None, g: dict[str, Any], step: PopulationStep | None) -> str:
    """One population: green only when its Monte Carlo check and its heterogeneity check passed and
    every specimen's own checks trust its E; its name says whether it is a material's E."""
    mu, s = g["mu"], g["s"]
    mc = g.get("monte_carlo_check") or {}
    het = g.get("heterogeneity") or {}
    trusted = g.get("trusted") or {}
    one = het.get("passed") is not False
    all_trusted = bool(trusted.get("n")) and trusted.get("k") == trusted.get("n")
    green = bool(mc.get("passed")) and one and all_trusted
    label = _e(pooled_label(g["parameter"], material, one, len(g["specimens"]), het.get("quantity")))
    status = f" ({_e(step.status)}: {_e(step.note.rstrip('.'))})" if step is not None else ""
    et = modulus_line(g.get("modulus_at"), material, len(g["specimens"]))
    return (f"<div class='box {'ok' if green else 'warn'}'><b>{label}: μ = {pm(mu['mean'], mu['sd'])} "
            f"MPa</b> (90 % HDI {_hdi(mu.get('hdi_90'), mu['sd'])}); specimen-to-specimen sd <b>s = "
            f"{pm(s['mean'], s['sd'])} MPa</b> (90 % HDI {_hdi(s.get('hdi_90'), s['sd'])}); from "
            f"{len(g['specimens'])} tests{status}."
            + (f"<br><b>{_e(et)}</b>." if et else "") + f"<br>{_trusted_line(g)}"
            + ("" if green or not (mc.get("passed") and one) else
               " A number drawn from tests whose own checks do not trust E's interval is not green.")
            + "</div>")


def _group_html(material: str | None, g: dict[str, Any], data: dict[str, Any],
                step: PopulationStep | None) -> list[str]:
    mc = g.get("monte_carlo_check") or {}
    ess = mc.get("effective_draws") or {}
    lim = mc.get("limits") or {}
    passed = bool(mc.get("passed"))
    fewest = min(ess.values()) if ess else None
    het = g.get("heterogeneity") or {}
    parts = [_group_box(material, g, step)]
    if het.get("words") and het.get("passed") is False:
        parts.append(f"<div class='box warn'><b>Not one material</b>: {_e(het['words'])}</div>")
    elif het.get("words"):
        parts.append(f"<p>Heterogeneity: {_e(het['words'])}</p>")
    parts.append(f"<p>Monte Carlo check <b>{'passed' if passed else 'FAILED'}</b>: the fewest effective "
                 f"draws of a test at the posterior mean of (μ, s) is {_g(fewest, '.0f')} (at least "
                 f"{_g(lim.get('effective_draws_min'), '.0f')} wanted); the Monte Carlo variance of ln L "
                 f"there is {_g(mc.get('log_likelihood_variance'), '.2g')} (at most "
                 f"{_g(lim.get('log_likelihood_variance_max'), 'g')}).</p>")
    shown = [w for w in g.get("warnings") or [] if not w.startswith(NOT_ONE)]   # in its own box
    if shown:
        parts.append("<div class='box warn'>" + "<br>".join(_e(w) for w in shown) + "</div>")
    truth = data.get("truth") or {}
    members = data.get("members") or {}
    with_et = any((members.get(k) or {}).get("Et") for k in g["specimens"])
    rows = ""
    for k in g["specimens"]:
        sh = g["shrunk"][k]
        own, shr = sh["own"], sh["shrunk"]
        m = members.get(k) or {}
        flag = m.get("trust_interval")
        mark = {True: "<td class='text'>yes</td>",
                False: "<td class='flag'>no ⚑</td>"}.get(flag, "<td>–</td>")
        et = ""
        if with_et:
            e = m.get("Et") or {}
            et = ("<td>–</td>" if e.get("mean") is None else
                  f"<td{' class=flag' if e.get('trust') is False else ''}>{pm(e['mean'], e.get('sd'))}</td>")
        rows += (f"<tr{' class=warn' if flag is False else ''}><th>{_e(k)}</th>{mark}"
                 f"<td>{pm(own['mean'], own['sd'])}</td><td>{pm(shr['mean'], shr['sd'])}</td>"
                 f"<td>{_hdi(shr.get('interval_90'), shr['sd'])}</td>{et}"
                 f"<td>{_g(ess.get(k), '.0f')}</td>"
                 + (f"<td>{fmt(truth.get(k))}</td>" if truth else "") + "</tr>")
    p = _e(g["parameter"])
    t_s = next(((members.get(k) or {}).get("Et") or {}).get("t_s") for k in g["specimens"]
               if (members.get(k) or {}).get("Et")) if with_et else None
    parts.append(f"<table class='num'><thead><tr><th>test</th><th>trusted (own checks)</th><th>own {p} "
                 f"(MPa)</th><th>shrunken {p} (MPa)</th><th>shrunken 90 %</th>"
                 + (f"<th>E(t = {fmt(t_s, 3)} s) (MPa)</th>" if with_et else "")
                 + "<th>effective draws</th>"
                 + ("<th>true (synthetic)</th>" if truth else "") + f"</tr></thead><tbody>{rows}"
                 "</tbody></table>")
    return parts


def _section(step: PopulationStep, img) -> str:
    head = "<h2>Population of the tests (two-stage)</h2>"
    if step.data is None:
        cls = " warn" if step.status == "failed" else ""
        label = {"off": "not run", "skipped": "skipped", "failed": "failed"}.get(step.status, step.status)
        box = f"<div class='box{cls}'><b>Population {_e(label)}</b>: {_e(step.note)}</div>"
        return head + box + _excluded_html(step)
    d = step.data
    parts = [head]
    groups = groups_of(d)
    if len(groups) > 1 or d.get("skipped_groups"):
        between = d.get("heterogeneity") or {}
        note = _e(step.note.rstrip("."))
        parts.append(f"<p>One population per material ({_e(step.status)}: {note}); none spans "
                     f"two materials. {_e(between.get('words', ''))}</p>")
        parts += [f"<p class='note'>{_e(k)}: not pooled: {_e(v)}</p>"
                  for k, v in (d.get("skipped_groups") or {}).items()]
        for material, g in groups:
            parts.append(f"<h3>{_e(material or UNLABELLED)}</h3>")
            parts += _group_html(material, g, d, None)
    else:
        material, g = groups[0]
        parts += _group_html(material, g, d, step)
    parts.append(_excluded_html(step))
    fig = next((f for f in step.files if Path(f).name == FIGURE), None)
    if fig is not None and Path(fig).is_file():
        parts.append(img(Path(fig), "population", "Left: each test's own posterior (grey, ±1.645 sd; "
                         "amber: not trusted by its own checks) and its estimate shrunken to the "
                         "population (red, 90 %), with μ's 90 % HDI (band); right: the posterior of "
                         "(μ, s). One row per material."))
    parts.append(f"<p class='note'>{POPULATION_FILE}, {MARKDOWN} and {FIGURE} beside this page; "
                 "the method and the heterogeneity check: docs/population.md. Opt out with "
                 "<code>batch --no-population</code>.</p>")
    return "".join(parts)
