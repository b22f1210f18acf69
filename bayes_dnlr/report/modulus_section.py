"""The report's E(t): the relaxation modulus the data determine, in the headline beside E and in a
section of its own (its figure, its times, its trust), for every test.

E(t) is read from summary.json's ``modulus_at`` and its curve from ``modulus_curve`` (runs/modulus_block.py
makes both; the report imports no model code): the band over the times the test resolves, its
dashed continuation to t → 0 the extrapolation that E is (eq. 11-14).
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.numbers import fmt, interval, pm
from bayes_dnlr.report.figure_cache import drawn
from bayes_dnlr.report.page_parts import bullets, img, para
from bayes_dnlr.runs.modulus_view import curves, entries, reference
from bayes_dnlr.runs.results import RunResults

WHAT_E_IS = ("E is E(t) extrapolated to t → 0 through the fast end of Cunat's spectrum (eq. 12), "
             "which no tensile test observes; E(t) inside the times the test resolves is what its "
             "data determine.")


def rows_of(run: RunResults) -> dict[str, list[dict]]:
    """Each test's E(t) rows (a run with one test under its name)."""
    found = entries(run.summary or {})
    if "" in found:
        return {run.cfg.test_names[0]: found[""]}
    return found


def headline_words(run: RunResults) -> str:
    """The headline's sentence on E(t): each test's values with their trust, then what E is."""
    rows = rows_of(run)
    if not rows:
        return ""
    several = len(rows) > 1
    parts = []
    for t, rs in rows.items():
        for r in rs:
            who = f"{html.escape(t)}: " if several else ""
            mark = ('<span class="good">trusted</span>' if r.get("trust") else
                    '<span class="bad">not trusted (below)</span>')
            lo, hi = r["hdi_90"]
            at = f" at {r['temperature']:g} °C" if r.get("temperature") is not None else ""
            parts.append(f"{who}<b>E({fmt(r['t'], 3)} s){at} = {pm(r['mean'], r['sd'])} MPa</b> "
                         f"(90 % HDI {interval(lo, hi, r['sd'])}), {mark}")
    text = ("The modulus the data determine, the relaxation modulus at the shortest time the "
            "test resolves: " + "; ".join(parts) + ". ")
    ref = reference(run.summary or {})
    trusted = [r for r in (ref or {}).get("rows") or [] if r.get("trust")]
    if ref and ref.get("rows"):
        shown = trusted or ref["rows"][:1]
        text += (f"At the reference temperature, {ref['temperature']:g} °C (the master curve, below): "
                 + "; ".join(f"<b>E({fmt(r['t'], 3)} s) = {pm(r['mean'], r['sd'])} MPa</b> from "
                             f"{html.escape(str(r.get('test')))}" for r in shown[:3])
                 + ("" if trusted else ", not trusted") + ". ")
    return text + html.escape(WHAT_E_IS)


def consistency_box(run: RunResults) -> str:
    """A run with several tests: whether they agree, fitted alone (summary.json ``consistency``);
    amber when they do not, so that a shared E is never read without it."""
    block = (run.summary or {}).get("consistency")
    if not block:
        return ""
    css = "ok" if block.get("agree") else "warn"
    return (f'<div class="box {css}"><b>One material?</b> {html.escape(block.get("words") or "")}'
            "</div>")


def trust_box(run: RunResults) -> str:
    """Under the headline: green when every E(t) is trusted, amber with the reasons otherwise."""
    rows = rows_of(run)
    if not rows:
        return ""
    reasons = [x for rs in rows.values() for r in rs for x in r.get("trust_reasons") or []]
    if not reasons:
        return ('<div class="box ok"><b>E(t)</b>: its checks pass (the band where it draws its '
                "information, the start of the curve, the prior): quote E(t) with its interval."
                "</div>")
    return ('<div class="box warn"><b>E(t)</b>: do not use its interval as it is.'
            + bullets(reasons) + "</div>")


def _curve_of(run: RunResults, test: str) -> dict | None:
    """The stored E(t) curve of a test (summary.json ``modulus_curve``)."""
    found = curves(run.summary or {})
    return found.get("") if "" in found else found.get(test)


def _chords(view: RunResults, rows: list[dict]) -> list[tuple[str, float, float, float]]:
    """The ISO 527-1 modulus to place on the figure, over the times the loading takes between its
    two strains (the start check's; ASTM D638's window moves with the curve, so it is left out)."""
    start = next((r["checks"].get("start") for r in rows if r["checks"].get("start")), None)
    if not start:
        return []
    t1, t2 = start["times"]
    return [(start.get("standard", "ISO 527-1"), float(start["data_chord"]), t1, t2)]


def section(run: RunResults, figdir: Path) -> list[str]:
    """The E(t) section: per test, the figure and a table of its times with their checks."""
    rows = rows_of(run)
    if not rows:          # no posterior yet (the fit's linearized E(t) is in the fit's console)
        return []
    sec = [para(WHAT_E_IS + " A constant-rate loading's slope at strain ε is close to E(ε/ε̇), so a "
                "curve sampled every Δt over a duration T measures E(t) for t between a few Δt and "
                "T. Quote E(t) where its checks pass; E with its own verdict.")]
    several = len(rows) > 1
    for t, rs in rows.items():
        view = run.of_test(t)
        if several:
            sec.append(f"<h3>{html.escape(t)}</h3>")
        curve = _curve_of(run, t)
        if curve is not None and rs:
            suffix = "" if not several else "-" + "".join(c if c.isalnum() else "_" for c in t)
            q = np.array([curve["q05"], curve["q50"], curve["q95"]], dtype=float)  # null: NaN
            marks = [(r["t"], r["mean"], *r["hdi_90"], bool(r.get("trust"))) for r in rs]
            p = drawn(modulus_plot, np.asarray(curve["t"]), q, tuple(curve["resolved"]),
                      float(curve["E_median"]), tuple(curve["E_hdi_90"]), _chords(view, rs), marks,
                      figdir / f"modulus{suffix}.png")
            chord = ("the ISO 527-1 chord over the times the loading takes from 0.05 to 0.25 % strain"
                     if _standard(rs) == "ISO 527-1" else f"the {_standard(rs)} slope over the times "
                     "the loading takes across its window")
            sec.append(img(p, "E(t)", (
                "E(t), the relaxation modulus of the identified model: posterior median and 90 % "
                "band over the times the test resolves (solid), its continuation to t → 0 (dashed: "
                "an extrapolation through the spectrum's fast end) ending at E (left, with its 90 % "
                f"HDI); the reported times (dots: filled when trusted); {chord} (bar): the mean of "
                "E(t) there.")))
        sec.append(_table(rs))
    return sec + _master_curve(run, figdir)


def _master_curve(run: RunResults, figdir: Path) -> list[str]:
    """Tests at several temperatures: E(t) at the reference temperature over their reduced
    windows (runs/master_curve.py), its figure and its table."""
    ref = reference(run.summary or {})
    if not ref or not ref.get("rows"):
        return []
    curve, rows = ref["curve"], ref["rows"]
    temp = f"{ref['temperature']:g} °C"
    spans = "; ".join(f"{html.escape(t)} at {w['temperature']:g} °C: {fmt(w['reduced'][0], 3)}-"
                      f"{fmt(w['reduced'][1], 3)} s (a_T = {fmt(w['a_T'], 3)})"
                      for t, w in ref["windows"].items())
    q = np.array([curve["q05"], curve["q50"], curve["q95"]], dtype=float)  # null: NaN
    marks = [(r["t"], r["mean"], *r["hdi_90"], bool(r.get("trust"))) for r in rows]
    p = drawn(modulus_plot, np.asarray(curve["t"]), q, tuple(curve["resolved"]),
              float(curve["E_median"]), tuple(curve["E_hdi_90"]), [], marks,
              figdir / "modulus-reference.png",
              tuple(tuple(w["reduced"]) for w in ref["windows"].values()),
              f"reduced time at {temp} (s)")
    return [f"<h3>The master curve: E(t) at {temp}</h3>",
            para(f"Each test at temperature T resolves E(t) at T over its times; the run's "
                 f"temperature law ({html.escape(ref['law'])}) maps them to {temp}, divided by a_T(T). "
                 f"The tests' windows in reduced time: {spans}. Each time below comes from the "
                 "test whose window holds it."),
            img(p, "E(t) at the reference temperature", (
                f"E(t) at {temp}: median and 90 % band over the union of the tests' reduced windows "
                "(solid), the extrapolation beyond them (dashed), the reported times (dots: filled "
                "when trusted).")),
            _table(rows)]


def _standard(rows: list[dict]) -> str:
    """Whose slope the start check compares: ISO 527-1's chord, or ASTM D638's on a curve that
    starts past 0.05 % strain (a cropped toe: inference/checks/start.py)."""
    start = next((s for r in rows if (s := (r.get("checks") or {}).get("start"))), None) or {}
    return start.get("standard", "ISO 527-1")


def _what(rows: list[dict]) -> str:
    return "ISO 527-1 chord" if _standard(rows) == "ISO 527-1" else f"{_standard(rows)} slope"


def _table(rows: list[dict]) -> str:
    head = ("<table class='num'><thead><tr><th>t (s)</th><th>E(t) (MPa)</th><th>90 % HDI</th>"
            f"<th>band where it is measured</th><th>start ({_what(rows)}, data / model)</th>"
            "<th>trust</th></tr></thead><tbody>")
    body = []
    for r in rows:
        c = r["checks"]
        band = c.get("band")
        band_txt = (f"{100 * band['share']:.0f} % (≥ {100 * max(band['floor'], 0):.0f} %)"
                    if band else "–")
        st = c.get("start")
        st_txt = (f"{fmt(st['data_chord'])} / {fmt(st['model_chord'])} ({st['z']:+.1f} sd)" if st else "–")
        lo, hi = r["hdi_90"]
        trust = "yes" if r.get("trust") else "no"
        cls = "" if r.get("trust") else " class='flag'"
        body.append(f"<tr><td>{fmt(r['t'], 3)}</td><td>{pm(r['mean'], r['sd'])}</td>"
                    f"<td>{interval(lo, hi, r['sd'])}</td><td>{band_txt}</td><td>{st_txt}</td>"
                    f"<td{cls}>{trust}</td></tr>")
    why = rows[0].get("why") if rows else None
    note = f"<p class='note'>Times: {html.escape(why)}.</p>" if why else ""
    return head + "".join(body) + "</tbody></table>" + note


def modulus_plot(grid: np.ndarray, q: np.ndarray, resolved: tuple[float, float], e_median: float,
                 e_hdi: tuple[float, float], chords: list[tuple[str, float, float, float]],
                 marks: list[tuple[Any, ...]], path: Path,
                 spans: tuple[tuple[float, float], ...] = (),
                 xlabel: str = "t (s after the loading began)") -> Path:
    """E(t) against log t: the band inside the resolved times, dashed outside, E at the left edge,
    the standards' moduli as bars over their times, the reported times as dots."""
    from bayes_dnlr.report.canvas import new_figure, save_figure
    from bayes_dnlr.report.figures import C_GN, C_MODEL, C_TRUTH

    fig = new_figure(figsize=(7.2, 4.2))
    ax = fig.add_subplot(1, 1, 1)
    lo, hi = resolved
    inside = (grid >= lo * (1 - 1e-9)) & (grid <= hi * (1 + 1e-9))
    ax.fill_between(grid[inside], q[0][inside], q[2][inside], color=C_MODEL, alpha=0.25, lw=0,
                    label="E(t), 90 % band (resolved times)")
    ax.plot(grid[inside], q[1][inside], color=C_MODEL, lw=1.8, label="E(t), posterior median")
    before = grid <= lo
    ax.plot(grid[before], q[1][before], color=C_MODEL, lw=1.2, ls="--",
            label="extrapolation to t → 0")
    ax.fill_between(grid[before], q[0][before], q[2][before], color=C_MODEL, alpha=0.08, lw=0)
    left = grid[0]
    ax.errorbar([left], [e_median], yerr=[[e_median - e_hdi[0]], [e_hdi[1] - e_median]], fmt="s",
                color=C_MODEL, capsize=3, ms=5, label="E = E(0), 90 % HDI")
    for i, (label, value, t1, t2) in enumerate(chords):
        ax.plot([max(t1, grid[0]), t2], [value, value], color=(C_GN, C_TRUTH)[i % 2], lw=3,
                solid_capstyle="butt", label=f"{label} ({value:.0f} MPa)")
    for t, mean, low, high, trusted in marks:
        ax.errorbar([t], [mean], yerr=[[mean - low], [high - mean]], fmt="o", color="k",
                    mfc="k" if trusted else "w", capsize=3, ms=5)
    for a, b in spans or ((lo, hi),):          # the windows that resolve E(t), shaded
        ax.axvspan(a, b, color="0.9", zorder=-1, lw=0)
    ax.set_xscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("E(t) (MPa)")
    ax.legend(fontsize=8, loc="upper right", frameon=False)
    ax.set_ylim(bottom=0)
    return save_figure(fig, path)
