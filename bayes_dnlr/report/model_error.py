"""The report's model-error section: the two analyses of E and what the checks say of them
(docs/model-error.md).

- the interval of E under white noise (the paper's linearized analysis), under the model
  discrepancy (linearized GLS, and the posterior), with the paper's by-hand ±6.5 % as context;
- the discrepancy's hyperparameters: maximum likelihood, prior, posterior;
- the autocorrelation of the residuals (white fit, and whitened by the discrepancy);
- the posterior mean of δ (runs/curves.py), drawn on the residual plot by html.py;
- what summary.json's ``noise`` block says of the noise model, in words (its ``verdict`` key; the
  page keeps the word "verdict" for the checks' verdict).
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from bayes_dnlr.numbers import fmt, fmt_at, fmt_sd, interval, pct, pm
from bayes_dnlr.report import figures as figs
from bayes_dnlr.report.figure_cache import drawn
from bayes_dnlr.report.page_parts import img, para
from bayes_dnlr.report.tables import Table
from bayes_dnlr.runs.curves import Discrepancy
from bayes_dnlr.runs.results import RunResults
from bayes_dnlr.vocabulary import Z90

PAPER_BY_HAND = ("The paper widens Err(E) of A_// at 5e-3 1/s from the linearized 0.47 % to ±6.5 % "
                 "by hand, \"changing E within ±ΔE so that the model curves flank the experimental "
                 "ones\", because its residuals show bias (section 4.1).")
MAX_LAGS = 300


def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation at lags 0..max_lag (FFT, O(n log n))."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = x.size
    f = np.fft.rfft(x, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[: max_lag + 1]
    return acf / acf[0] if acf[0] > 0 else np.zeros(max_lag + 1)


def interval_table(run: RunResults, parameter: str = "E", note: str = "") -> Table | None:
    """The interval of a parameter under white noise and under the discrepancy, side by side: the
    run's analyses (fit.json) beside the run's posterior (``note``: a first line under it)."""
    rec = run.record
    s = run.summary or {}
    rows = []

    def row(label: str, est: float | None, sd: float | None, lo: float | None, hi: float | None) -> None:
        if est is None or sd is None:
            return
        err = sd / abs(est) if est else None
        rows.append([label, fmt_at(est, sd), fmt_sd(sd), interval(lo, hi, sd), pct(err)])

    z = Z90
    white = rec.white if rec is not None else None
    w_est = white.estimate.get(parameter) if white is not None else None
    w_sd = white.sd.get(parameter) if white is not None else None
    if w_est is not None and w_sd is not None:
        row("white noise, linearized (the paper's eq. 32)", w_est, w_sd, w_est - z * w_sd, w_est + z * w_sd)
    gls = rec.generalized if rec is not None else None
    g_est = gls.estimate.get(parameter) if gls is not None else None
    g_sd = gls.sd.get(parameter) if gls is not None else None
    if g_est is not None and g_sd is not None and np.isfinite(g_sd):
        disc = (run.fit or {}).get("discrepancy") or {}
        label = ("with the discrepancy, linearized (the projection θ*, Var θ* + S(h))"
                 if disc.get("target") == "l2" else
                 "with the discrepancy, linearized (GLS under the exp covariance, the kernels' sandwich sd)"
                 if disc.get("projection") else
                 "with the discrepancy, linearized (GLS, Δ = (XᵀK⁻¹X)⁻¹)")
        row(label, g_est, g_sd, g_est - z * g_sd, g_est + z * g_sd)
    post = (s.get("posterior") or {}).get(parameter)
    if post:
        model = run.run_noise or (s.get("noise") or {}).get("model", "white")
        label = ("posterior, with the discrepancy" if model == "discrepancy"
                 else "posterior, white likelihood")
        row(label, post["mean"], post["sd"], *post["hdi_90"])
    if not rows:
        return None
    return Table(["analysis", f"{parameter} (MPa)" if parameter in ("E", "G") else parameter, "sd",
                  "90 % interval", "Err"], rows,
                 f"{parameter}: the two analyses", [n for n in (note, PAPER_BY_HAND) if n],
                 css="num")


def hyper_table(run: RunResults) -> Table | None:
    """σ0, amplitude and length of the test's discrepancy: ML, prior, posterior."""
    own = run.own_fit()
    d = own.discrepancy if own is not None else None
    if not d:
        return None
    noise = (run.summary or {}).get("noise") or {}
    ml = d.get("hyperparameters") or {}
    priors = d.get("priors") or {}
    unit = d.get("axis_unit", "s")
    rows = []
    for key, label, u, prior_key in (("sigma0", "σ0 (white noise)", "MPa", None),
                                     ("amplitude", "δ amplitude", "MPa", "disc_amplitude"),
                                     ("length", "δ length", unit, "disc_length")):
        p = priors.get(prior_key) if prior_key else None
        if p is None:
            prior = "—" if key != "sigma0" else noise.get("sigma0", {}).get("source", "—")
        elif p.get("value") is not None:
            prior = f"fixed at {fmt(p['value'])}"
        else:
            prior = p.get("prior", "") + " (" + ", ".join(f"{k} {fmt(v)}" for k, v in p.items()
                                                          if k != "prior") + ")"
        post = noise.get(key) or {}
        if post.get("sampled"):
            lo, hi = post["hdi_90"]
            cell = f"{pm(post['mean'], post['sd'])} {interval(lo, hi, post['sd'])}"
        else:
            cell = "fixed" if post else "—"
        rows.append([f"{label} ({u})", fmt(ml.get(key)), prior, cell])
    choice = (d.get("kernel_choice") or {}).get("reason")
    chosen = f" (kernel: auto: {choice})" if choice else ""
    notes = [f"Kernel {d.get('kernel')}{chosen} on the {d.get('axis')} axis. Likelihood ratio against "
             f"the white model 2 Δ log L = {fmt(d.get('likelihood_ratio'))}: "
             + ("evidence of model error (> 9.21), the hyperparameters are sampled."
                if d.get("evidence") else "no evidence of model error (≤ 9.21)."
                + (" The amplitude is fixed at 0: the posterior is the white one."
                   if (priors.get("disc_amplitude") or {}).get("value") == 0 else ""))]
    return Table(["hyperparameter", "maximum likelihood (fit)", "prior", "posterior mean ± sd [90 % HDI]"],
                 rows, "The model discrepancy δ", notes)


def noise_section(run: RunResults, figure: Path, disc: Discrepancy | None,
                  resid: np.ndarray | None, note: str = "") -> list[str]:
    """HTML of the section for one test; the ACF figure ``figure`` of ``resid`` (the white fit's
    residuals on the window, in window order) when given; ``note`` under the intervals."""
    out: list[str] = []
    noise = (run.summary or {}).get("noise") or {}
    own = run.own_fit()
    residuals = own.residuals if own is not None else {}
    verdict = noise.get("verdict")
    if verdict is None and own is not None and own.discrepancy:
        verdict = ("The posterior is not sampled yet; the linearized analyses above show how the "
                   "discrepancy moves and widens the interval.")
    elif verdict is None:
        verdict = ("This run has no discrepancy analysis (noise.discrepancy: none): the interval "
                   "assumes the model fits to within white noise."
                   + (" The residuals are not white, so that interval is too narrow."
                      if residuals.get("white") is False else ""))
    resid_white = residuals.get("white")
    cls = "ok" if resid_white else "warn"
    out.append(f'<div class="box {cls}"><b>The noise model.</b> {html.escape(verdict)}</div>')
    for t in (interval_table(run, note=note), hyper_table(run)):
        if t is not None:
            out.append(t.html())
    if resid is not None and resid.size > 3:
        if disc is not None:
            resid = disc.axis.sort(resid)
        series = {"residuals of the white fit": autocorrelation(resid, min(MAX_LAGS, resid.size // 2))}
        step, unit = _step(run)
        if disc is not None:
            series["whitened by the discrepancy"] = autocorrelation(
                disc.whitened, min(MAX_LAGS, disc.whitened.size // 2))[: len(next(iter(series.values())))]
        m = len(next(iter(series.values())))
        lags = np.arange(m) * step
        p = drawn(figs.acf_plot, lags, series, resid.size, figure, xlabel=f"lag ({unit})")
        out.append(img(p, "residual autocorrelation", (
            "Autocorrelation of the residuals against the lag. White residuals stay inside the shaded "
            "band; long positive correlation is the model error the white likelihood ignores. Whitened "
            "by the discrepancy (green) they should fall into the band; what stays outside is model "
            "error the kernel does not describe.")))
    elif own is None:
        out.append(para("No fit.json: no residual autocorrelation."))
    return out


def _step(run: RunResults) -> tuple[float, str]:
    t = run.test
    axis = ((run.summary or {}).get("noise") or {}).get("axis", "time")
    if t is None:
        return 1.0, "samples"
    n = t.model_end
    win = np.asarray(t.window[:n], bool)
    x = np.asarray(t.time if axis == "time" else t.strain_input)[:n][win]
    d = np.diff(np.sort(x))
    d = d[d > 0]
    return (float(np.median(d)), "s" if axis == "time" else "strain") if d.size else (1.0, "samples")
