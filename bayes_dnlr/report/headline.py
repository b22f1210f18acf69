"""The report's top: the headline (E, how it compares with the paper's white least squares and the
standards, De_max, the truth of a synthetic test) and the warnings of the run and of every test.

Written for any number of tests: each test's part is labelled with its name in a run with several
(``Layout.plain`` runs keep the one-test wording).
"""

from __future__ import annotations

import html
from typing import Any

from bayes_dnlr.inference.lsq.plausibility import plausibility_warnings
from bayes_dnlr.numbers import fmt, interval, pm
from bayes_dnlr.report import tables as tb
from bayes_dnlr.report.modulus_section import consistency_box
from bayes_dnlr.report.modulus_section import headline_words as modulus_words
from bayes_dnlr.report.modulus_section import trust_box as modulus_box
from bayes_dnlr.report.page_parts import bullets
from bayes_dnlr.report.run_sections import truths
from bayes_dnlr.runs.results import RunResults, verdict_lines

STANDARDS = (("iso527_1", "ISO 527-1"), ("astm_d638", "ASTM D638"))


def _labels(run: RunResults) -> dict[str, str]:
    """Each test's prefix in sentences about several tests ("" for a run with one test)."""
    plain = run.layout.plain
    return {t: "" if plain else f"{t}: " for t in run.cfg.test_names}


def _standard(view: RunResults, results: dict | None, key: str) -> tuple[float | None, Any]:
    """A standard modulus of a test (summary.json's, else computed now) and its computed result."""
    r = (results or {}).get(key)
    val = ((view.summary or {}).get("standards") or {}).get(key)
    if val is None and r is not None:
        val = r.modulus
    return val, r


def missing_standards(run: RunResults, standards: dict[str, dict | None]) -> list[str]:
    """A sentence per standard modulus that could not be computed on a test's curve."""
    out = []
    for t, view in run.tests.items():
        where = "this curve" if run.layout.plain else t
        for key, name in STANDARDS:
            val, r = _standard(view, standards.get(t), key)
            known = r is not None or key in ((view.summary or {}).get("standards") or {})
            if val is None and known:
                why = getattr(r, "reason", None)
                out.append(f"{name} is not available on {where}" + (f": {why}" if why else ""))
    return out


def headline(run: RunResults, standards: dict[str, dict | None] | None = None, rate=None) -> str:
    """The box at the top of the page (``standards``: test -> standards.standard_results, or
    None; ``rate``: the rate question's analysis, when the run asks it)."""
    standards = standards or {}
    e, e_sd, src = tb.e_model(run)
    parts = []
    if e is not None:
        s = f"<b>E = {pm(e, e_sd)} MPa</b> ({src} ± sd"
        post = (run.summary or {}).get("posterior") or {}
        if "E" in post and post["E"].get("hdi_90"):
            lo, hi = post["E"]["hdi_90"]
            s += f"; 90 % HDI {interval(lo, hi, e_sd)}"
        s += ")"
        gn = run.gn()
        if run.uses_discrepancy:
            s += "; with the model discrepancy"
        if gn is not None and src != "Gauss-Newton" and "E" in gn["estimate"]:
            s += (f"; white-noise least squares (the paper's) "
                  f"{pm(gn['estimate']['E'], (gn['sd'] or {}).get('E'))} MPa")
        parts.append(s + ".")
        words = modulus_words(run)
        if words:
            parts.append(words)
    elif rate is not None:
        parts.append(html.escape(rate.words))
    labels = _labels(run)
    iso = []
    for t, view in run.tests.items():
        val, _ = _standard(view, standards.get(t), "iso527_1")
        e_t = tb.e_model(view)[0]
        if val is not None and e_t:
            iso.append(f"{labels[t]}{fmt(val)} MPa, {val / e_t:.2f} × E")
    if iso:
        parts.append(f"ISO 527-1 on the same curve{'s' if len(iso) > 1 else ''}: {'; '.join(iso)}.")
    missing = missing_standards(run, standards)
    if missing:
        parts.append(html.escape("; ".join(missing)) + ".")
    for t, view in run.tests.items():
        above = tb.standards_above_e(view, standards.get(t))
        if above:
            parts.append(f'<span class="bad">{html.escape(labels[t] + above)}</span>')
    de = [(labels[t], *tb.deborah(view)) for t, view in run.tests.items()]
    de = [(lab, v, src) for lab, v, _, src in de if v is not None]
    if de:
        srcs = sorted({src for *_, src in de})
        parts.append("De<sub>max</sub> = τ<sub>max</sub>·ε̇ = "
                     + ", ".join(html.escape(lab) + fmt(v, 3) for lab, v, _ in de)
                     + f" (eq. 45, {html.escape(' and '.join(srcs))}).")
    true = truths(run, ["E"])
    if true and true[0] is not None and e is not None:
        te = true[0]
        parts.append(f"Synthetic test{'s' if len(run.tests) > 1 else ''}: true E = {fmt(te)} MPa "
                     f"({(e - te) / e_sd if e_sd else float('nan'):+.1f} sd away).")
    return ('<div class="box">' + " ".join(parts) + "</div>" + consistency_box(run) + checks_box(run)
            + modulus_box(run))


def checks_box(run: RunResults) -> str:
    """The verdict of the run's checks (summary.json ``checks``), under the headline: green when E's
    interval can be used as it is, amber otherwise (the verdict's first sentence says which)."""
    checks = (run.summary or {}).get("checks")
    if not checks or not checks.get("verdict"):
        return ""
    css = "ok" if checks.get("trust_interval") else "warn"
    head, points = verdict_lines(checks)          # one finding per line: four in a paragraph read as one
    words = f"<b>{html.escape(head)}</b>" + bullets(points) if points else html.escape(head)
    return f'<div class="box {css}"><b>Verdict</b> of the checks (docs/sampling.md, "checks"): {words}</div>'


def warnings(run: RunResults) -> list[str]:
    """The run's warnings and every test's own (its fit's, the plausibility of its point, its data),
    each named with its test in a run with several; then the sampler's."""
    out = list(run.problems)
    rec = run.record
    for ws in (rec.warnings if rec is not None else None, (run.summary or {}).get("warnings")):
        out += [str(w) for w in ws or [] if str(w) not in out]
    labels = _labels(run)
    for t, view in run.tests.items():
        own = rec.tests.get(t) if rec is not None else None
        out += [labels[t] + w for w in (own.warnings if own is not None else []) if labels[t] + w not in out]
        point = view.point()
        which = "least squares under model error" if view.compared_with_gls else "white least squares"
        post = (view.summary or {}).get("posterior") or {}
        if post:      # the posterior medians too: a fit.json made before the check, or a shifted posterior
            point = {**point, **{k: v["median"] for k, v in post.items() if k in ("E", "G")}}
            which = "posterior medians"
        for w in plausibility_warnings(point, which):
            kind = labels[t] + w.split("=")[0]     # "3G ": one of each kind, the fit's when it has one
            if not any(x.startswith(kind) for x in out):
                out.append(labels[t] + w)
    post = (run.summary or {}).get("posterior") or {}
    for k, v in post.items():
        rh, ess = v.get("r_hat"), v.get("ess_bulk")
        issues = []
        if rh is not None and rh > 1.01 and not any(f"R-hat of {k} " in w for w in out):
            issues.append(f"R-hat {rh:.3f} > 1.01")
        if ess is not None and ess < 400:
            issues.append(f"bulk ESS {ess:.0f} < 400")
        if issues:
            out.append(f"{k}: {', '.join(issues)}: the posterior summaries of {k} are not reliable yet "
                       "(a longer chain: raise sampler.max_steps and run `sample` again).")
    for t, view in run.tests.items():
        if view.data_error:
            out.append(f"{labels[t]}The test data could not be loaded ({view.data_error}): no fit or "
                       "sensitivity figure.")
    return out
