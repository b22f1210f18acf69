"""The report's sections of the run's parameter vector, one per run whatever its number of tests:
the parameter table, the corner plot against the linearized analysis, the correlations and the
sampler diagnostics. The posterior is always set beside the analysis of its own likelihood
(``RunResults.linearized``: the generalized least squares when the posterior used the model
discrepancy, else the paper's white analysis)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bayes_dnlr.inference.layout import test_of
from bayes_dnlr.report import figures as figs
from bayes_dnlr.report import tables as tb
from bayes_dnlr.report.figure_cache import drawn
from bayes_dnlr.report.page_parts import bullets, img, para
from bayes_dnlr.runs.results import RunResults
from bayes_dnlr.vocabulary import base_name


def truths(run: RunResults, names: list[str]) -> list[float | None] | None:
    """The true values of the run's names (synthetic tests): a test's own name from its truth, a
    shared one only when every test's truth agrees."""
    tests = run.tests
    if not all(v.truth for v in tests.values()):
        return None
    out: list[float | None] = []
    for g in names:
        t, k = test_of(g), base_name(g)
        vals = [tests[t].truth.get(k)] if t else [v.truth.get(k) for v in tests.values()]
        ok = all(x is not None for x in vals) and max(vals) - min(vals) <= 1e-12 * abs(max(vals))
        out.append(vals[0] if ok else None)
    return out


def _uses_gls(run: RunResults) -> bool:
    return run.uses_discrepancy and run.gls() is not None


def parameters_section(run: RunResults, model_error: int) -> list[str]:
    return [tb.parameter_table(run, model_error).html()]


def corner_section(run: RunResults, figdir: Path, title: str) -> list[str]:
    """The posterior of the model parameters with the linearized estimate and ellipses (eq. 32)."""
    names = run.model_names
    if run.draws is not None and all(n in run.draws for n in names):
        samples = np.column_stack([run.draws[n].reshape(-1) for n in names])
        gn = run.linearized()
        est = cov = None
        if gn is not None and gn["covariance"] is not None and all(n in gn["names"] for n in names):
            idx = [gn["names"].index(n) for n in names]
            est = [gn["estimate"][n] for n in names]
            cov = gn["covariance"][np.ix_(idx, idx)]
        true = truths(run, names)
        specs = run.cfg.parameters
        bounds = [specs[base_name(n)].bounds() if base_name(n) in specs else (-np.inf, np.inf)
                  for n in names]
        p = drawn(figs.corner_plot, samples, names, figdir / "corner.png", est, cov, true,
                  linearized_label="GLS" if _uses_gls(run) else "Gauss-Newton", bounds=bounds,
                  aside=True)
        sandwich = bool(((run.fit or {}).get("discrepancy") or {}).get("projection"))
        lin_txt = ("the estimate under model error (generalized least squares under the exp covariance) "
                   "and the 1σ and 2σ ellipses of its linearized covariance under the kernels' model of "
                   "the error (docs/model-error.md, blue)" if _uses_gls(run) and sandwich else
                   "the generalized least-squares estimate and the linearized 1σ and 2σ ellipses of "
                   "Δ = (XᵀK⁻¹X)⁻¹ (eq. 32 with the discrepancy's covariance K, blue)"
                   if _uses_gls(run) else
                   "the Gauss-Newton estimate and the linearized 1σ and 2σ ellipses of Δ = σ0²(XᵀX)⁻¹ "
                   "(eq. 32, blue)")
        return [title, img(p, "corner plot", (
            "Posterior of the free parameters (grey: histograms and the 39 % / 86 % contours) with "
            + lin_txt
            + ("; green: the true values of this synthetic test" if true else "")
            + ". Where the grey contours and the blue ellipses coincide, the linearization holds."))]
    if run.has_posterior:
        return [title, para("posterior.nc is missing or unreadable: no corner plot (summary tables below).")]
    return []


def correlation_section(run: RunResults, number: int, model_error: int) -> list[str]:
    """The posterior correlations beside Δ̃ (eq. 35), and where the two disagree."""
    post_t, lin_ts = tb.correlation_tables(run)
    if not (post_t or lin_ts):
        return []
    sec = [f"<h2>{number}. Correlations: posterior against Δ̃ (eq. 35)</h2>" if post_t else
           f"<h2>{number}. Correlations: the linearized Δ̃ (eq. 35)</h2>"]
    sec.append('<div class="pair">' + "".join(t.html() for t in (post_t, *lin_ts) if t) + "</div>")
    comp = tb.comparison_table(run)
    if comp is None:
        return sec
    sec.append(comp.html())
    found = tb.disagreements(run)
    dis = [d for d in found if d.kind in ("sd", "rho")]
    notes = [d for d in found if d.kind == "mean"]
    white = all((v.own_fit() is not None and v.own_fit().residuals.get("white"))
                for v in run.tests.values())
    if dis:
        sec.append('<div class="box warn"><b>Where the linearization fails</b>'
                   + bullets([d.text for d in dis], "flags") + "</div>")
    elif white:
        sec.append('<div class="box ok">The posterior agrees with the linearized analysis: '
                   f"every sd within {100 * tb.SD_TOLERANCE:.0f} % and every correlation within "
                   f"{tb.RHO_TOLERANCE}.</div>")
    else:
        sec.append('<div class="box">The posterior and the linearized analysis agree (every sd '
                   f"within {100 * tb.SD_TOLERANCE:.0f} %, every correlation within "
                   f"{tb.RHO_TOLERANCE}), but the residuals are not white: the agreement says the "
                   f"posterior is close to Gaussian, not that the model fits. See section {model_error} "
                   "for what the checks say of the intervals.</div>")
    if notes:
        sec.append(bullets([d.text for d in notes]))
    return sec


def sampler_section(run: RunResults, figdir: Path) -> list[str]:
    """The sampler's numbers, the trace plot and the rank plot of every sampled parameter."""
    sec = []
    st = tb.sampler_table(run)
    if st is not None:
        sec.append(st.html())
    sampled = {n: run.draws[n] for n in run.names if n in run.draws}
    p = drawn(figs.trace_plot, sampled, figdir / "trace.png", aside=True)
    sec.append(img(p, "trace plot", (
        "Trace plot, one row per parameter. Left: the marginal density of all kept draws (grey) and "
        "of the walkers pooled into 8 groups (lines); right: the kept draws of every walker against "
        "the step after burn-in. Walkers that wander off, stay flat (stuck) or groups whose "
        "densities disagree mean the chain is not converged.")))
    tau = (run.summary or {}).get("autocorr_time")
    taus = [float(v) for v in (tau.values() if isinstance(tau, dict) else [tau])
            if isinstance(v, int | float) and np.isfinite(v)]
    thin = max(1, int(np.ceil(max(taus)))) if taus else 1
    p = drawn(figs.rank_plot, sampled, figdir / "rank.png", thin=thin, aside=True)
    sec.append(img(p, "rank plot", (
        f"Rank plot (ArviZ's plot_rank): walkers thinned by their autocorrelation time ({thin} "
        "steps) and pooled into 8 groups; each line is the ECDF of one group's fractional "
        "ranks minus the uniform one (flat near zero when the groups sample the same "
        "distribution). Above each panel, ArviZ's multi-chain uniformity test: p above α means "
        "no evidence that the groups differ (the ranks that drive a deviation are marked, when "
        "there are any). emcee walkers are not independent chains, so read a small p as a hint, "
        "not a proof.")))
    return sec
