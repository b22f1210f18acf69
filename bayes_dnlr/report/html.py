"""The self-contained report: run_dir/report.html (figures embedded as base64 PNG) and run_dir/figures/.

``build_report(run_dir)`` reads what the run directory holds: with only fit.json it shows the fit part
and says that the posterior is missing; with summary.json and posterior.nc it adds the corner plot,
the posterior predictive band, the posterior/linearized comparison and the ArviZ diagnostics.
"""

from __future__ import annotations

import datetime as _dt
import html
import time
from pathlib import Path

import numpy as np

from bayes_dnlr import __version__
from bayes_dnlr.inference.lsq.plausibility import plausibility_warnings
from bayes_dnlr.numbers import fmt, interval, pm
from bayes_dnlr.report import figures as figs
from bayes_dnlr.report import model_error as rn
from bayes_dnlr.report import tables as tb
from bayes_dnlr.report import views
from bayes_dnlr.report.page_parts import CSS, bullets, img, para
from bayes_dnlr.runs.curves import N_DRAWS, model_curves, run_white_curve
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
from bayes_dnlr.runs.results import RunResults, load_run
from bayes_dnlr.runs.testset import plain_names


def _headline(run: RunResults, std: dict | None) -> str:
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
    iso = ((run.summary or {}).get("standards") or {}).get("iso527_1")
    if iso is None and std and std.get("iso527_1") is not None:
        iso = std["iso527_1"].modulus
    if iso is not None and e:
        parts.append(f"ISO 527-1 on the same curve: {fmt(iso)} MPa, {iso / e:.2f} × E.")
    above = tb.standards_above_e(run, std)
    if above:
        parts.append(f'<span class="bad">{html.escape(above)}</span>')
    de, de_sd, _ = tb.deborah(run)
    if de is not None:
        parts.append(f"De<sub>max</sub> = τ<sub>max</sub>·ε̇ = {fmt(de, 3)} (eq. 45).")
    truth = run.truth
    if truth and "E" in truth and e is not None:
        parts.append(f"Synthetic test: true E = {fmt(truth['E'])} MPa "
                     f"({(e - truth['E']) / e_sd if e_sd else float('nan'):+.1f} sd away).")
    return '<div class="box">' + " ".join(parts) + "</div>"


def _warnings(run: RunResults) -> list[str]:
    out = list(run.problems)
    for src in (run.fit, run.summary):
        if src:
            out += [str(w) for w in src.get("warnings") or [] if str(w) not in out]
    point = run.point()
    post = (run.summary or {}).get("posterior") or {}
    if post:      # the posterior medians too: a fit.json made before the check, or a shifted posterior
        point = {**point, **{k: v["median"] for k, v in post.items() if k in ("E", "G")}}
    for w in plausibility_warnings(point):
        kind = w.split("=")[0]          # "3G ": one warning of each kind, the fit's when it has one
        if not any(x.startswith(kind) for x in out):
            out.append(w)
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
    if run.data_error:
        out.append(f"The test data could not be loaded ({run.data_error}): no fit or sensitivity figure.")
    return out


def build_report(run_dir: Path | str) -> Path:
    """Write run_dir/report.html and run_dir/figures/*.png; return the path of report.html."""
    t0 = time.perf_counter()
    run_dir = Path(run_dir)
    run = load_run(run_dir)
    figdir = run_dir / FIGURES_DIR
    figdir.mkdir(exist_ok=True)
    for old in figdir.glob("*.png"):     # figures of an earlier report that may not apply any more
        old.unlink()
    if not plain_names(run.cfg):
        from bayes_dnlr.report.joint import build_joint_report

        out = run_dir / REPORT_FILE
        write_atomic(out, build_joint_report(run, figdir, t0))
        return out
    std = None
    if run.test is not None:
        from bayes_dnlr.standards import standard_results

        std = standard_results(run.test)
    curves = model_curves(run) if run.test is not None else None
    names = run.model_names
    gn = run.linearized()
    sec: list[str] = []

    cfg = run.cfg
    w = cfg.data.window
    window_txt = ", ".join(f"{k} {v:g}" for k, v in w.model_dump().items() if v is not None) or "whole test"
    n_pts = (run.fit or run.summary or {}).get("n_points") or (run.test.n_points if run.test else None)
    meta = (f"Data: <code>{html.escape(cfg.data.file)}</code> · observable {cfg.data.observable} · "
            f"window: {html.escape(window_txt)} · {fmt(n_pts)} points · strain rate "
            f"{fmt(run.strain_rate(), 3)} 1/s · model: {cfg.model.modes} modes over {cfg.model.decades:g} "
            f"decades · free parameters: {', '.join(names)}"
            + (" (and sigma0, sampled)" if "sigma0" in run.names else ""))
    sec.append(f"<h1>{html.escape(run.name)}: identification report</h1><div class='meta'>{meta}</div>")
    sec.append(_headline(run, std))
    if not run.has_posterior:
        sec.append('<div class="box warn"><b>No posterior yet.</b> This run has no summary.json/'
                   "posterior.nc: the report shows the least-squares part only. Run "
                   "<code>python -m bayes_dnlr sample "
                   f"{html.escape(str(run_dir))}/config.yaml</code>, then this report again.</div>")
    if run.fit is None:
        sec.append('<div class="box warn"><b>No fit.json.</b> The least-squares results (estimate, '
                   "linearized covariance, residual diagnostics) are missing: run <code>python -m bayes_dnlr "
                   "fit</code>.</div>")
    warns = _warnings(run)
    if warns:
        sec.append('<div class="box warn"><b>Warnings</b>' + bullets(warns) + "</div>")

    # 1. parameters
    sec.append("<h2>1. Parameters</h2>")
    sec.append(tb.parameter_table(run).html())

    # 2. corner
    if run.draws is not None and all(n in run.draws for n in names):
        sec.append("<h2>2. Posterior and its linearization</h2>")
        samples = np.column_stack([run.draws[n].reshape(-1) for n in names])
        est = cov = None
        if gn is not None and gn["covariance"] is not None and all(n in gn["names"] for n in names):
            idx = [gn["names"].index(n) for n in names]
            est = [gn["estimate"][n] for n in names]
            cov = gn["covariance"][np.ix_(idx, idx)]
        truths = [run.truth.get(n) for n in names] if run.truth else None
        p = figs.corner_plot(samples, names, figdir / "corner.png", est, cov, truths,
                             linearized_label="GLS" if run.uses_discrepancy and run.gls() else
                             "Gauss-Newton")
        lin_txt = ("the generalized least-squares estimate and the linearized 1σ and 2σ ellipses of "
                   "Δ = (XᵀK⁻¹X)⁻¹ (eq. 32 with the discrepancy's covariance K, blue)"
                   if run.uses_discrepancy and run.gls() else
                   "the Gauss-Newton estimate and the linearized 1σ and 2σ ellipses of Δ = σ0²(XᵀX)⁻¹ "
                   "(eq. 32, blue)")
        sec.append(img(p, "corner plot", (
            "Posterior of the free parameters (grey: histograms and the 39 % / 86 % contours) with "
            + lin_txt
            + ("; green: the true values of this synthetic test" if truths else "")
            + ". Where the grey contours and the blue ellipses coincide, the linearization holds.")))
    elif run.has_posterior:
        sec.append("<h2>2. Posterior and its linearization</h2>")
        sec.append(para("posterior.nc is missing or unreadable: no corner plot (summary tables below)."))

    # 3. correlations and disagreements
    post_t, lin_t = tb.correlation_tables(run)
    if post_t or lin_t:
        sec.append("<h2>3. Correlations: posterior against Δ̃ (eq. 35)</h2>" if post_t else
                   "<h2>3. Correlations: the linearized Δ̃ (eq. 35)</h2>")
        sec.append('<div class="pair">' + "".join(t.html() for t in (post_t, lin_t) if t) + "</div>")
        comp = tb.comparison_table(run)
        if comp is not None:
            sec.append(comp.html())
            dis = [d for d in tb.disagreements(run) if d.kind in ("sd", "rho")]
            notes = [d for d in tb.disagreements(run) if d.kind == "mean"]
            if dis:
                sec.append('<div class="box warn"><b>Where the linearization fails</b>'
                           + bullets([d.text for d in dis], "flags") + "</div>")
            elif (run.fit or {}).get("residuals", {}).get("white"):
                sec.append('<div class="box ok">The posterior agrees with the linearized analysis: '
                           f"every sd within {100 * tb.SD_TOLERANCE:.0f} % and every correlation within "
                           f"{tb.RHO_TOLERANCE}.</div>")
            else:
                sec.append('<div class="box">The posterior and the linearized analysis agree (every sd '
                           f"within {100 * tb.SD_TOLERANCE:.0f} %, every correlation within "
                           f"{tb.RHO_TOLERANCE}), but the residuals are not white: the agreement says the "
                           "posterior is close to Gaussian, not that the model fits. See section 5 for "
                           "what the checks say of the intervals.</div>")
            if notes:
                sec.append(bullets([d.text for d in notes]))

    # 4. fit and residuals
    sec.append("<h2>4. Fit and residuals</h2>")
    if curves is not None:
        inset = views.fit_inset(curves.x, run.test.relaxation_start)
        centre = curves.median if curves.median is not None else curves.gn_curve
        disc = (rn.discrepancy_on_window(run, centre[curves.window])
                if centre is not None and run.uses_discrepancy else None)
        p = figs.fit_plot(curves.x, curves.data, figdir / "fit.png", window=curves.window,
                          median=curves.median, band=curves.band, predictive=curves.predictive,
                          gn_curve=curves.gn_curve, sigma0=run.sigma0(), xlabel=curves.xlabel,
                          inset_xmax=inset.xmax if inset else None,
                          inset_title=inset.title if inset else None,
                          discrepancy=None if disc is None else disc.mean)
        n_used = min(N_DRAWS, next(iter(run.draws.values())).size) if run.draws else 0
        noise_txt = "model + discrepancy δ + noise σ0" if run.uses_discrepancy else "model + noise σ0"
        what = (f"the posterior median of the model over {n_used} posterior draws, its 90 % credible band "
                f"(dark) and the 90 % posterior predictive band ({noise_txt}, light)"
                if curves.median is not None else "the least-squares fit")
        if disc is not None:
            what += "; green on the residuals: the posterior mean of the model discrepancy δ"
        sec.append(img(p, "fit and residuals", (
            f"Data (grey dots) and {what}; the dashed blue line is the least-squares fit"
            + (f"; {inset.caption}" if inset else "") + ". Residuals "
            "(data - model) below, with ±σ0 dotted: without model bias they scatter evenly around zero "
            "(paper Figs 6-10).")))
    else:
        sec.append(para("No fit figure: the test data could not be loaded."))
    fit_sigma0 = (run.fit or {}).get("sigma0", run.sigma0())   # the white analysis' own σ0
    sec.append("<h3>Residual diagnostics of the white fit (fit.json)</h3>"
               + bullets(tb.residual_words(run.fit, fit_sigma0)))

    # 5. model error
    sec.append("<h2>5. Model error: the two analyses and the checks</h2>")
    white_resid = None
    if curves is not None and curves.gn_curve is not None:
        white_resid = (curves.data - run_white_curve(run, curves))[curves.window]
    sec += rn.noise_section(run, figdir, disc if curves is not None else None, white_resid)

    # 6. sensitivities
    if curves is not None and curves.sensitivities:
        sec.append("<h2>6. Sensitivities (eq. 37)</h2>")
        p = figs.sensitivity_plot(curves.x, curves.sensitivities, figdir / "sensitivity.png",
                                  window=curves.window, xlabel=curves.xlabel)
        sec.append(img(p, "sensitivities", (
            "Normalised sensitivities X̃<sub>j</sub> = β<sub>j</sub> ∂σ/∂β<sub>j</sub> (eq. 37, MPa) at the "
            "least-squares estimate (paper Fig. 11). Parameters are identifiable where their curves differ "
            "in shape; proportional curves mean correlated parameters.")))
        view = views.xy_view(curves.sensitivities, curves.strain, run.test.time,
                             run.test.relaxation_start)
        if view is not None:
            p = figs.sensitivity_xy_plot(view.x_tau, view.x_e, view.colour, figdir / "sensitivity_xy.png",
                                         colour_label=view.colour_label, zoom=view.zoom,
                                         zoom_title=view.zoom_title, mark=view.mark,
                                         mark_label=view.mark_label, log_colour=view.log_colour)
            sec.append(img(p, "X(E) against X(tau_max)", view.caption))

    # 7. standards, Deborah, cross-checks
    sec.append("<h2>7. Standards, Deborah number and independent measurements</h2>")
    sec.append(tb.standards_table(run, std).html())
    sec.append(tb.deborah_table(run).html())
    cc = tb.crosscheck_table(run, std)
    if cc is not None:
        sec.append(cc.html())

    # 8. sampler diagnostics
    if run.draws is not None:
        sec.append("<h2>8. Sampler diagnostics</h2>")
        st = tb.sampler_table(run)
        if st is not None:
            sec.append(st.html())
        model_draws = {n: run.draws[n] for n in run.names if n in run.draws}
        p = figs.trace_plot(model_draws, figdir / "trace.png")
        sec.append(img(p, "trace plot", (
            "Trace plot, one row per parameter. Left: the marginal density of all kept draws (grey) and "
            "of the walkers pooled into 8 groups (lines); right: the kept draws of every walker against "
            "the step after burn-in. Walkers that wander off, stay flat (stuck) or groups whose "
            "densities disagree mean the chain is not converged.")))
        tau = (run.summary or {}).get("autocorr_time")
        taus = [float(v) for v in (tau.values() if isinstance(tau, dict) else [tau])
                if isinstance(v, int | float) and np.isfinite(v)]
        thin = max(1, int(np.ceil(max(taus)))) if taus else 1
        p = figs.rank_plot(model_draws, figdir / "rank.png", thin=thin)
        sec.append(img(p, "rank plot", (
            f"Rank plot (ArviZ's plot_rank): walkers thinned by their autocorrelation time ({thin} "
            "steps) and pooled into 8 groups; each line is the ECDF of one group's fractional "
            "ranks minus the uniform one (flat near zero when the groups sample the same "
            "distribution). Above each panel, ArviZ's multi-chain uniformity test: p above α means "
            "no evidence that the groups differ (the ranks that drive a deviation are marked, when "
            "there are any). emcee walkers are not independent chains, so read a small p as a hint, "
            "not a proof.")))

    elapsed = time.perf_counter() - t0
    files = ", ".join(f for f in (RESOLVED_CONFIG, FIT_FILE, SUMMARY_FILE, POSTERIOR_FILE, CHAINS_FILE)
                      if (run_dir / f).exists())
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    sec.append(f"<footer>bayes_dnlr {__version__} · {now} · run directory {html.escape(str(run_dir))} "
               f"({html.escape(files)}) · built in {elapsed:.1f} s · Blaise et al., eq. and figure numbers "
               "refer to the paper.</footer>")
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(run.name)} report</title><style>{CSS}</style></head><body>"
            + "\n".join(sec) + "</body></html>")
    out = run_dir / REPORT_FILE
    write_atomic(out, page)
    return out
