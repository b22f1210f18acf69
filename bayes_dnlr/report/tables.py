"""A run's results and the report's tables (paper Tables 1-5), as HTML and Markdown.

``load_run`` reads a run directory (config, fit.json, summary.json, posterior.nc, the test data);
the table functions turn it into ``Table`` objects; ``disagreements`` lists, in words, where the
posterior and the linearized analysis (eq. 32-35) differ: sd by more than 15 %, ρ by more than 0.05.
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass, field

import numpy as np

from bayes_dnlr.crosscheck import deborah_max
from bayes_dnlr.numbers import fmt, fmt_at, fmt_sd, interval, pct
from bayes_dnlr.runs.records import TestFit
from bayes_dnlr.runs.results import RunResults
from bayes_dnlr.vocabulary import QUANTITIES, unit

SD_TOLERANCE = 0.15      # posterior sd vs linearized sd, relative
RHO_TOLERANCE = 0.05     # posterior ρ vs linearized ρ, absolute
NAMES_HTML = {k: q.html for k, q in QUANTITIES.items()}


@dataclass
class Table:
    """A small table: header, rows of cells (already formatted strings), a caption and notes."""

    header: list[str]
    rows: list[list[str]]
    caption: str = ""
    notes: list[str] = field(default_factory=list)
    css: str = ""
    html_header: list[str] | None = None   # header with HTML markup (names with sub/superscripts)

    def html(self) -> str:
        head = self.html_header or [html.escape(h) for h in self.header]
        out = [f'<table class="{self.css}">' if self.css else "<table>"]
        if self.caption:
            out.append(f"<caption>{html.escape(self.caption)}</caption>")
        out.append("<thead><tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr></thead><tbody>")
        for row in self.rows:
            cells = []
            for i, c in enumerate(row):
                tag = "th" if i == 0 else "td"
                cls = ' class="flag"' if c.endswith(" ⚑") else (' class="text"' if len(c) > 30 else "")
                cells.append(f"<{tag}{cls}>{c if c.startswith('<') else html.escape(c)}</{tag}>")
            out.append("<tr>" + "".join(cells) + "</tr>")
        out.append("</tbody></table>")
        if self.notes:
            out.append('<p class="note">' + "<br>".join(html.escape(n) for n in self.notes) + "</p>")
        return "\n".join(out)

    def markdown(self) -> str:
        def esc(c: str) -> str:
            return c.replace("|", "\\|")

        lines = []
        if self.caption:
            lines += [f"**{self.caption}**", ""]
        lines.append("| " + " | ".join(esc(h) for h in self.header) + " |")
        lines.append("|" + "---|" * len(self.header))
        lines += ["| " + " | ".join(esc(c) for c in row) + " |" for row in self.rows]
        if self.notes:
            lines += [""] + [f"{n}  " for n in self.notes]
        return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# tables
# ---------------------------------------------------------------------------------------------

def parameter_table(run: RunResults, model_error: int = 5) -> Table:
    """Posterior mean, sd, median, 90 % HDI, ESS, R-hat beside the least-squares estimate ± sd (the
    generalized one when the posterior used the discrepancy) and the truth (``model_error``: the
    number of the page's model-error section)."""
    gn = run.linearized()
    gls = run.uses_discrepancy and run.gls() is not None
    post = (run.summary or {}).get("posterior") or {}
    truth = run.truth or {}
    header = ["parameter", "unit"]
    if post:
        header += ["posterior mean", "sd", "median", "90 % HDI", "ESS bulk", "ESS tail", "R-hat"]
    if gn is not None:
        header += ["least squares (GLS)" if gls else "Gauss-Newton", "± sd",
                   "Err (eq. 33, GLS)" if gls else "Err (eq. 33)"]
    if truth:
        header += ["true value"]
    rows = []
    for n in run.names:
        row = [n, unit(n)]
        prec = (post.get(n) or {}).get("sd") or ((gn or {}).get("sd") or {}).get(n)
        if post:
            s = post.get(n, {})
            hdi = s.get("hdi_90") or [None, None]
            row += [fmt_at(s.get("mean"), prec), fmt_sd(s.get("sd")), fmt_at(s.get("median"), prec),
                    interval(hdi[0], hdi[1], prec), fmt(s.get("ess_bulk"), 3),
                    fmt(s.get("ess_tail"), 3), fmt(s.get("r_hat"), 4)]
        if gn is not None:
            est, sd = gn["estimate"].get(n), (gn["sd"] or {}).get(n)
            if n in gn["err"]:              # the same analysis' Err: null for a value of zero
                err = gn["err"][n]
            else:
                err = None if est in (None, 0) or sd is None else sd / abs(est)
            row += [fmt_at(est, sd if sd else prec), fmt_sd(sd), pct(err)]
        if truth:
            t = truth.get(n)
            cell = fmt_at(t, prec)
            if t is not None and post.get(n, {}).get("hdi_90"):
                lo, hi = post[n]["hdi_90"]
                cell += "" if lo <= t <= hi else " ⚑"
            row.append(cell)
        rows.append(row)
    notes = []
    if post:
        notes.append("HDI: highest-density interval. ESS: effective sample size; R-hat near 1.00 "
                     "(below 1.01) means the walkers agree.")
    if gn is not None and gls:
        notes.append("GLS: the estimate under model error (generalized least squares under the exp "
                     "covariance), with the linearized sd of that estimate under the kernels' model of "
                     "the error and its Err = sd/|estimate| (docs/model-error.md); the paper's white "
                     f"analysis is in section {model_error}.")
    elif gn is not None:
        notes.append("Gauss-Newton: least-squares estimate with the linearized sd √Δ_jj "
                     "(eq. 32, Δ = σ0² (XᵀX)⁻¹).")
    if truth and post:
        notes.append("⚑ on a true value: outside the 90 % HDI (expected for about one parameter in ten).")
    caption = ("Parameters: posterior and least squares" if post and gn is not None else
               "Parameters: posterior" if post else "Parameters: least squares")
    return Table(header, rows, caption, notes, css="num")


def _matrix_table(names: list[str], diagonal: list[str], m: np.ndarray, caption: str) -> Table:
    """A matrix over ``names``: the given diagonal cells, the correlations off it."""
    rows = [[n] + [diagonal[i] if i == j else (fmt(m[i, j], 4) if abs(m[i, j]) < 0.9995
                                               else f"{m[i, j]:.5f}") for j in range(len(names))]
            for i, n in enumerate(names)]
    return Table([""] + list(names), rows, caption, css="num",
                 html_header=[""] + [NAMES_HTML.get(n, n) for n in names])


def _delta_tilde_table(analysis: dict | None, names: list[str], caption: str) -> Table | None:
    """Δ̃ of a linearized analysis (eq. 35: Err in % on the diagonal, ρ off it) over ``names``."""
    if analysis is None or analysis["delta_tilde"] is None:
        return None
    gnames = analysis["names"]
    if not all(n in gnames for n in names):
        return None
    idx = [gnames.index(n) for n in names]
    d = analysis["delta_tilde"][np.ix_(idx, idx)]
    return _matrix_table(names, [pct(d[i, i]) for i in range(len(names))], d, caption)


def correlation_tables(run: RunResults) -> tuple[Table | None, list[Table]]:
    """The posterior correlation matrix, and the linearized Δ̃ (eq. 35: Err in % on the diagonal)
    it is compared with: the generalized analysis's when the posterior used the discrepancy, then
    the paper's white one beside it; the white one alone otherwise."""
    names = run.model_names
    post_t = None
    pc = (run.summary or {}).get("posterior_correlation")
    snames = list((run.summary or {}).get("parameters") or names)
    if pc is not None:
        a = np.asarray(pc, dtype=float)
        idx = [snames.index(n) for n in names if n in snames]
        if a.shape == (len(snames), len(snames)) and len(idx) == len(names):
            post = (run.summary or {}).get("posterior") or {}
            rel = [None if not post.get(n, {}).get("mean") else
                   post[n].get("sd", math.nan) / abs(post[n]["mean"]) for n in names]
            post_t = _matrix_table(names, [pct(r) for r in rel], a[np.ix_(idx, idx)],
                                   "Posterior: sd/mean on the diagonal, correlation off it")
    white = run.gn()
    if run.compared_with_gls:
        tables = [_delta_tilde_table(run.gls(), names, "Linearized Δ̃ (eq. 35) of the estimate under model "
                                                 "error (GLS, the kernels' covariance): Err in % on "
                                                 "the diagonal, ρ off it"),
                  _delta_tilde_table(white, names, "The paper's Δ̃ (eq. 35, white noise): Err in % on "
                                                   "the diagonal, ρ off it")]
    else:
        tables = [_delta_tilde_table(white, names, "Linearized Δ̃ (eq. 35): Err in % on the diagonal, "
                                                   "ρ off it")]
    return post_t, [t for t in tables if t is not None]


@dataclass(frozen=True)
class Disagreement:
    """One place where the posterior and the linearized analysis part."""

    kind: str           # "sd" | "rho" | "mean"
    names: tuple[str, ...]
    posterior: float
    linearized: float
    text: str


def disagreements(run: RunResults) -> list[Disagreement]:
    """Posterior vs linearized: sd differing by more than 15 %, ρ by more than 0.05 (and a mean shift
    beyond half a linearized sd, as a note). Empty without a posterior or a fit."""
    gn = run.linearized()
    post = (run.summary or {}).get("posterior") or {}
    if gn is None or not post or gn["sd"] is None:
        return []
    out: list[Disagreement] = []
    names = [n for n in run.model_names if n in post and n in gn["sd"]]
    for n in names:
        sp, sl = float(post[n]["sd"]), float(gn["sd"][n])
        if sl > 0 and abs(sp / sl - 1) > SD_TOLERANCE:
            word = "larger" if sp > sl else "smaller"
            out.append(Disagreement("sd", (n,), sp, sl, (
                f"{n}: the posterior sd ({fmt(sp)} {unit(n)}) is {abs(sp / sl - 1) * 100:.0f} % {word} than "
                f"the linearized sd ({fmt(sl)} {unit(n)}): the linearization "
                f"{'underestimates' if sp > sl else 'overestimates'} this uncertainty.")))
        mean, est = float(post[n]["mean"]), gn["estimate"].get(n)
        if est is not None and sl > 0 and abs(mean - est) > 0.5 * sl:
            out.append(Disagreement("mean", (n,), mean, est, (
                f"{n}: the posterior mean ({fmt(mean)}) lies {abs(mean - est) / sl:.1f} linearized sd "
                f"from the least-squares estimate ({fmt(est)}): the posterior is skewed or the "
                "prior matters (a note, not a failure).")))
    pc = (run.summary or {}).get("posterior_correlation")
    snames = list((run.summary or {}).get("parameters") or [])
    if pc is not None and gn["correlation"] is not None:
        a = np.asarray(pc, dtype=float)
        g = gn["correlation"]
        for i, n in enumerate(names):
            for m in names[i + 1:]:
                if n not in snames or m not in snames:
                    continue
                rp = float(a[snames.index(n), snames.index(m)])
                rl = float(g[gn["names"].index(n), gn["names"].index(m)])
                if abs(rp - rl) > RHO_TOLERANCE:
                    out.append(Disagreement("rho", (n, m), rp, rl, (
                        f"ρ({n}, {m}): posterior {rp:.3f}, linearized {rl:.3f} (difference "
                        f"{abs(rp - rl):.3f} > {RHO_TOLERANCE}): the linear approximation of the model "
                        "does not describe how these two parameters trade off.")))
    return out


def comparison_table(run: RunResults) -> Table | None:
    """sd and ρ side by side, posterior against linearized, flagged where they disagree."""
    gn = run.linearized()
    post = (run.summary or {}).get("posterior") or {}
    if gn is None or not post or gn["sd"] is None:
        return None
    names = [n for n in run.model_names if n in post and n in gn["sd"]]
    flags = {(d.kind, d.names) for d in disagreements(run)}
    rows = []
    for n in names:
        sp, sl = float(post[n]["sd"]), float(gn["sd"][n])
        f = " ⚑" if ("sd", (n,)) in flags else ""
        rows.append([f"sd({n}) {unit(n)}", fmt(sp), fmt(sl), f"{(sp / sl - 1) * 100:+.1f} %{f}"])
    pc = (run.summary or {}).get("posterior_correlation")
    snames = list((run.summary or {}).get("parameters") or [])
    if pc is not None and gn["correlation"] is not None:
        a = np.asarray(pc, dtype=float)
        for i, n in enumerate(names):
            for m in names[i + 1:]:
                rp = float(a[snames.index(n), snames.index(m)])
                rl = float(gn["correlation"][gn["names"].index(n), gn["names"].index(m)])
                f = " ⚑" if ("rho", (n, m)) in flags else ""
                rows.append([f"ρ({n}, {m})", f"{rp:.4f}", f"{rl:.4f}", f"{rp - rl:+.4f}{f}"])
    lin = ("linearized with the discrepancy (Δ = (XᵀK⁻¹X)⁻¹)" if run.uses_discrepancy and run.gls()
           else "linearized (eq. 32-35)")
    return Table(["quantity", "posterior", lin, "difference"], rows,
                 "Posterior against the linearized analysis",
                 [f"⚑: sd differs by more than {100 * SD_TOLERANCE:.0f} % "
                  f"or ρ by more than {RHO_TOLERANCE}."],
                 css="num")


def residual_words(fit: TestFit | None, sigma0: float | None = None) -> list[str]:
    """A test's residual diagnostics at the run's white estimate (fit.json), in sentences."""
    if fit is None or not fit.residuals:
        return ["No residual diagnostics (fit.json is missing or has no 'residuals')."]
    r = fit.residuals
    n = fit.n_points
    out = []
    if r.get("rms") is not None:
        s = f"RMS of the residuals: {fmt(r['rms'], 3)} MPa"
        if sigma0:
            s += f" for a noise level σ0 = {fmt(sigma0, 3)} MPa (ratio {r['rms'] / sigma0:.2f})"
        out.append(s + ".")
    if r.get("lag1_autocorrelation") is not None:
        a = float(r["lag1_autocorrelation"])
        s = f"Lag-1 autocorrelation {a:.3f}"
        if n:
            lim = 2 / math.sqrt(n)
            s += (f" ({'beyond' if abs(a) > lim else 'within'} ±{lim:.3f}, the 95 % band for white noise "
                  f"of {n} points)")
        out.append(s + ".")
    if r.get("durbin_watson") is not None:
        d = float(r["durbin_watson"])
        judge = ("close to 2, as for independent residuals" if 1.5 <= d <= 2.5 else
                 "well below 2: neighbouring residuals share their sign (signed, wavy residuals "
                 "point to a model or input bias, as in the paper's Fig. 9)" if d < 1.5 else
                 "well above 2: residuals alternate in sign")
        out.append(f"Durbin-Watson statistic {d:.3f}, {judge}.")
    rt = r.get("runs_test")
    if isinstance(rt, dict) and rt:
        parts = ", ".join(f"{k.replace('_', ' ')} {fmt(v, 3) if isinstance(v, (int, float)) else v}"
                          for k, v in rt.items() if not isinstance(v, (dict, list)))
        out.append(f"Runs test of the residual signs: {parts}.")
    if r.get("white") is False:
        out.append("The residuals are not white noise: the linearized uncertainties (and a posterior "
                   "with a white-noise likelihood) are then optimistic.")
    elif r.get("white") and not r.get("verdict"):
        out.append("The residuals look like white noise.")
    if r.get("verdict"):
        out.append(f"Residuals: {r['verdict']}")
    if fit.rms_alone is not None:
        out.append(f"RMS of this test's residuals at its own estimate (fitted alone): "
                   f"{fmt(fit.rms_alone, 3)} MPa; above: at the run's estimate, shared with the other tests.")
    return out


def standards_table(run: RunResults, results: dict | None) -> Table:
    """ISO 527-1 and ASTM D638 beside E with the ratio (paper Tables 1 and 4) and De_max (eq. 45)."""
    e_mean, e_sd, src = e_model(run)
    std = dict((run.summary or {}).get("standards") or {})
    rows = []
    label = {"iso527_1": "ISO 527-1 (0.05-0.25 %)", "astm_d638": "ASTM D638 (toe-compensated)"}
    for key in ("iso527_1", "astm_d638"):
        r = (results or {}).get(key)
        val = std.get(key)
        if val is None and r is not None:
            val = r.modulus
        how = _standard_how(r) if r is not None else ("from summary.json" if val is not None
                                                      else "not available")
        ratio = "–" if val is None or not e_mean else f"{val / e_mean:.3f}"
        if val is not None and e_mean and val > e_mean:
            ratio += " ⚑"
        rows.append([label[key], fmt(val), ratio, how])
    rows.append([f"E, model ({src})", fmt_at(e_mean, e_sd), "1", f"± {fmt_sd(e_sd)} MPa" if e_sd else ""])
    notes = ["Ratio: standard modulus / E. The paper's Table 1 and 4 find 1138 (ISO) and 1141 (ASTM) "
             "against E = 2830 MPa (ratio 0.40) for HDPE at 5 mm/min: the standards measure an apparent "
             "modulus that depends on the test speed, not the instantaneous modulus."]
    above = standards_above_e(run, results)
    if above:
        notes.append("⚑ " + above)
    return Table(["method", "modulus (MPa)", "ratio to E", "how"], rows,
                 "Standards on the same curve against the model's E", notes, css="num")


def standards_above_e(run: RunResults, results: dict | None) -> str | None:
    """A remark when a standard modulus exceeds the model's instantaneous E (None otherwise)."""
    e_mean, _, src = e_model(run)
    if not e_mean:
        return None
    std = dict((run.summary or {}).get("standards") or {})
    above = []
    for key, label in (("iso527_1", "ISO 527-1"), ("astm_d638", "ASTM D638")):
        val = std.get(key)
        if val is None and (results or {}).get(key) is not None:
            val = results[key].modulus
        if val is not None and val > e_mean:
            above.append(f"{label} {fmt(val)} MPa")
    if not above:
        return None
    return (f"{' and '.join(above)} above the model's instantaneous E = {fmt(e_mean)} MPa ({src}): a "
            "modulus measured at a finite strain rate cannot exceed the instantaneous modulus of a "
            "viscoelastic solid. Either E is underestimated (E and tau_max trade off on this window: "
            "read ρ(E, tau_max) and Err), or the standard's strain range is distorted (a toe, a cropped "
            "or preloaded start, few or noisy samples: see how it was computed).")


def _standard_how(r) -> str:
    """How a standard modulus was obtained (StandardModulus), without the value."""
    if r.modulus is None:
        return f"not available: {r.reason}"
    lo, hi = r.strain_range
    if r.method == "chord":       # two stresses interpolated at the range's ends, not samples
        text = (f"chord between the stresses interpolated at nominal strains {100 * lo:.3f} % and "
                f"{100 * hi:.3f} %")
    else:
        text = f"{r.method}, nominal strain {100 * lo:.3f}-{100 * hi:.3f} %, {r.n_points} samples"
    if r.standard == "ASTM D638":
        text += f", corrected zero at {100 * r.corrected_zero:.4f} %"
    return text + (f" ({r.reason})" if r.reason else "")


def e_model(run: RunResults) -> tuple[float | None, float | None, str]:
    """E of the model: posterior mean and sd, else the Gauss-Newton estimate and sd."""
    post = (run.summary or {}).get("posterior") or {}
    if "E" in post:
        return float(post["E"]["mean"]), float(post["E"]["sd"]), "posterior mean"
    gn = run.gn()
    if gn is not None and "E" in gn["estimate"]:
        return gn["estimate"]["E"], (gn["sd"] or {}).get("E"), "Gauss-Newton"
    fixed = run.cfg.fixed_values.get("E")
    return fixed, None, "fixed"


def deborah(run: RunResults) -> tuple[float | None, float | None, str]:
    """De_max = tau_max · ε̇ (eq. 45): (value, sd, the estimate of tau_max it uses, in words)."""
    rate = run.strain_rate()
    if rate is None:
        return None, None, "no strain rate"
    if run.draws is not None and "tau_max" in run.draws:
        d = run.draws["tau_max"].ravel() * rate
        return float(np.mean(d)), float(np.std(d)), "posterior mean"
    v = (run.summary or {}).get("deborah_max_posterior")
    if isinstance(v, dict) and v.get("mean") is not None:
        return float(v["mean"]), v.get("sd"), "posterior mean"
    own = run.own_fit()
    if own is not None and own.deborah_max is not None:
        return own.deborah_max, None, "white least squares"
    tau = run.point().get("tau_max")
    return ((None, None, "no tau_max") if tau is None else
            (deborah_max(tau, rate), None, "least squares" + (" under model error" if run.uses_discrepancy
                                                              else "")))


def deborah_table(run: RunResults) -> Table:
    rate = run.strain_rate()
    de, de_sd, src = deborah(run)
    tau = de / rate if de is not None and rate else None        # the same estimate's tau_max
    rows = [["strain rate ε̇ (1/s)", fmt(rate, 3)], [f"tau_max (s), {src}", fmt(tau)],
            ["De_max = tau_max·ε̇", fmt(de, 3) + (f" ± {fmt(de_sd, 2)}" if de_sd else "")]]
    return Table(["quantity", "value"], rows, "Deborah number (eq. 45)",
                 [f"De_max from the {src} of tau_max. The paper's Table 5: about 0.03 for HDPE at 2.5e-3 "
                  "to 1e-2 1/s: the material's longest relaxation time is two decades below the test's "
                  "time scale."],
                 css="num")


def sampler_table(run: RunResults) -> Table | None:
    s = run.summary
    if not s:
        return None
    rows = [["walkers", fmt(s.get("walkers"), 6)], ["steps", fmt(s.get("steps"), 8)]]
    tau = s.get("autocorr_time")
    if isinstance(tau, dict):
        rows.append(["autocorrelation time (steps)",
                     ", ".join(f"{k} {fmt(v, 3)}" for k, v in tau.items())])
    elif tau is not None:
        rows.append(["autocorrelation time (steps)", fmt(tau, 3)])
    s0 = s.get("sigma0")
    sigma_txt = (", ".join(f"{t} {fmt(v, 3)}" for t, v in s0.items()) if isinstance(s0, dict)
                 and not {"mean", "value"} & set(s0) else fmt(run.sigma0(), 3))   # per test: a joint run
    rows += [["wall time (s)", fmt(s.get("wall_time_s"), 3)], ["n points (q)", fmt(s.get("n_points"), 8)],
             ["σ0 (MPa)", sigma_txt]]
    return Table(["", "value"], rows, "Sampler", css="num")
