"""The population of specimens in words, a table and a figure: population.md and population.png
beside population.json (``python -m bayes_dnlr population``; docs/population.md). One section (and
one row of the figure) per material."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.inference.analyses.population import Population
from bayes_dnlr.numbers import fmt, interval, pm
from bayes_dnlr.report.tables import Table
from bayes_dnlr.runs.folder import write_atomic
from bayes_dnlr.workflows.population.run import UNLABELLED, PopulationRun, run_population

FIGURE = "population.png"
MARKDOWN = "population.md"
UNTRUSTED_COLOUR = "#d08a00"      # amber: a specimen whose own checks do not trust E's interval


def pooled_label(parameter: str, material: str | None, one_material: bool, n: int,
                 compared: str | None = None) -> str:
    """What the pooled value is called: the material's only when its heterogeneity check passed
    (on ``compared``, the quantity it compared: E(t) at a common time, or E)."""
    if one_material:
        return f"{parameter} of the material{f' {material}' if material else ''}"
    return (f"Pooled {parameter} of these {n} tests{f' labelled {material}' if material else ''} "
            f"(not shown as a material's: their {compared or parameter} differ beyond their own "
            "uncertainty)")


def modulus_line(m: dict[str, Any] | None, material: str | None, n: int) -> str:
    """The pooled E(t) of a population (population.json's ``modulus_at``) in words, or ''."""
    if not m:
        return ""
    who = (f"of the material{f' {material}' if material else ''}" if m.get("agree") else
           f"of these {n} tests (not a material's)")
    return (f"{m['quantity']} {who}: {pm(m['mean'], m['sd'])} MPa (their random-effects mean: the "
            f"spread between them beyond their own uncertainty, τ = {fmt(m['tau'], 3)} MPa, is in its "
            "sd)")


def listed(names: list[str], limit: int = 8) -> str:
    """Names joined by commas, the first ``limit`` of them and how many more."""
    more = len(names) - limit
    return ", ".join(names[:limit]) + (f" and {more} more" if more > 0 else "")


def trust_words(trusted: dict[str, Any], parameter: str = "E") -> str:
    """'k of N trusted' for E's interval (and E(t)'s), with the untrusted named."""
    if not trusted.get("n"):
        return "The specimens' runs have no verdict (made by an earlier version): trust unknown."
    text = (f"{trusted['k']} of {trusted['n']} specimens' {parameter} intervals trusted by their own "
            "checks")
    if trusted.get("untrusted"):
        text += f" (not: {listed(trusted['untrusted'])})"
    et = trusted.get("Et")
    if et:
        text += f"; E(t) trusted in {et['k']} of {et['n']}"
    return text + "."


def _et_cell(member: dict[str, Any]) -> str:
    et = member.get("Et") or {}
    if et.get("mean") is None:
        return "–"
    return pm(et["mean"], et.get("sd")) + ("" if et.get("trust") is not False else " ⚑")


def _group_markdown(pr: PopulationRun, label: str, title: str) -> list[str]:
    r = pr.results[label]
    p = r.parameter
    mu, s = r.mu, r.s
    material = None if label == UNLABELLED else label
    trusted = pr.trusted(r.names)
    compared = r.heterogeneity.get("quantity")
    et = modulus_line(pr.modulus.get(label), material, len(r.names))
    lines = [title, "",
             f"**{pooled_label(p, material, r.one_material, len(r.names), compared)}: μ = "
             f"{pm(mu['mean'], mu['sd'])} MPa** (90 % HDI {interval(*mu['hdi_90'], mu['sd'])}); "
             f"specimen-to-specimen sd **s = {pm(s['mean'], s['sd'])} MPa** (90 % HDI "
             f"{interval(*s['hdi_90'], s['sd'])}).", "", *([f"**{et}**.", ""] if et else []),
             f"Heterogeneity: {r.heterogeneity.get('words', 'not checked.')}", "",
             f"Trust: {trust_words(trusted, p)}", "",
             *([] if r.spread_resolved else [
                 f"The specimens' {p} agree within their own uncertainties: s is consistent with no "
                 f"spread at all, and {len(r.names)} specimens only bound it, s < "
                 f"{fmt(s['hdi_90'][1], 3)} MPa at 90 %; its mean, its sd and that bound lean on "
                 f"the prior (half-normal, scale {fmt(r.s_prior_scale, 3)} MPa; docs/population.md).",
                 ""]),
             f"Method: {r.to_dict()['method']}; priors: μ flat over the grid, s half-normal with scale "
             f"{fmt(r.s_prior_scale)} MPa. Stage 1: each specimen's own posterior (its run); stage 2: "
             "their draws reweighted under Normal(μ, s), divided by each run's prior.", ""]
    with_et = any((pr.members.get(k) or {}).get("Et") for k in r.names)
    rows = []
    for k in r.names:
        sp = r.specimens[k]
        own, shr = sp["own"], sp["shrunk"]
        member = pr.members.get(k) or {}
        trust = {True: "yes", False: "no ⚑"}.get(member.get("trust_interval"), "–")
        row = [k, pm(own["mean"], own["sd"]), pm(shr["mean"], shr["sd"]),
               interval(*shr["interval_90"], shr["sd"]), f"{r.effective_draws[k]:.0f}", trust]
        if with_et:
            row.append(_et_cell(member))
        if pr.truth:
            row.append(fmt(pr.truth.get(k)))
        rows.append(row)
    header = ["specimen", f"own {p} (MPa)", "shrunk (MPa)", "shrunk 90 %", "effective draws",
              "trusted (own checks)"]
    if with_et:
        t = next((pr.members[k]["Et"]["t_s"] for k in r.names if (pr.members.get(k) or {}).get("Et")),
                 None)
        header.append(f"E(t = {fmt(t, 3)} s) (MPa)")
    if pr.truth:
        header.append("true (synthetic)")
    lines.append(Table(header, rows, "Each specimen: its own posterior and its estimate shrunk to the "
                                     "population").markdown())
    mc = r.to_dict()["monte_carlo_check"]
    lines += ["", f"Monte Carlo check: {'passed' if mc['passed'] else 'FAILED'}: the fewest effective "
              f"draws of a specimen at the posterior mean of (μ, s) is "
              f"{min(r.effective_draws.values()):.0f} (at least {mc['limits']['effective_draws_min']:.0f} "
              f"wanted); the Monte Carlo variance of ln L there is {r.log_l_variance:.3g} (at most "
              f"{mc['limits']['log_likelihood_variance_max']:g})."]
    truths = [pr.truth[k] for k in r.names if k in pr.truth]
    if len(truths) == len(r.names):
        t = np.array(truths)
        lines.append(f"Synthetic specimens: their true {p} have mean {fmt(float(t.mean()))} and sd "
                     f"{fmt(float(t.std(ddof=1)))} MPa.")
    if r.warnings:
        lines += ["", "Warnings:"] + [f"- {w}" for w in r.warnings]
    return lines


def markdown(pr: PopulationRun) -> str:
    n = sum(len(p.names) for p in pr.results.values())
    parameter = next(iter(pr.results.values())).parameter
    if not pr.grouped:
        label = next(iter(pr.results))
        of = "" if label == UNLABELLED else f" ({label})"
        lines = _group_markdown(pr, label, f"# Population of {n} specimens{of}: {parameter}")
    else:
        lines = [f"# Populations of {n} specimens of {len(set(pr.materials.values()))} materials: "
                 f"{parameter}", "", "One population per material (the configs' material:); none "
                 f"spans two. {(pr.between or {}).get('words', '')}", ""]
        lines += [f"- {label}: not pooled: {why}" for label, why in pr.skipped.items()]
        for label, pop in pr.results.items():
            lines += ["", *_group_markdown(pr, label, f"## {label}: {len(pop.names)} specimens")]
    lines.append(f"\nPopulation step: {pr.wall_time_s:.2f} s for {n} specimens.")
    return "\n".join(lines) + "\n"


def _draw_group(a, b, pr: PopulationRun, label: str) -> None:
    """One material's row of the figure: its specimens (left) and its (μ, s) posterior (right)."""
    r: Population = pr.results[label]
    n = len(r.names)
    y = np.arange(n)[::-1]
    lo, hi = r.mu["hdi_90"]
    a.axvspan(lo, hi, color="#cfe0f3", label="μ: 90 % HDI")
    a.axvline(r.mu["mean"], color="#2b6cb0", lw=1)
    # one errorbar per kind for all specimens: one per specimen made 2n artists, which took a batch
    # of 150 tests 4 s to draw (and the legend's "best" place searched through all of them)
    untrusted = [(pr.members.get(k) or {}).get("trust_interval") is False for k in r.names]
    own = [r.specimens[k]["own"] for k in r.names]
    for bad in (False, True):
        idx = [i for i, u in enumerate(untrusted) if u == bad]
        if not idx:
            continue
        a.errorbar([own[i]["mean"] for i in idx], y[idx] + 0.15,
                   xerr=[1.645 * own[i]["sd"] for i in idx], fmt="o",
                   color=UNTRUSTED_COLOUR if bad else "#666", ms=4,
                   label="own posterior, not trusted by its checks" if bad else
                   "own posterior (±1.645 sd)")
    shrunk = [r.specimens[k]["shrunk"] for k in r.names]
    mid = np.array([sh["mean"] for sh in shrunk])
    a.errorbar(mid, y - 0.15, xerr=[mid - [sh["interval_90"][0] for sh in shrunk],
                                    [sh["interval_90"][1] for sh in shrunk] - mid],
               fmt="s", color="#c0392b", ms=4, label="shrunk (90 %)")
    true = [(pr.truth[k], yi) for yi, k in zip(y, r.names, strict=True) if k in pr.truth]
    if true:
        a.plot(*np.transpose(true), "x", color="#2a9d4b", ms=7, label="true (synthetic)")
    labels = [f"{k} ⚑" if u else k for k, u in zip(r.names, untrusted, strict=True)]
    a.set_yticks(y, labels, fontsize=None if n <= 40 else 5)
    a.set_ylim(-0.6, n - 0.4)
    a.set_xlabel(f"{r.parameter} (MPa)")
    a.legend(loc="best", fontsize=8)
    name = "" if label == UNLABELLED else f"{label}: "
    a.set_title(f"{name}specimens and the population mean"
                + ("" if r.one_material else " (not one material)"))
    g = r.grid
    post = np.asarray(g["posterior"])
    top = float(post.max()) if post.size else 0.0
    if top > 0:
        b.contourf(g["mu"], g["s"], post.T, levels=np.linspace(0.02 * top, top, 10), cmap="Blues")
    b.plot(r.mu["mean"], r.s["mean"], "+", color="#c0392b", ms=10, label="posterior mean")
    truths = [pr.truth[k] for k in r.names if k in pr.truth]
    if len(truths) == n:
        t = np.array(truths)
        b.plot(t.mean(), t.std(ddof=1), "x", color="#2a9d4b", ms=8,
               label="the true values' mean and sd (synthetic)")
    b.set_xlabel("μ (MPa)")
    b.set_ylabel("s (MPa)")
    b.set_title(f"{name}posterior of (μ, s)")
    b.legend(loc="upper right", fontsize=8)
    mass = post * np.gradient(g["s"])[None, :]           # the density times each s cell
    scum, mcum = np.cumsum(mass.sum(axis=0)), np.cumsum(mass.sum(axis=1))
    scum, mcum = scum / scum[-1], mcum / mcum[-1]
    if top > 0:
        b.set_ylim(0, 1.15 * g["s"][min(np.searchsorted(scum, 0.995), g["s"].size - 1)])
        m_lo = g["mu"][np.searchsorted(mcum, 0.003)]
        m_hi = g["mu"][min(np.searchsorted(mcum, 0.997), g["mu"].size - 1)]
        pad = 0.1 * (m_hi - m_lo)
        b.set_xlim(m_lo - pad, m_hi + pad)


def figure(pr: PopulationRun, path: Path) -> Path:
    """One row per material: left, each specimen's own (amber: not trusted by its own checks) and
    shrunk estimate (90 % intervals) with μ's HDI; right, the posterior of (μ, s) on the grid."""
    from bayes_dnlr.report.canvas import save_figure
    from bayes_dnlr.report.figures import pyplot

    plt = pyplot()
    sizes = [len(p.names) for p in pr.results.values()]
    # a batch of a few hundred tests: narrower rows past 40 specimens (18 in for them, 0.1 in at least)
    heights = [(0.45 if n <= 40 else max(0.1, 18.0 / n)) * n + 2.6 for n in sizes]
    fig, axes = plt.subplots(len(sizes), 2, figsize=(11, sum(heights)), squeeze=False,
                             gridspec_kw={"width_ratios": [1.4, 1], "height_ratios": heights})
    for (a, b), label in zip(axes, pr.results, strict=True):
        _draw_group(a, b, pr, label)
    fig.tight_layout()
    return save_figure(fig, path)


def population_report(run_dirs: list[Path | str], *, parameter: str = "E", out: Path | str | None = None,
                      force: bool = False, made_by: str = "population", min_group: int = 2) -> PopulationRun:
    """population.json, population.md and population.png of the finished runs ``run_dirs``."""
    pr = run_population(run_dirs, parameter=parameter, out=out, force=force, made_by=made_by,
                        min_group=min_group)
    md = pr.out_dir / MARKDOWN
    write_atomic(md, markdown(pr))
    pr.written += [md, figure(pr, pr.out_dir / FIGURE)]
    return pr
