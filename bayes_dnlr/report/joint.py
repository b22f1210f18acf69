"""The report of a run with several tests (``tests:``): one joint posterior, every test's fit.

Sections: the parameters of the joint vector (posterior against the joint least squares, eq. 32-35);
the paper's Tables 3 and 5 layout (one column per test, sorted by rate) from the joint posterior;
the rate question when E is one per test (posterior differences, trend, Savage-Dickey, verdict;
the paper's χ² beside it); one corner plot; each test's fit and residuals; each test's model
error; sampler diagnostics.

Each test is shown through a *view*: a ``RunResults`` of that test alone whose draws, estimates and
noise are the joint ones mapped to the test's own names (``tau_max[r5e-3]`` -> ``tau_max``), so the
single-test figures (fit_plot, model_curves) serve unchanged.
"""

from __future__ import annotations

import datetime as _dt
import html
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr import __version__
from bayes_dnlr.inference.layout import joint_name
from bayes_dnlr.report import figures as figs
from bayes_dnlr.report import model_error as rn
from bayes_dnlr.report import tables as tb
from bayes_dnlr.report.page_parts import CSS, bullets, img, para
from bayes_dnlr.report.tables import Table, fmt, fmt_at
from bayes_dnlr.runs.curves import N_DRAWS, model_curves, run_white_curve
from bayes_dnlr.runs.results import RunResults, attach_test
from bayes_dnlr.vocabulary import NOISE_NAMES, base_name, unit


def _joint(name: str, test: str, per_test: list[str]) -> str:
    return joint_name(name, test) if (name in per_test or name in NOISE_NAMES) else name


def _sub(obj: Any, idx: list[int]) -> Any:
    if obj is None:
        return None
    a = np.asarray(obj, dtype=float)
    return a[np.ix_(idx, idx)].tolist() if a.ndim == 2 else None


def _local_block(block: dict | None, names: list[str], local: list[str], test: str,
                 per_test: list[str]) -> dict | None:
    """estimate/sd/covariance/correlation of the joint vector, restricted to a test's own names."""
    if not block or block.get("estimate") is None:
        return None
    idx = [names.index(_joint(k, test, per_test)) for k in local]
    g = [names[i] for i in idx]
    return {"parameters": local,
            "estimate": {k: block["estimate"][j] for k, j in zip(local, g, strict=True)},
            "sd": {k: (block.get("sd") or {}).get(j) for k, j in zip(local, g, strict=True)},
            "covariance": _sub(block.get("covariance"), idx),
            "correlation": _sub(block.get("correlation"), idx)}


def test_view(run: RunResults, test: str) -> RunResults:
    """One test of a joint run as a single-test RunResults (joint draws and estimates, its names)."""
    cfg = run.cfg.for_test(test)
    fit = run.fit or {}
    per_test = list(fit.get("per_test") or run.cfg.per_test_parameters)
    names = list(fit.get("parameters") or run.names)
    local = [k for k in cfg.free_parameters if _joint(k, test, per_test) in names]
    info = (fit.get("tests") or {}).get(test) or {}
    single = (fit.get("single_fits") or {}).get(test) or {}
    vfit = _local_block(fit, names, local, test, per_test)
    if vfit is not None:
        vfit.update({"sigma0": info.get("sigma0"), "sigma0_source": info.get("sigma0_source"),
                     "residuals": info.get("residuals"), "strain_rate": info.get("strain_rate"),
                     "deborah_max": single.get("deborah_max"), "n_points": info.get("n_points")})
        gls = fit.get("discrepancy")
        if gls and test in (gls.get("tests") or []):
            vfit["discrepancy"] = _local_block(gls, names, local, test, per_test)
    vsum = None
    if run.summary is not None:
        post = run.summary.get("posterior") or {}
        sampled = [k for k in (*local, *NOISE_NAMES) if _joint(k, test, per_test) in post]
        vsum = {"parameters": local,
                "posterior": {k: post[_joint(k, test, per_test)] for k in sampled},
                "noise": ((run.summary.get("noise") or {}).get("tests") or {}).get(test),
                "sigma0": (run.summary.get("sigma0") or {}).get(test),
                "standards": (run.summary.get("standards") or {}).get(test),
                "strain_rate": info.get("strain_rate")}
    draws = None
    if run.draws is not None:
        draws = {k: run.draws[_joint(k, test, per_test)] for k in (*local, *NOISE_NAMES)
                 if _joint(k, test, per_test) in run.draws}
    view = RunResults(run_dir=run.run_dir, cfg=cfg, fit=vfit, summary=vsum, draws=draws)
    attach_test(view, cfg)
    return view


def _rate(view: RunResults) -> float:
    r = view.strain_rate()
    return float(r) if r is not None else math.nan


def _truths(views: dict[str, RunResults], names: list[str]) -> list[float | None] | None:
    """True values of the joint names (synthetic tests): a shared one only when every test agrees."""
    if not all(v.truth for v in views.values()):
        return None
    out = []
    for g in names:
        t = g[g.index("[") + 1:-1] if "[" in g else None
        k = base_name(g)
        vals = [views[t].truth.get(k)] if t else [v.truth.get(k) for v in views.values()]
        ok = all(x is not None for x in vals) and max(vals) - min(vals) <= 1e-12 * abs(max(vals))
        out.append(vals[0] if ok else None)
    return out


def rate_question(run: RunResults, views: dict[str, RunResults]):
    """inference.rate.RateAnalysis of the joint posterior when E is one per test (else None)."""
    from bayes_dnlr.inference.analyses.rate import rate_analysis
    from bayes_dnlr.inference.posterior.priors import Prior

    if run.draws is None or "E" not in run.cfg.per_test_parameters:
        return None
    keys = {t: joint_name("E", t) for t in views}
    if not all(k in run.draws for k in keys.values()):
        return None
    rates = {t: _rate(v) for t, v in views.items()}
    if len({r for r in rates.values() if math.isfinite(r)}) < 2:
        return None
    draws = {t: run.draws[k].reshape(-1) for t, k in keys.items()}
    priors = {t: Prior.from_spec("E", run.cfg.parameters["E"]) for t in views}
    return rate_analysis(draws, rates, priors, joint=True)


def tables_3_5(run: RunResults, views: dict[str, RunResults]) -> Table:
    """The paper's Tables 3/5 layout from the joint posterior: one column per test (by rate)."""
    order = sorted(views, key=lambda t: _rate(views[t]))
    post = (run.summary or {}).get("posterior") or {}
    est = (run.fit or {}).get("estimate") or {}
    sds = (run.fit or {}).get("sd") or {}
    per_test = run.cfg.per_test_parameters
    rows = [["strain rate (1/s)", *[fmt(_rate(views[t]), 3) for t in order]]]
    for k in run.cfg.free_parameters:
        cells = []
        for t in order:
            g = _joint(k, t, per_test)
            s = post.get(g)
            if s is not None:
                v, sd = float(s["mean"]), float(s["sd"])
            elif g in est:
                v, sd = est[g], sds.get(g)
            else:
                cells.append("–")
                continue
            cells.append(f"{fmt_at(v, sd)} ± {fmt(sd, 2)}" + (" (shared)" if k not in per_test else ""))
        rows.append([f"{k} ({unit(k)})", *cells])
    for k, v in run.cfg.fixed_values.items():
        rows.append([f"{k} ({unit(k)}), fixed", *[fmt(v) for _ in order]])
    de = [tb.deborah(views[t]) for t in order]
    rows.append(["De_max = tau_max·ε̇ (eq. 45)",
                 *[fmt(d[0], 3) + (f" ± {fmt(d[1], 2)}" if d[1] else "") for d in de]])
    std = [((views[t].summary or {}).get("standards") or {}) for t in order]
    rows.append(["ISO 527-1 modulus (MPa)", *[fmt(s.get("iso527_1")) for s in std]])
    rows.append(["ASTM D638 modulus (MPa)", *[fmt(s.get("astm_d638")) for s in std]])
    singles = (run.fit or {}).get("single_fits") or {}
    alone = []
    for t in order:
        s = singles.get(t) or {}
        e, sd = (s.get("estimate") or {}).get("E"), (s.get("sd") or {}).get("E")
        alone.append("–" if e is None else f"{fmt_at(e, sd)} ± {fmt(sd, 2)}")
    rows.append(["E of the test alone, least squares (MPa)", *alone])
    return Table(["", *order], rows, "Tables 3/5 layout: the joint posterior, one column per test",
                 ["Posterior mean ± sd of the joint posterior; '(shared)': one value for all tests. The "
                  "last row fits each test alone (the paper's way), for contrast with the joint E."],
                 css="num")


def _headline(run: RunResults, views: dict[str, RunResults], ra) -> str:
    post = (run.summary or {}).get("posterior") or {}
    singles = (run.fit or {}).get("single_fits") or {}
    best = min((float((s.get("sd") or {}).get("E") or math.inf) for s in singles.values()),
               default=math.inf)
    if "E" in post:
        e = post["E"]
        lo, hi = e["hdi_90"]
        txt = (f"<b>E = {fmt_at(e['mean'], e['sd'])} ± {fmt(e['sd'], 2)} MPa</b> (joint posterior of "
               f"{len(views)} tests, 90 % HDI [{fmt(lo)}, {fmt(hi)}])")
        if math.isfinite(best) and best > 0:
            txt += (f"; its sd is {e['sd'] / best:.2f} × the smallest single-test least-squares sd "
                    f"({fmt(best, 2)} MPa)")
        return f'<div class="box ok">{txt}.</div>'
    if ra is not None:
        return f'<div class="box">{html.escape(ra.words)}</div>'
    return '<div class="box warn">No posterior yet: run <code>sample</code>.</div>'


def _rate_section(run: RunResults, views: dict[str, RunResults], ra) -> list[str]:
    from bayes_dnlr.report.compare import consistency_of_e, rate_table, run_row

    sec = ["<h2>3. Is E rate-independent?</h2>"]
    if ra is None:
        if "E" not in run.cfg.per_test_parameters:
            sec.append(para("E is shared by all tests in this run (one E by construction): the joint "
                            "posterior cannot say whether the rates disagree. To ask the data, give E "
                            "one value per test (parameters.E: {per: test}); the model comparison then "
                            "weighs one E against one E per rate. The paper's way, each test alone, "
                            "is below."))
        else:
            sec.append(para("No posterior draws of E per test yet (run sample), or fewer than two "
                            "distinct strain rates."))
    else:
        sec.append(rate_table(ra).html())
        method = ra.to_dict()["method"]
        cls = {"consistent": "ok", "rate-dependent": "warn"}.get(ra.verdict, "")
        words = ra.words.removeprefix(ra.verdict + ": ")
        sec.append(f'<div class="box {cls}"><b>Verdict: {html.escape(ra.verdict)}.</b> '
                   f"{html.escape(words)}<br>Model comparison, one E for all rates against one E per "
                   f"rate: ln BF<sub>01</sub> = {ra.log_bf01:+.2f}, method: {html.escape(method)}, "
                   f"under the likelihood of each test ({_likelihoods(views)}).</div>")
        if ra.notes:
            sec.append(bullets(ra.notes))
    rows = []
    for t, v in views.items():
        s = ((run.fit or {}).get("single_fits") or {}).get(t) or {}
        alone = RunResults(run_dir=run.run_dir, cfg=v.cfg, fit={**s, "parameters": list(
            (s.get("estimate") or {}).keys()), "strain_rate": v.strain_rate()})
        rows.append(run_row(alone))
    c = consistency_of_e(rows)
    sec.append("<h3>The paper's way: each test alone, χ² of one E</h3>" + para(c.verdict))
    return sec


def _likelihoods(views: dict[str, RunResults]) -> str:
    parts = []
    for t, v in views.items():
        model = ((v.summary or {}).get("noise") or {}).get("model", "white")
        parts.append(f"{html.escape(t)}: {model}")
    return ", ".join(parts)


def build_joint_report(run: RunResults, figdir: Path, t0: float) -> str:
    """The HTML page of a joint run (figures written into ``figdir``)."""
    cfg = run.cfg
    views = {t: test_view(run, t) for t in cfg.test_names}
    names = run.names
    model_names = [n for n in names if base_name(n) not in NOISE_NAMES]
    ra = rate_question(run, views)
    sec: list[str] = []
    tests_txt = "; ".join(
        f"{html.escape(t)}: <code>{html.escape(v.cfg.data.file)}</code>, {fmt(_rate(v), 3)} 1/s, "
        f"{fmt(((run.fit or {}).get('tests') or {}).get(t, {}).get('n_points'))} points"
        for t, v in views.items())
    per = ", ".join(cfg.per_test_parameters) or "none"
    sec.append(f"<h1>{html.escape(run.name)}: joint identification report ({len(views)} tests)</h1>"
               f"<div class='meta'>Tests: {tests_txt} · one parameter per test: {html.escape(per)}; "
               f"the others shared · model: {cfg.model.modes} modes over {cfg.model.decades:g} decades"
               "</div>")
    sec.append(_headline(run, views, ra))
    warns = list((run.summary or {}).get("warnings") or (run.fit or {}).get("warnings") or [])
    warns += [f"{t}: the data could not be loaded ({v.data_error})" for t, v in views.items() if v.data_error]
    if warns:
        sec.append('<div class="box warn"><b>Warnings</b>' + bullets(warns) + "</div>")
    if not run.has_posterior:
        sec.append('<div class="box warn"><b>No posterior yet.</b> Run <code>python -m bayes_dnlr sample '
                   f"{html.escape(str(run.run_dir))}/config.yaml</code>, then this report again.</div>")

    sec.append("<h2>1. Parameters of the joint vector</h2>")
    sec.append(tb.parameter_table(run).html())
    sec.append("<h2>2. Tables 3 and 5 of the paper, from the joint posterior</h2>")
    sec.append(tables_3_5(run, views).html())
    sec += _rate_section(run, views, ra)

    # 4. one corner plot of the model parameters
    if run.draws is not None and all(n in run.draws for n in model_names):
        sec.append("<h2>4. Joint posterior and its linearization</h2>")
        samples = np.column_stack([run.draws[n].reshape(-1) for n in model_names])
        gn = run.linearized()
        est = cov = None
        if gn is not None and gn["covariance"] is not None and all(n in gn["names"] for n in model_names):
            idx = [gn["names"].index(n) for n in model_names]
            est = [gn["estimate"][n] for n in model_names]
            cov = gn["covariance"][np.ix_(idx, idx)]
        truths = _truths(views, model_names)
        p = figs.corner_plot(samples, model_names, figdir / "corner.png", est, cov, truths,
                             linearized_label="joint GLS" if run.uses_discrepancy and run.gls()
                             else "joint Gauss-Newton")
        sec.append(img(p, "corner plot", (
            "Joint posterior of the model parameters of all tests (grey: histograms and the 39 % / 86 % "
            "contours) with the joint least-squares estimate and the linearized 1σ and 2σ ellipses of "
            "Δ = (Σ X<sub>t</sub>ᵀW<sub>t</sub>X<sub>t</sub>)⁻¹ (eq. 32 over the stacked tests, blue)"
            + ("; green: the true values of these synthetic tests" if truths else "") + ".")))

    # 5. every test's fit and residuals
    sec.append("<h2>5. Fit and residuals of every test</h2>")
    for t, v in views.items():
        sec.append(f"<h3>{html.escape(t)} ({fmt(_rate(v), 3)} 1/s)</h3>")
        if v.test is None:
            sec.append(para(f"No fit figure: {v.data_error}"))
            continue
        curves = model_curves(v, N_DRAWS)
        slug = "".join(c if c.isalnum() or c in "._-" else "_" for c in t)
        centre = curves.median if curves.median is not None else curves.gn_curve
        disc = (rn.discrepancy_on_window(v, centre[curves.window])
                if centre is not None and v.uses_discrepancy else None)
        p = figs.fit_plot(curves.x, curves.data, figdir / f"fit-{slug}.png", window=curves.window,
                          median=curves.median, band=curves.band, predictive=curves.predictive,
                          gn_curve=curves.gn_curve, sigma0=v.sigma0(), xlabel=curves.xlabel,
                          discrepancy=None if disc is None else disc.mean)
        what = ("the joint posterior median of this test's model, its 90 % credible band (dark) and "
                "90 % posterior predictive band (light)" if curves.median is not None
                else "the joint least-squares fit")
        if disc is not None:
            what += "; green on the residuals: the posterior mean of this test's model discrepancy δ"
        sec.append(img(p, f"fit {t}", f"Data (grey dots) and {what}; dashed blue: the joint "
                                       "least-squares fit. Residuals below, ±σ0 dotted."))
        resid = None
        if curves.gn_curve is not None:
            resid = (curves.data - run_white_curve(v, curves))[curves.window]
        words = tb.residual_words(v.fit, (v.fit or {}).get("sigma0"))
        if resid is not None and resid.size:
            rms = float(np.sqrt(np.mean(resid**2)))
            alone = (((run.fit or {}).get("tests") or {}).get(t) or {}).get("rms_single_fit")
            words.append(f"rms of the residuals at the joint estimate: {fmt(rms, 3)} MPa (this test "
                         f"fitted alone: {fmt(alone, 3)} MPa)")
        sec.append(bullets(words))
        noise = (v.summary or {}).get("noise") or {}
        if noise.get("verdict"):
            sec.append(f'<p class="note">Model error: {html.escape(noise["verdict"])}</p>')

    # 6. sampler
    if run.draws is not None:
        sec.append("<h2>6. Sampler diagnostics</h2>")
        st = tb.sampler_table(run)
        if st is not None:
            sec.append(st.html())
        p = figs.trace_plot({n: run.draws[n] for n in names if n in run.draws}, figdir / "trace.png")
        sec.append(img(p, "trace plot", "Trace plot of every sampled parameter of the joint vector "
                                         "(left: marginals of 8 walker groups; right: the kept draws)."))
    elapsed = time.perf_counter() - t0
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    sec.append(f"<footer>bayes_dnlr {__version__} · {now} · run directory {html.escape(str(run.run_dir))} "
               f"· built in {elapsed:.1f} s · eq. and table numbers refer to Blaise et al.</footer>")
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(run.name)} joint report</title><style>{CSS}</style></head><body>"
            + "\n".join(sec) + "</body></html>")
