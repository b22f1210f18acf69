"""The report's sections across the tests of a run with several: the paper's Tables 3 and 5 layout
from the run's posterior (one column per test, by strain rate) and the rate question (is E the
same at every rate?), with the paper's way beside it: each test alone, χ² of one E.

Each table sets like beside like: the run's posterior in one table, each test's own least squares
(the paper's white analysis) beside the run's white least squares in another.
"""

from __future__ import annotations

import html
import math

from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.numbers import fmt, fmt_at
from bayes_dnlr.report import tables as tb
from bayes_dnlr.report.page_parts import bullets, para
from bayes_dnlr.report.tables import Table
from bayes_dnlr.runs.results import RunResults
from bayes_dnlr.vocabulary import unit


def rate_of(view: RunResults) -> float:
    r = view.strain_rate()
    return float(r) if r is not None else math.nan


def rate_question(run: RunResults):
    """inference.analyses.rate.RateAnalysis of the run's posterior when E is one per test and the
    tests have at least two strain rates (else None)."""
    from bayes_dnlr.inference.analyses.rate import one_rate, rate_analysis
    from bayes_dnlr.inference.posterior.priors import Prior

    layout = run.layout
    if run.draws is None or "E" not in layout.per_test:
        return None
    keys = {t: layout.name("E", t) for t in layout.tests}
    if not all(k in run.draws for k in keys.values()):
        return None
    rates = {t: rate_of(v) for t, v in run.tests.items()}
    if one_rate(rates) is not None:
        return None
    draws = {t: run.draws[k].reshape(-1) for t, k in keys.items()}
    priors = {t: Prior.from_spec("E", run.cfg.parameters["E"]) for t in keys}
    return rate_analysis(draws, rates, priors, joint=True)


def _by_rate(run: RunResults) -> list[str]:
    return sorted(run.tests, key=lambda t: rate_of(run.tests[t]))


def tables_3_5(run: RunResults) -> Table:
    """The paper's Tables 3/5 layout from the run's posterior: one column per test (by rate)."""
    order = _by_rate(run)
    layout: Layout = run.layout
    post = (run.summary or {}).get("posterior") or {}
    lin = run.linearized()
    rows = [["strain rate (1/s)", *[fmt(rate_of(run.tests[t]), 3) for t in order]]]
    for k in run.cfg.free_parameters:
        cells = []
        for t in order:
            g = layout.name(k, t)
            s = post.get(g)
            if s is not None:
                v, sd = float(s["mean"]), float(s["sd"])
            elif lin is not None and g in lin["estimate"]:
                v, sd = lin["estimate"][g], (lin["sd"] or {}).get(g)
            else:
                cells.append("–")
                continue
            shared = " (shared)" if k not in layout.per_test else ""
            cells.append(f"{fmt_at(v, sd)} ± {fmt(sd, 2)}{shared}")
        rows.append([f"{k} ({unit(k)})", *cells])
    for k, v in run.cfg.fixed_values.items():
        rows.append([f"{k} ({unit(k)}), fixed", *[fmt(v) for _ in order]])
    de = [tb.deborah(run.tests[t]) for t in order]
    rows.append(["De_max = tau_max·ε̇ (eq. 45)",
                 *[fmt(d[0], 3) + (f" ± {fmt(d[1], 2)}" if d[1] else "") for d in de]])
    std = [((run.tests[t].summary or {}).get("standards") or {}) for t in order]
    rows.append(["ISO 527-1 modulus (MPa)", *[fmt(s.get("iso527_1")) for s in std]])
    rows.append(["ASTM D638 modulus (MPa)", *[fmt(s.get("astm_d638")) for s in std]])
    what = "posterior" if post else "least squares"
    return Table(["", *order], rows, f"Tables 3/5 layout: the run's {what}, one column per test",
                 [f"Mean ± sd of the run's {what} (all tests at once); '(shared)': one value for all "
                  "tests. Each test fitted alone, the paper's way, is in the next section."], css="num")


def alone_table(run: RunResults) -> Table | None:
    """E of each test fitted alone (the paper's white least squares) beside the run's white least
    squares: the same likelihood on both sides."""
    rec = run.record
    if rec is None:
        return None
    layout = run.layout
    rows = []
    for t in _by_rate(run):
        own = rec.tests[t].white
        g = layout.name("E", t)
        alone = None if own is None else own.estimate.get("E")
        alone_sd = None if own is None else own.sd.get("E")
        joint = None if rec.white is None else rec.white.estimate.get(g)
        joint_sd = None if rec.white is None else rec.white.sd.get(g)
        rows.append([t, fmt(rate_of(run.tests[t]), 3),
                     "–" if alone is None else f"{fmt_at(alone, alone_sd)} ± {fmt(alone_sd, 2)}",
                     "–" if joint is None else f"{fmt_at(joint, joint_sd)} ± {fmt(joint_sd, 2)}"])
    return Table(["test", "rate (1/s)", "E alone, white least squares (MPa)",
                  "E of the run, white least squares (MPa)"], rows,
                 "E of each test alone against the run's, both under white noise (eq. 32)", css="num")


def rate_section(run: RunResults, ra) -> list[str]:
    """The rate question from the run's posterior, and the paper's way (each test alone)."""
    from bayes_dnlr.report.compare import consistency_of_e, rate_table, run_row

    sec = []
    if ra is None:
        if "E" not in run.layout.per_test:
            sec.append(para("E is shared by all tests in this run (one E by construction): the joint "
                            "posterior cannot say whether the rates disagree. To ask the data, give E "
                            "one value per test (parameters.E: {per: test}); the model comparison then "
                            "weighs one E against one E per rate. The paper's way, each test alone, "
                            "is below."))
        else:
            from bayes_dnlr.inference.analyses.rate import one_rate

            why = one_rate({t: rate_of(v) for t, v in run.tests.items()})
            sec.append(para(f"No rate question: {why}" if why else
                            "No posterior draws of E per test yet (run sample)."))
    else:
        sec.append(rate_table(ra).html())
        method = ra.to_dict()["method"]
        cls = {"consistent": "ok", "rate-dependent": "warn"}.get(ra.verdict, "")
        words = ra.words.removeprefix(ra.verdict + ": ")
        sec.append(f'<div class="box {cls}"><b>The rate question: {html.escape(ra.verdict)}.</b> '
                   f"{html.escape(words)}<br>Model comparison, one E for all rates against one E per "
                   f"rate: ln BF<sub>01</sub> = {ra.log_bf01:+.2f}, method: {html.escape(method)}, "
                   f"under the likelihood of each test ({likelihoods(run)}).</div>")
        if ra.notes:
            sec.append(bullets(ra.notes))
    rec = run.record
    rows = []
    for t, v in run.tests.items():
        own = rec.tests[t] if rec is not None else None
        if own is None or own.white is None:
            continue
        alone = RunResults(run_dir=run.run_dir, cfg=v.cfg, fit={**own.raw, "parameters": own.white.names,
                                                                "strain_rate": v.strain_rate()})
        rows.append(run_row(alone))
    c = consistency_of_e(rows)
    sec.append("<h3>The paper's way: each test alone, χ² of one E</h3>" + para(c.verdict))
    t = alone_table(run)
    if t is not None:
        sec.append(t.html())
    return sec


def likelihoods(run: RunResults) -> str:
    """Each test's likelihood in the run's posterior, in words."""
    parts = []
    for t, v in run.tests.items():
        model = ((v.summary or {}).get("noise") or {}).get("model", "white")
        parts.append(f"{html.escape(t)}: {model}")
    return ", ".join(parts)
