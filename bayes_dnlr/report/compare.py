"""Compare runs (paper Tables 3 and 5): E, G, tau_max, De_max and the standards across strain rates.

``compare_runs(run_dirs, out_dir)`` reads each run's summary.json (posterior) and fit.json
(Gauss-Newton), writes compare.md and compare.csv into ``out_dir`` (by default the folder that holds the runs,
never the current directory)
and returns a ``Comparison`` whose ``markdown()`` is what the CLI prints.

Runs of several materials (their configs' ``material:``) get one answer each: E is compared within a
material, never across two. Each run's trust (runs/trust.py) and E(t) at its first time are rows
of the table and columns of compare.csv.

Consistency of E across runs (the paper's central claim: E is instantaneous, so it must not depend on
the strain rate): with E_i ± s_i per run (posterior mean and sd, else the Gauss-Newton values), the
package's one test of agreement (inference/analyses/agreement.py): the weighted mean
Ē = Σ E_i/s_i² / Σ 1/s_i², χ² = Σ ((E_i - Ē)/s_i)² on n - 1 degrees of freedom and its p-value at
the level P_AGREE; also the largest pairwise difference in combined sd,
|E_i - E_j| / sqrt(s_i² + s_j²), and the spread (max - min)/Ē that the paper quotes (±4 % around the
central value, section 5.1). The same test on E(t) at the time every run resolves
(runs/modulus_across.py) follows it.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bayes_dnlr.csvcells import safe_cell
from bayes_dnlr.errors import RunError
from bayes_dnlr.fileset import publishing
from bayes_dnlr.inference.analyses.agreement import P_AGREE, agreement
from bayes_dnlr.numbers import fmt, fmt_at, fmt_sd, interval, pm
from bayes_dnlr.report.table4 import across_runs, references_of
from bayes_dnlr.report.tables import Table, deborah
from bayes_dnlr.runs.folder import write_atomic
from bayes_dnlr.runs.layout import SUMMARY_FILE
from bayes_dnlr.runs.modulus_across import at_common_time, run_entries
from bayes_dnlr.runs.modulus_view import entries
from bayes_dnlr.runs.results import RunResults, load_run, verdict_lines
from bayes_dnlr.runs.testset import plain_names
from bayes_dnlr.runs.trust import run_trust, trusted_count
from bayes_dnlr.vocabulary import PARAMETER_NAMES, UNITS

P_CONSISTENT = P_AGREE      # one E at this level: the package's one test of agreement
# row keys kept out of compare.csv: the verdict's sentences one by one (its `verdict` column has them)
NOT_IN_CSV = ("verdict_points",)


@dataclass
class Consistency:
    """The test of E across runs."""

    n: int
    weighted_mean: float | None = None
    chi2: float | None = None
    dof: int = 0
    p_value: float | None = None
    max_pair_sd: float | None = None
    max_pair: tuple[str, str] | None = None
    spread: float | None = None          # (max - min) / weighted mean
    verdict: str = ""
    modulus: str = ""                    # the same test on E(t) at a common time (or why not)


@dataclass
class MaterialComparison:
    """The answer for the runs of one material: the consistency of E and the rate question."""

    consistency: Consistency
    rate: Any = None            # inference.rate.RateAnalysis of the posteriors, when there are draws
    rate_note: str = ""         # why there is none, when the runs' rates cannot answer the question


@dataclass
class Comparison:
    """Rows (one per run, by material then strain rate) and, per material, the consistency of E
    and the rate question; one material (or none named) keeps ``consistency``, ``rate`` and
    ``rate_note`` at the top."""

    rows: list[dict[str, Any]]
    consistency: Consistency
    notes: list[str] = field(default_factory=list)
    written: list[Path] = field(default_factory=list)
    rate: Any = None            # inference.rate.RateAnalysis of the posteriors, when there are draws
    rate_note: str = ""         # why there is none, when the runs' rates cannot answer the question
    materials: dict[str, MaterialComparison] = field(default_factory=dict)   # several materials
    table4: Table | None = None     # the paper's Table 4 across the runs (report/table4.py)

    def table(self) -> Table:
        """Table 3/5 layout: one column per run, one row per quantity."""
        header = ["", *[r["run"] for r in self.rows]]
        lines: list[list[str]] = []
        if any(r.get("material") for r in self.rows):
            lines.append(["material", *[r.get("material") or "–" for r in self.rows]])
        lines.append(["strain rate (1/s)", *[fmt(r["strain_rate"], 3) for r in self.rows]])
        for p in PARAMETER_NAMES:
            if not any(r.get(f"{p}_post") is not None or r.get(f"{p}_gn") is not None for r in self.rows):
                continue
            u = UNITS[p]
            lines.append([f"{p} posterior ({u})", *[_pm(r.get(f"{p}_post"), r.get(f"{p}_post_sd"))
                                                    for r in self.rows]])
            lines.append([f"{p} Gauss-Newton ({u})", *[_pm(r.get(f"{p}_gn"), r.get(f"{p}_gn_sd"))
                                                       for r in self.rows]])
            if any(r.get(f"{p}_true") is not None for r in self.rows):
                lines.append([f"{p} true ({u})", *[fmt_at(r.get(f"{p}_true"), r.get(f"{p}_post_sd")
                                                          or r.get(f"{p}_gn_sd")) for r in self.rows]])
        if any(r.get("Et_t") is not None for r in self.rows):
            lines.append(["E(t) at t (s)", *[fmt(r.get("Et_t"), 3) for r in self.rows]])
            lines.append(["E(t) posterior (MPa)",
                          *[_pm(r.get("Et_mean"), r.get("Et_sd")) for r in self.rows]])
            lines.append(["E(t) trusted", *["–" if r.get("Et_trust") is None else
                                             ("yes" if r["Et_trust"] else "no") for r in self.rows]])
        lines.append(["De_max = tau_max·ε̇ (eq. 45)", *[fmt(r["de_max"], 3) for r in self.rows]])
        lines.append(["ISO 527-1 (MPa)", *[fmt(r["iso527_1"]) for r in self.rows]])
        lines.append(["ASTM D638 (MPa)", *[fmt(r["astm_d638"]) for r in self.rows]])
        lines.append(["ISO 527-1 / E", *[fmt(r["iso_ratio"], 3) for r in self.rows]])
        lines.append(["checks (summary.json)", *[_checks_cell(r) for r in self.rows]])
        notes = []
        for r in self.rows:
            if r.get("verdict"):
                head, points = verdict_lines(r)
                notes += [f"{r['run']}: {head}", *(f"  - {p}" for p in points)]
        return Table(header, lines, "Runs compared (paper Tables 3 and 5)", css="num", notes=notes)

    def markdown(self) -> str:
        parts = [self.table().markdown(), ""]
        if self.table4 is not None:
            parts += [self.table4.markdown(), ""]
        answers = self.materials or {"": MaterialComparison(self.consistency, self.rate, self.rate_note)}
        for material, m in answers.items():
            of = f" ({material})" if material else ""
            parts += [f"**Is E the same at every strain rate{of}?**", ""]
            if m.rate is not None:
                parts += [rate_table(m.rate).markdown(), "", f"Posterior: {m.rate.words}",
                          *[f"- {n}" for n in m.rate.notes], "",
                          "The paper's way (each run's sd, a χ² test):", ""]
            elif m.rate_note:
                parts += [f"No rate question: {m.rate_note}", ""]
            parts += [m.consistency.verdict, ""]
            if m.consistency.modulus:
                parts += [m.consistency.modulus, ""]
        if self.materials:
            parts.append(f"One answer per material (the configs' material:): {len(self.materials)} "
                         "materials, none compared with another.")
        if self.notes:
            parts += ["", *[f"- {n}" for n in self.notes]]
        return "\n".join(parts).rstrip("\n") + "\n"

    def csv(self) -> str:
        keys: list[str] = []
        for r in self.rows:
            keys += [k for k in r if k not in keys]
        keys = [k for k in keys if k not in NOT_IN_CSV and any(r.get(k) is not None for r in self.rows)]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow([safe_cell(k) for k in keys])
        for r in self.rows:
            w.writerow([safe_cell("" if r.get(k) is None else r.get(k)) for k in keys])
        return buf.getvalue()


def _checks_cell(row: dict[str, Any]) -> str:
    """The checks' decision of a run in one cell (the verdict's words go under the table)."""
    if row.get("trust_interval") is None:
        return "–"
    if row["trust_interval"]:
        return "use E's interval"
    return "adequate, E's interval not as is" if row.get("adequate") else "model does not describe the test"


def _pm(v: float | None, sd: float | None) -> str:
    if v is None:
        return "–"
    return pm(v, sd)


def run_row(run: RunResults) -> dict[str, Any]:
    """One run's numbers for the comparison (None where a result is missing)."""
    row: dict[str, Any] = {"run": run.name, "material": run.cfg.material,
                           "strain_rate": run.strain_rate()}
    post = (run.summary or {}).get("posterior") or {}
    gn = run.gn()
    truth = run.truth or {}
    for p in PARAMETER_NAMES:
        s = post.get(p)
        row[f"{p}_post"] = None if s is None else float(s["mean"])
        row[f"{p}_post_sd"] = None if s is None else float(s["sd"])
        row[f"{p}_gn"] = None if gn is None else gn["estimate"].get(p)
        row[f"{p}_gn_sd"] = None if gn is None or gn["sd"] is None else gn["sd"].get(p)
        if p in run.cfg.fixed_values:
            row[f"{p}_gn"] = run.cfg.fixed_values[p]
        row[f"{p}_true"] = truth.get(p)
    row["de_max"] = deborah(run)[0]
    std = dict((run.summary or {}).get("standards") or {})
    if not std and run.test is not None:
        from bayes_dnlr.standards import standard_moduli

        std = standard_moduli(run.test)
    row["iso527_1"] = std.get("iso527_1")
    row["astm_d638"] = std.get("astm_d638")
    e = row["E_post"] if row["E_post"] is not None else row["E_gn"]
    row["iso_ratio"] = None if e is None or row["iso527_1"] is None else row["iso527_1"] / e
    row["source"] = "posterior" if post else ("gauss-newton" if gn is not None else "none")
    checks = (run.summary or {}).get("checks") or {}
    row["adequate"], row["trust_interval"] = checks.get("adequate"), checks.get("trust_interval")
    row["verdict"] = checks.get("verdict")
    row["verdict_points"] = checks.get("verdict_points")
    first = next(iter(entries(run.summary or {}).values()), [None])[0]
    row["Et_t"] = None if first is None else first["t"]
    row["Et_mean"] = None if first is None else first["mean"]
    row["Et_sd"] = None if first is None else first["sd"]
    row["Et_trust"] = None if first is None else bool(first.get("trust"))
    fired = run_trust(run.summary)["checks_fired"]
    row["checks_fired"] = None if fired is None else ", ".join(fired)
    for r in references_of(run)[0]:           # Table 4: each reference by its label
        key = f"ref_{r['label']}"
        row[f"{key}_value"] = r.get("value")
        row[f"{key}_at"] = r.get("at")
        row[f"{key}_model"] = (r.get("prediction") or {}).get("mean")
        row[f"{key}_z"] = r.get("z")
        row[f"{key}_vs_E_pct"] = r.get("discrepancy_to_E_pct")
        row[f"{key}_check_fired"] = (r.get("check") or {}).get("fired")
    return row


def consistency_of_e(rows: Sequence[dict[str, Any]]) -> Consistency:
    """The test of agreement (inference/analyses/agreement.py) of one E across runs, the largest
    pairwise gap in combined sd, and the spread."""
    pts, sources = [], set()
    for r in rows:
        if r.get("E_post") is not None and r.get("E_post_sd"):
            pts.append((r["run"], r["E_post"], r["E_post_sd"]))
            sources.add("posterior mean")
        elif r.get("E_gn") is not None and r.get("E_gn_sd"):
            pts.append((r["run"], r["E_gn"], r["E_gn_sd"]))
            sources.add("white least-squares")
    c = Consistency(n=len(pts))
    a = agreement("E", {n: e for n, e, _ in pts}, {n: s for n, _, s in pts})
    if a is None:
        c.verdict = "Fewer than two runs with E and its sd: nothing to compare."
        return c
    mean = c.weighted_mean = a.pooled
    c.chi2, c.dof, c.p_value = a.q, a.df, a.p
    c.max_pair_sd, c.max_pair = a.worst_z, a.worst_pair
    es = [e for _, e, _ in pts]
    c.spread = (max(es) - min(es)) / mean
    ok = a.agree
    c.verdict = (
        f"{'Yes' if ok else 'No'}: E = {fmt(mean)} MPa (weighted mean of {len(pts)} runs' "
        f"{' and '.join(sorted(sources))} E); "
        f"χ² = {c.chi2:.2f} on {c.dof} degrees of freedom, p = {c.p_value:.3g} "
        f"({'consistent' if ok else 'not consistent'} with one E at the {100 * P_CONSISTENT:.0f} % level). "
        f"Largest pairwise difference: {c.max_pair_sd:.2f} combined sd ({c.max_pair[0]} vs {c.max_pair[1]}). "
        f"Spread (max - min)/E = {100 * c.spread:.2f} % (the paper: 2700-2950 MPa, ±4 %, across its "
        "tests). The test uses each run's statistical sd only: a model bias common to a run (signed "
        "residuals) is not in it.")
    flags = [r.get("trust_interval") for r in rows if r["run"] in {n for n, _, _ in pts}]
    k, n = trusted_count(flags)
    if k < n:
        untrusted = [r["run"] for r in rows if r.get("trust_interval") is False]
        c.verdict += (f" Only {k} of these {n} runs' own checks trust E's interval (not: "
                      f"{', '.join(untrusted)}): read their verdicts under the table before using "
                      "this answer.")
    truths = [r["E_true"] for r in rows if r.get("E_true") is not None]
    if len(truths) >= 2:
        lo, hi = min(truths), max(truths)
        c.verdict += (f" Synthetic runs: their true E themselves range over {fmt(lo)}-{fmt(hi)} MPa "
                      f"({100 * (hi - lo) / mean:.2f} %)" + (": the test should find them different."
                                                            if hi > lo else "."))
    return c


def consistency_of_modulus(runs: Sequence[RunResults]) -> str:
    """The same test on the runs' E(t) at the time every one resolves (runs/modulus_across.py): a
    sentence, or why E(t) is not compared ('' with fewer than two runs with a posterior)."""
    have = {r.name: run_entries(r.summary) for r in runs if r.summary}
    have = {k: v for k, v in have.items() if v is not None}
    if len(have) < 2:
        return ""
    at = at_common_time(have)
    if at.t is None:
        return f"E(t) not compared: {at.why}."
    a = agreement(at.quantity, at.values(), at.sds())
    if a is None:
        return ""
    untrusted = [k for k, e in at.entries.items() if e.get("trust") is False]
    return (f"{at.quantity}, the modulus the data determine, at the time every run resolves: "
            + (f"the runs agree ({a.figures()}), pooled {pm(a.pooled, a.pooled_sd)} MPa."
               if a.agree else f"the runs differ ({a.figures()}; furthest apart: {a.pair_text()}).")
            + (f" Not trusted by their own checks there: {', '.join(untrusted)}." if untrusted else ""))


def rate_table(ra) -> Table:
    """The posterior differences of E from the slowest rate, and the trend per decade."""
    rows = [[f"E[{t}] - E[{ra.reference}] (MPa)", fmt(ra.rates[t], 3), fmt_at(d["mean"], d["sd"]),
             fmt_sd(d["sd"]), interval(*d["hdi_90"], d["sd"]), f"{d['z']:+.1f}"]
            for t, d in ra.differences.items()]
    s = ra.slope
    rows.append(["trend of E (% per decade of rate)", "", f"{s['mean']:+.2f}", fmt_sd(s["sd"]),
                 f"95 % [{s['lo95']:+.2f}, {s['hi95']:+.2f}]", ""])
    return Table(["quantity", "rate (1/s)", "posterior mean", "sd", "interval", "mean / sd"], rows,
                 "E across strain rates, from the posteriors", css="num")


def _rate_of_runs(runs: Sequence[RunResults]) -> tuple[Any, str]:
    """The rate analysis of separate runs (independent posteriors of E), when ≥ 2 have draws and
    their rates can answer it; else None and why not (empty: fewer than two with draws)."""
    from bayes_dnlr.inference.analyses.rate import one_rate, rate_analysis
    from bayes_dnlr.inference.posterior.priors import Prior

    use = [r for r in runs if r.draws is not None and "E" in r.draws and r.strain_rate()]
    rates = {r.name: r.strain_rate() for r in use}
    if len(use) < 2:
        return None, ""
    why = one_rate(rates)
    if why is not None:
        return None, why
    draws = {r.name: r.draws["E"].ravel() for r in use}
    priors = {r.name: Prior.from_spec("E", r.cfg.parameters["E"]) for r in use}
    return rate_analysis(draws, rates, priors, joint=False), ""


def default_out_dir(run_dirs: Sequence[Path | str]) -> Path:
    """Where compare writes by default: the folder that holds the runs (never the current
    directory by accident)."""
    parents = {Path(d).resolve().parent for d in run_dirs}
    if len(parents) == 1:
        return parents.pop()
    import os

    common = Path(os.path.commonpath([str(p) for p in parents]))
    if common == Path(common.anchor):
        raise RunError(f"the runs are in folders with nothing in common but {common} "
                       f"({', '.join(sorted(str(p) for p in parents))}): give compare --out DIR")
    return common


def compare_runs(run_dirs: Sequence[Path | str], out_dir: Path | str | None = None) -> Comparison:
    """Table 3/5-style comparison of runs; writes compare.md and compare.csv into ``out_dir``
    (by default the folder that holds the runs)."""
    if not run_dirs:
        raise RunError("compare needs at least one run directory")
    runs = []
    notes = []
    for d in run_dirs:
        d = Path(d)
        if not d.is_dir():
            raise RunError(f"{d}: not a run directory")
        need_data = not (d / SUMMARY_FILE).is_file()
        run = load_run(d, load_data=need_data)
        if not plain_names(run.cfg):
            raise RunError(f"{d}: a run with several tests (tests:) is compared within itself: its "
                           f"report (python -m bayes_dnlr report {d}) has the Tables 3/5 layout and the "
                           "rate question from the joint posterior; compare takes one-test runs")
        if run.fit is None and run.summary is None:
            notes.append(f"{run.name}: no fit.json or summary.json yet (run `fit` or `sample`).")
        elif run.summary is None:
            notes.append(f"{run.name}: no posterior yet; Gauss-Newton values only.")
        runs.append(run)
    order = list(dict.fromkeys(r.cfg.material for r in runs))       # materials as first given
    pairs = sorted(((run_row(r), r) for r in runs),
                   key=lambda p: (order.index(p[0]["material"]), p[0]["strain_rate"] is None,
                                  p[0]["strain_rate"] or 0.0, p[0]["run"]))
    rows = [row for row, _ in pairs]
    if len(order) == 1:
        rate, rate_note = _rate_of_runs(runs)
        comp = Comparison(rows, consistency_of_e(rows), notes, rate=rate, rate_note=rate_note)
        comp.consistency.modulus = consistency_of_modulus(runs)
    else:                       # one answer per material: no E is computed across two
        comp = Comparison(rows, Consistency(n=0, verdict=f"Runs of {len(order)} materials: one answer "
                                            "per material."), notes)
        for material in order:
            mine = [r for r in runs if r.cfg.material == material]
            m_rate, m_note = _rate_of_runs(mine)
            c = consistency_of_e([r for r in rows if r["material"] == material])
            c.modulus = consistency_of_modulus(mine)
            comp.materials[material or "no material given"] = MaterialComparison(c, m_rate, m_note)
    comp.table4 = across_runs([run for _, run in pairs])
    out = Path(out_dir) if out_dir is not None else default_out_dir(run_dirs)
    md, cs = out / "compare.md", out / "compare.csv"
    with publishing(out, "compare", [md.name, cs.name]):        # the two tables as one set
        write_atomic(md, comp.markdown())
        write_atomic(cs, comp.csv())
    comp.written = [md, cs]
    return comp
