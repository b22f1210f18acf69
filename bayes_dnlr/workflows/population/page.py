"""The population of specimens in words, a table and a figure: population.md and population.png
beside population.json (``python -m bayes_dnlr population``; docs/population.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bayes_dnlr.numbers import fmt, interval, pm
from bayes_dnlr.report.tables import Table
from bayes_dnlr.runs.folder import write_atomic
from bayes_dnlr.workflows.population.run import PopulationRun, run_population

FIGURE = "population.png"
MARKDOWN = "population.md"


def markdown(pr: PopulationRun) -> str:
    r = pr.result
    p = r.parameter
    mu, s = r.mu, r.s
    lines = [f"# Population of {len(r.names)} specimens: {p}", "",
             f"**{p} of the material: μ = {pm(mu['mean'], mu['sd'])} MPa** "
             f"(90 % HDI {interval(*mu['hdi_90'], mu['sd'])}); specimen-to-specimen sd **s = "
             f"{pm(s['mean'], s['sd'])} MPa** (90 % HDI {interval(*s['hdi_90'], s['sd'])}).",
             "",
             *([] if r.spread_resolved else [
                 f"The specimens' {p} agree within their own uncertainties: s is consistent with no "
                 f"spread at all, and {len(r.names)} specimens only bound it, s < "
                 f"{fmt(s['hdi_90'][1], 3)} MPa at 90 %; its mean, its sd and that bound lean on "
                 f"the prior (half-normal, scale {fmt(r.s_prior_scale, 3)} MPa; docs/population.md).",
                 ""]),
             f"Method: {r.to_dict()['method']}; priors: μ flat over the grid, s half-normal with scale "
             f"{fmt(r.s_prior_scale)} MPa. Stage 1: each specimen's own posterior (its run); stage 2: "
             "their draws reweighted under Normal(μ, s), divided by each run's prior.", ""]
    rows = []
    for k in r.names:
        sp = r.specimens[k]
        own, shr = sp["own"], sp["shrunk"]
        row = [k, pm(own["mean"], own["sd"]), pm(shr["mean"], shr["sd"]),
               interval(*shr["interval_90"], shr["sd"]),
               f"{r.effective_draws[k]:.0f}"]
        if pr.truth:
            row.append(fmt(pr.truth.get(k)))
        rows.append(row)
    header = ["specimen", f"own {p} (MPa)", "shrunk (MPa)", "shrunk 90 %", "effective draws"]
    if pr.truth:
        header.append("true (synthetic)")
    lines.append(Table(header, rows, "Each specimen: its own posterior and its estimate shrunk to the "
                                     "population").markdown())
    mc = r.to_dict()["monte_carlo_check"]
    lines += ["", f"Monte Carlo check: {'passed' if mc['passed'] else 'FAILED'}: the fewest effective "
              f"draws of a specimen at the posterior mean of (μ, s) is "
              f"{min(r.effective_draws.values()):.0f} (at least {mc['limits']['effective_draws_min']:.0f} "
              f"wanted); the Monte Carlo variance of ln L there is {r.log_l_variance:.3g} (at most "
              f"{mc['limits']['log_likelihood_variance_max']:g}).",
              f"Population step: {pr.wall_time_s:.2f} s for {len(r.names)} specimens."]
    if pr.truth and len(pr.truth) == len(r.names):
        t = np.array(list(pr.truth.values()))
        lines.append(f"Synthetic specimens: their true {p} have mean {fmt(float(t.mean()))} and sd "
                     f"{fmt(float(t.std(ddof=1)))} MPa.")
    if r.warnings:
        lines += ["", "Warnings:"] + [f"- {w}" for w in r.warnings]
    return "\n".join(lines) + "\n"


def figure(pr: PopulationRun, path: Path) -> Path:
    """Left: each specimen's own and shrunk estimate (90 % intervals) with μ's HDI; right: the
    posterior of (μ, s) on the grid."""
    from bayes_dnlr.report.canvas import save_figure
    from bayes_dnlr.report.figures import pyplot

    plt = pyplot()
    r = pr.result
    n = len(r.names)
    # a batch of a few hundred tests: narrower rows past 40 specimens (18 in for them, 0.1 in at least)
    row = 0.45 if n <= 40 else max(0.1, 18.0 / n)
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, row * n + 2.6), gridspec_kw={"width_ratios": [1.4, 1]})
    y = np.arange(len(r.names))[::-1]
    lo, hi = r.mu["hdi_90"]
    a.axvspan(lo, hi, color="#cfe0f3", label="μ: 90 % HDI")
    a.axvline(r.mu["mean"], color="#2b6cb0", lw=1)
    # one errorbar per kind for all specimens: one per specimen made 2n artists, which took a batch
    # of 150 tests 4 s to draw (and the legend's "best" place searched through all of them)
    own = [r.specimens[k]["own"] for k in r.names]
    shrunk = [r.specimens[k]["shrunk"] for k in r.names]
    a.errorbar([o["mean"] for o in own], y + 0.15, xerr=[1.645 * o["sd"] for o in own], fmt="o",
               color="#666", ms=4, label="own posterior (±1.645 sd)")
    mid = np.array([sh["mean"] for sh in shrunk])
    a.errorbar(mid, y - 0.15, xerr=[mid - [sh["interval_90"][0] for sh in shrunk],
                                    [sh["interval_90"][1] for sh in shrunk] - mid],
               fmt="s", color="#c0392b", ms=4, label="shrunk (90 %)")
    true = [(pr.truth[k], yi) for yi, k in zip(y, r.names, strict=True) if k in pr.truth]
    if true:
        a.plot(*np.transpose(true), "x", color="#2a9d4b", ms=7, label="true (synthetic)")
    a.set_yticks(y, r.names, fontsize=None if n <= 40 else 5)
    a.set_ylim(-0.6, n - 0.4)
    a.set_xlabel(f"{r.parameter} (MPa)")
    a.legend(loc="best", fontsize=8)
    a.set_title("specimens and the population mean")
    g = r.grid
    post = np.asarray(g["posterior"])
    top = float(post.max()) if post.size else 0.0
    if top > 0:
        b.contourf(g["mu"], g["s"], post.T, levels=np.linspace(0.02 * top, top, 10), cmap="Blues")
    b.plot(r.mu["mean"], r.s["mean"], "+", color="#c0392b", ms=10, label="posterior mean")
    if pr.truth and len(pr.truth) == len(r.names):
        t = np.array(list(pr.truth.values()))
        b.plot(t.mean(), t.std(ddof=1), "x", color="#2a9d4b", ms=8,
               label="the true values' mean and sd (synthetic)")
    b.set_xlabel("μ (MPa)")
    b.set_ylabel("s (MPa)")
    b.set_title("posterior of (μ, s)")
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
    fig.tight_layout()
    return save_figure(fig, path)


def population_report(run_dirs: list[Path | str], *, parameter: str = "E", out: Path | str | None = None,
                      force: bool = False, made_by: str = "population") -> PopulationRun:
    """population.json, population.md and population.png of the finished runs ``run_dirs``."""
    pr = run_population(run_dirs, parameter=parameter, out=out, force=force, made_by=made_by)
    md = pr.out_dir / MARKDOWN
    write_atomic(md, markdown(pr))
    pr.written += [md, figure(pr, pr.out_dir / FIGURE)]
    return pr
