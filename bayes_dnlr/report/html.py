"""The self-contained report: run_dir/report.html (figures embedded as base64 PNG) and run_dir/figures/.

``build_report(run_dir)`` reads what the run directory holds: with only fit.json it shows the fit part
and says that the posterior is missing; with summary.json and posterior.nc it adds the corner plot,
the posterior predictive band, the posterior/linearized comparison and the ArviZ diagnostics.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayes_dnlr import __version__
from bayes_dnlr.inference.plausibility import plausibility_warnings
from bayes_dnlr.model.spectrum import UNIVERSAL_EXPONENT
from bayes_dnlr.numbers import fmt, interval, pm
from bayes_dnlr.report import figures as figs
from bayes_dnlr.report import noise as rn
from bayes_dnlr.report import tables as tb
from bayes_dnlr.report import views
from bayes_dnlr.report.tables import RunResults, load_run

N_DRAWS = 200          # posterior draws pushed through the model for the bands


@dataclass
class Curves:
    """Model curves on the data grid (up to the last window sample)."""

    x: np.ndarray
    xlabel: str
    data: np.ndarray
    window: np.ndarray
    strain: np.ndarray
    median: np.ndarray | None = None
    band: tuple[np.ndarray, np.ndarray] | None = None
    predictive: tuple[np.ndarray, np.ndarray] | None = None
    gn_curve: np.ndarray | None = None
    sensitivities: dict[str, np.ndarray] | None = None


def _model(run: RunResults):
    from bayes_dnlr.model import DNLR

    t = run.test
    n = t.model_end
    return DNLR(t.time[:n], t.strain_input[:n], run.cfg.model.modes, run.cfg.model.decades,
                t.relaxation_start), n


def _stress(basis_values: np.ndarray, p: dict[str, float]) -> np.ndarray:
    s = p["E"] * basis_values[:, 0] + p["G"] * basis_values[:, 1]
    if "sigma_inf" in p:
        s = s + p["sigma_inf"] * basis_values[:, 2]
    return s


def _basis(model, p: dict[str, float], grad: bool = False):
    """The model's basis at the time constants and spectrum exponent of ``p``."""
    return model.basis(p["tau_max"], p.get("tau_max_R"), grad=grad,
                       alpha=p.get("alpha", UNIVERSAL_EXPONENT))


def _model_names(model) -> list[str]:
    """The model's parameters, the optional spectrum exponent included."""
    return [*model.parameter_names(), "alpha"]


def sensitivities(model, params: dict[str, float], names: list[str]) -> dict[str, np.ndarray]:
    """Normalised sensitivities X̃_j = β_j ∂σ/∂β_j (eq. 37), MPa, on the model grid."""
    b = _basis(model, params, grad=True)
    out = {}
    for n in names:
        if n in ("E", "G", "sigma_inf"):
            out[n] = params[n] * b.values[:, {"E": 0, "G": 1, "sigma_inf": 2}[n]]
        elif n in ("tau_max", "tau_max_R"):
            g = b.grad_tau_max if n == "tau_max" else b.grad_tau_max_R
            if g is not None:
                out[n] = _stress(g, params)   # ∂σ/∂ln tau = tau ∂σ/∂tau
        elif n == "alpha":
            out[n] = params[n] * _stress(b.grad_alpha, params)
    return out


def run_white_curve(run: RunResults, curves: Curves) -> np.ndarray:
    """The white least-squares fit (fit.json's estimate) on the data grid."""
    gn = run.gn()
    if gn is None:
        return curves.gn_curve
    model, _ = _model(run)
    p = dict(run.cfg.fixed_values)
    p.update(gn["estimate"])
    return _stress(_basis(model, p).values, p)


def model_curves(run: RunResults, n_draws: int = N_DRAWS, seed: int = 0) -> Curves:
    """Data, posterior median and 90 % bands (credible and predictive), the GN curve, sensitivities."""
    t = run.test
    model, n = _model(run)
    relax = t.relaxation_start is not None
    x = t.time[:n] if relax else t.strain_input[:n]
    c = Curves(x=x, xlabel="time (s)" if relax else r"true strain $\varepsilon_{11}$",
               data=np.asarray(t.stress[:n], dtype=float), window=np.asarray(t.window[:n], bool),
               strain=np.asarray(t.strain_input[:n], dtype=float))
    fixed = run.cfg.fixed_values
    point = run.point()
    if all(k in point for k in model.parameter_names()):
        if run.gn() is not None:
            c.gn_curve = _stress(_basis(model, point).values, point)
        c.sensitivities = sensitivities(model, point, [k for k in _model_names(model)
                                                       if k in run.model_names])
    if run.draws is not None and all(k in run.draws or k in fixed for k in model.parameter_names()):
        rng = np.random.default_rng(seed)
        total = next(iter(run.draws.values())).size
        pick = rng.choice(total, size=min(n_draws, total), replace=False)
        flat = {k: v.reshape(-1)[pick] for k, v in run.draws.items()}
        sig = flat.get("sigma0")
        s0 = run.sigma0()
        curves = np.empty((pick.size, n))
        for i in range(pick.size):
            p = dict(fixed)
            p.update({k: float(flat[k][i]) for k in _model_names(model) if k in flat})
            curves[i] = _stress(_basis(model, p).values, p)
        c.median = np.median(curves, axis=0)
        lo, hi = np.quantile(curves, [0.05, 0.95], axis=0)
        c.band = (lo, hi)
        # predictive band: model spread, noise and model discrepancy combined as a normal (a smooth
        # band; 200 replicates per point would make it ragged): mean ± 1.645 sqrt(var_model + E[σ0²]
        # (+ E[a²] with the discrepancy))
        s2 = float(np.mean(sig**2)) if sig is not None else (s0**2 if s0 is not None else 0.0)
        if run.uses_discrepancy:
            # the model error enters the prediction too: var(δ) = a² at every point
            amp = flat.get("disc_amplitude")
            fixed_amp = (((run.summary or {}).get("noise") or {}).get("amplitude") or {}).get("value", 0.0)
            s2 += float(np.mean(amp**2)) if amp is not None else float(fixed_amp) ** 2
        half = 1.6448536269514722 * np.sqrt(curves.var(axis=0) + s2)
        mean = curves.mean(axis=0)
        plo, phi = mean - half, mean + half
        c.predictive = (plo, phi)
    return c


# ---------------------------------------------------------------------------------------------

CSS = """
body{font-family:-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;color:#222;max-width:1080px;
margin:0 auto;padding:24px 28px 60px;line-height:1.45;background:#fff}
h1{font-size:1.7em;margin:0 0 4px}h2{font-size:1.3em;margin:34px 0 10px;border-bottom:1px solid #ddd;
padding-bottom:4px}h3{font-size:1.05em;margin:20px 0 6px}
.meta{color:#666;font-size:.9em;margin-bottom:18px}
.box{background:#f5f7fa;border:1px solid #dde3ea;border-radius:6px;padding:12px 16px;margin:14px 0}
.warn{background:#fff6e5;border-color:#f0c36d}.bad{color:#a61b1b;font-weight:600}.ok{background:#eef8f0;border-color:#a6d8b0}
table{border-collapse:collapse;margin:10px 0 6px;font-size:.92em}
caption{text-align:left;font-weight:600;padding:4px 0;color:#333}
th,td{border:1px solid #d8dde3;padding:4px 9px}thead th{background:#eef1f5}
tbody th{text-align:left;font-weight:600;background:#fafbfc}
table.num td{text-align:right;font-variant-numeric:tabular-nums}
td.flag{background:#fde2d4;font-weight:600}
table.num td{white-space:nowrap}table.num td.text{white-space:normal;text-align:left}
.pair{display:flex;gap:28px;flex-wrap:wrap;align-items:flex-start}
figure{margin:14px 0 22px}figure img{max-width:100%;border:1px solid #eee}
figcaption{color:#444;font-size:.92em;margin-top:4px}
.note{color:#555;font-size:.88em;margin:2px 0 12px}
ul.flags li{margin:4px 0}code{background:#f1f3f5;padding:1px 4px;border-radius:3px}
footer{margin-top:40px;color:#888;font-size:.85em;border-top:1px solid #eee;padding-top:8px}
"""


def _img(path: Path, alt: str, caption: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return (f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{caption}</figcaption></figure>")


def _p(text: str) -> str:
    return f"<p>{html.escape(text)}</p>"


def _ul(items: list[str], cls: str = "") -> str:
    c = f' class="{cls}"' if cls else ""
    return f"<ul{c}>" + "".join(f"<li>{html.escape(i)}</li>" for i in items) + "</ul>"


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
    figdir = run_dir / "figures"
    figdir.mkdir(exist_ok=True)
    for old in figdir.glob("*.png"):     # figures of an earlier report that may not apply any more
        old.unlink()
    if run.cfg.is_joint:
        from bayes_dnlr.report.joint import build_joint_report

        out = run_dir / "report.html"
        out.write_text(build_joint_report(run, figdir, t0), encoding="utf-8")
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
        sec.append('<div class="box warn"><b>Warnings</b>' + _ul(warns) + "</div>")

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
        sec.append(_img(p, "corner plot", (
            "Posterior of the free parameters (grey: histograms and the 39 % / 86 % contours) with "
            + lin_txt
            + ("; green: the true values of this synthetic test" if truths else "")
            + ". Where the grey contours and the blue ellipses coincide, the linearization holds.")))
    elif run.has_posterior:
        sec.append("<h2>2. Posterior and its linearization</h2>")
        sec.append(_p("posterior.nc is missing or unreadable: no corner plot (summary tables below)."))

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
                           + _ul([d.text for d in dis], "flags") + "</div>")
            elif (run.fit or {}).get("residuals", {}).get("white"):
                sec.append('<div class="box ok">The posterior agrees with the linearized analysis: '
                           f"every sd within {100 * tb.SD_TOLERANCE:.0f} % and every correlation within "
                           f"{tb.RHO_TOLERANCE}.</div>")
            else:
                sec.append('<div class="box">The posterior and the linearized analysis agree (every sd '
                           f"within {100 * tb.SD_TOLERANCE:.0f} %, every correlation within "
                           f"{tb.RHO_TOLERANCE}), but the residuals are not white: the agreement says the "
                           "posterior is close to Gaussian, not that the model fits. See section 5 for "
                           "which uncertainty to believe.</div>")
            if notes:
                sec.append(_ul([d.text for d in notes]))

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
        sec.append(_img(p, "fit and residuals", (
            f"Data (grey dots) and {what}; the dashed blue line is the least-squares fit"
            + (f"; {inset.caption}" if inset else "") + ". Residuals "
            "(data - model) below, with ±σ0 dotted: without model bias they scatter evenly around zero "
            "(paper Figs 6-10).")))
    else:
        sec.append(_p("No fit figure: the test data could not be loaded."))
    fit_sigma0 = (run.fit or {}).get("sigma0", run.sigma0())   # the white analysis' own σ0
    sec.append("<h3>Residual diagnostics of the white fit (fit.json)</h3>"
               + _ul(tb.residual_words(run.fit, fit_sigma0)))

    # 5. model error
    sec.append("<h2>5. Model error: which uncertainty to believe</h2>")
    white_resid = None
    if curves is not None and curves.gn_curve is not None:
        white_resid = (curves.data - run_white_curve(run, curves))[curves.window]
    sec += rn.noise_section(run, figdir, disc if curves is not None else None, white_resid)

    # 6. sensitivities
    if curves is not None and curves.sensitivities:
        sec.append("<h2>6. Sensitivities (eq. 37)</h2>")
        p = figs.sensitivity_plot(curves.x, curves.sensitivities, figdir / "sensitivity.png",
                                  window=curves.window, xlabel=curves.xlabel)
        sec.append(_img(p, "sensitivities", (
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
            sec.append(_img(p, "X(E) against X(tau_max)", view.caption))

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
        sec.append(_img(p, "trace plot", (
            "Trace plot, one row per parameter. Left: the marginal density of all kept draws (grey) and "
            "of the walkers pooled into 8 groups (lines); right: the kept draws of every walker against "
            "the step after burn-in. Walkers that wander off, stay flat (stuck) or groups whose "
            "densities disagree mean the chain is not converged.")))
        tau = (run.summary or {}).get("autocorr_time")
        taus = [float(v) for v in (tau.values() if isinstance(tau, dict) else [tau])
                if isinstance(v, int | float) and np.isfinite(v)]
        thin = max(1, int(np.ceil(max(taus)))) if taus else 1
        p = figs.rank_plot(model_draws, figdir / "rank.png", thin=thin)
        sec.append(_img(p, "rank plot", (
            f"Rank plot (ArviZ's plot_rank): walkers thinned by their autocorrelation time ({thin} "
            "steps) and pooled into 8 groups; each line is the ECDF of one group's fractional "
            "ranks minus the uniform one (flat near zero when the groups sample the same "
            "distribution). Above each panel, ArviZ's multi-chain uniformity test: p above α means "
            "no evidence that the groups differ (the ranks that drive a deviation are marked, when "
            "there are any). emcee walkers are not independent chains, so read a small p as a hint, "
            "not a proof.")))

    elapsed = time.perf_counter() - t0
    files = ", ".join(f for f in ("config.yaml", "fit.json", "summary.json", "posterior.nc", "chains.h5")
                      if (run_dir / f).exists())
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    sec.append(f"<footer>bayes_dnlr {__version__} · {now} · run directory {html.escape(str(run_dir))} "
               f"({html.escape(files)}) · built in {elapsed:.1f} s · Blaise et al., eq. and figure numbers "
               "refer to the paper.</footer>")
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(run.name)} report</title><style>{CSS}</style></head><body>"
            + "\n".join(sec) + "</body></html>")
    out = run_dir / "report.html"
    out.write_text(page, encoding="utf-8")
    return out
