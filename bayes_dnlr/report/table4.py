"""The paper's Table 4 for every run: the moduli of one material at every time scale, each beside
the model's prediction there.

Rows: the standards' chords on the test's own curve (ISO 527-1, ASTM D638), E(t) at the first time
the test resolves (the modulus its data determine), E (the model-based E^u, E(t) at t → 0), then
each reference (``reference_moduli``: pulse-echo, nanoindentation, a DMA sweep, a data sheet's
value) with the model's prediction at its time scale (E'(ω) at a frequency, E(t) at a time, E
itself where every mode is frozen), its z, its discrepancy against that prediction, and, as the
paper's Table 4 gives it, against E. A figure draws the same on one frequency axis: the model's
E'(ω) and E''(ω) with their 90 % bands (summary.json ``reference_curve``), E, and the references.
``compare`` gives one table across runs (``across_runs``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.numbers import fmt, fmt_at, fmt_sd, interval, pm
from bayes_dnlr.report.tables import Table, e_model
from bayes_dnlr.runs.modulus_view import entries as modulus_entries
from bayes_dnlr.runs.results import RunResults

STANDARDS = (("iso527_1", "ISO 527-1"), ("astm_d638", "ASTM D638"))
HEADER = ["modulus", "time scale", "measured (MPa)", "model there (MPa)", "90 % interval",
          "z", "vs model", "vs E (Table 4)", "use"]


def references_of(run: RunResults) -> tuple[list[dict[str, Any]], str]:
    """The run's references and from which analysis: summary.json's (the posterior's predictions),
    else fit.json's (linearized); when the config's references are not those the outputs hold (a
    reference added or changed since), each predicted now from fit.json's analysis. ([], "")
    without any."""
    expected = configured_labels(run.cfg)
    for src, how in ((run.summary, "posterior"), (run.fit, "least squares, linearized")):
        refs = (src or {}).get("reference_moduli")
        if refs and [r["label"] for r in refs] == expected and _same_values(run.cfg, refs):
            return list(refs), how
    if not expected:
        return [], ""
    from bayes_dnlr.runs.reference_fit import entries_from_fit

    try:
        refs = entries_from_fit(run.cfg, run.fit or {})
    except Exception as err:  # noqa: BLE001 - a reference the report cannot read is said, not fatal
        run.problems.append(f"reference_moduli: {err}")
        return [], ""
    return refs, "least squares, linearized now from fit.json (run `sample` for the posterior's)"


def _same_values(cfg, refs: Sequence[Mapping[str, Any]]) -> bool:
    """Whether the outputs' points hold the config's values (a value edited since is not)."""
    given = [r for r in cfg.reference_moduli or [] if r.value is not None]
    stored = {r["label"]: r for r in refs}
    labels = cfg.reference_labels
    return all(stored.get(labels[i], {}).get("value") == r.value
               for i, r in enumerate(cfg.reference_moduli or []) if r in given)


def configured_labels(cfg) -> list[str]:
    """The labels of the config's references (``reference_moduli`` and ``crosscheck:``)."""
    from bayes_dnlr.config.reference_section import crosscheck_entries, label_references

    return label_references(list(cfg.reference_moduli or []) + crosscheck_entries(cfg))


def _first_time(run: RunResults, test: str) -> dict[str, Any] | None:
    """E(t) at the first of the test's times: summary.json's (posterior), else fit.json's."""
    key = "" if run.layout.plain else test
    for src, how in ((run.summary, "posterior"), (run.fit, "least squares")):
        rows = modulus_entries(src or {}).get(key) or []
        if rows:
            return {**rows[0], "how": how}
    return None


def _pct(x: float | None) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:+.1f} %"


def _standard(run: RunResults, view: RunResults, standards: Mapping[str, Any] | None, key: str
              ) -> float | None:
    std = dict((view.summary or {}).get("standards") or {})
    v = std.get(key)
    if v is None and standards and standards.get(key) is not None:
        v = standards[key].modulus
    return None if v is None else float(v)


def table4(run: RunResults, test: str, view: RunResults, standards: Mapping[str, Any] | None
           ) -> Table | None:
    """Table 4 of one test of the run (module doc); None when the run has no reference."""
    refs, how = references_of(run)
    if not refs:
        return None
    e_mean, e_sd, e_src = e_model(view)
    rows = []
    rate = view.strain_rate()
    chord = "0.05-0.25 % strain" + (f" (t ≈ {fmt(5e-4 / rate, 2)}-{fmt(2.5e-3 / rate, 2)} s)" if rate else "")
    for key, label in STANDARDS:
        v = _standard(run, view, standards, key)
        if v is not None:
            rows.append([label, chord, fmt(v), "–", "–", "–", "–",
                         _pct(100 * (v - e_mean) / e_mean if e_mean else None), "this curve"])
    first = _first_time(run, test)
    if first is not None:
        lo, hi = first["hdi_90"]
        rows.append([f"E(t), the first time resolved ({first['how']})", f"t = {fmt(first['t'], 3)} s", "–",
                     pm(first["mean"], first["sd"]), interval(lo, hi, first["sd"]), "–", "–",
                     _pct(100 * (first["mean"] - e_mean) / e_mean if e_mean else None), "this curve"])
    rows.append([f"E, model-based ({e_src})", "t → 0", "–", fmt_at(e_mean, e_sd) + (
        f" ± {fmt_sd(e_sd)}" if e_sd else ""), "–", "–", "–", "reference", "this run"])
    fired = []
    for r in refs:
        p = r.get("prediction")
        measured = fmt(r["value"]) + (f" ± {fmt_sd(r['sd'])}" if r.get("sd") else "")
        name = r["label"] if r["label"] == r["method"] else f"{r['label']} ({r['method']})"
        if r.get("file"):
            n = len((r.get("points") or {}).get("value") or [])
            name += f", sweep of {n // 2 if n else '?'} frequencies"
        scale = r["at"] + (" (every mode frozen: E)" if r.get("regime") == "frozen" else "")
        check = r.get("check") or {}
        use = r["use"] + ("" if check.get("fired") is None else " ⚑" if check.get("fired") else
                          ", described" if r["use"] == "data" else ", agrees")
        if check.get("fired"):
            fired.append(check.get("words", ""))
        vs_e = _pct(100 * (r["value"] - e_mean) / e_mean if e_mean else None)   # the E row's E
        if p is None:
            rows.append([name, "none given", measured, "–", "–", "–", "–", vs_e, r["use"]])
            continue
        z = r.get("z")
        z_txt = "–" if z is None else f"{z:+.1f}" + (f" (χ² {r['chi2']:.1f}/{r['dof']})" if r.get("chi2")
                                                     is not None else "")
        rows.append([name, scale, measured, pm(p["mean"], p["sd"]),
                     interval(*p["hdi_90"], p["sd"]), z_txt, _pct(r.get("discrepancy_pct")), vs_e, use])
    notes = [f"Model column: the {how} prediction at each reference's time scale: E'(ω) of the same "
             "modes as E(t) at a frequency (E'(ω) = E where every mode is frozen), E(t) at a time. z: the "
             "reference against that prediction, their sd combined. 'vs model': (measured − model)/model; "
             "'vs E': (measured − E)/E, the paper's Table 4 (its discrepancies are against E^u_MBM). A "
             "reference to check (use: check) is held out; ⚑: it disagrees beyond the 99 % interval "
             "of their combined uncertainty, and the verdict says so; a reference in the data (use: "
             "data) is 'described' when the model follows it beside the tensile data, ⚑ when it does not."]
    notes += [f"⚑ {w}" for w in fired]
    if "now" in how:
        notes.insert(0, "The config's references are not those of the run's outputs (added or changed "
                        "since): predicted here from fit.json's analysis, and not in the verdict until "
                        "`sample` rewrites summary.json from its chain (or `fit` and `sample` again when a "
                        "reference is in the data).")
    data = (run.fit or {}).get("reference_data") or {}
    for label, sens in (data.get("sensitivities") or {}).items():
        cells = ", ".join(f"{k} {fmt(v, 3)}" for k, v in sens.items() if k != "at")
        notes.append(f"Normalised sensitivities X̃ = β ∂g/∂β (eq. 37, MPa) of {label} at {sens.get('at')} in "
                     f"the data, at the estimate with it: {cells}.")
    moved = data.get("E") or {}
    for k, m in moved.items():
        if m:
            b, a = m["before"], m["after"]
            notes.append(f"E with the data references ({'generalized' if k == 'model_error' else k} least "
                         f"squares): {pm(b['estimate'], b['sd'])} MPa from the tensile data alone, "
                         f"{pm(a['estimate'], a['sd'])} MPa with them: moved {m['move_sd']:+.2f} sd "
                         f"({m['move_pct']:+.2f} %), its interval ×{m['width_ratio']:.2f}.")
    for r in refs:
        notes += [f"{r['label']}: {n}" for n in r.get("notes") or []]
    return Table(HEADER, rows, "Table 4: the modulus at every time scale, beside the model's prediction",
                 notes, css="num")


def table4_plot(curve: Mapping[str, Any], points: Sequence[tuple[Any, ...]], path: Path) -> Path:
    """E'(ω) and E''(ω) of the model (posterior median and 90 % band) against frequency, E at the
    right, and the references: ``points`` (label, frequency, value, sd, kind, fired), kind
    "storage", "loss" or "relaxation" (drawn at f = 1/(2πt))."""
    from bayes_dnlr.report.canvas import new_figure, save_figure
    from bayes_dnlr.report.figures import C_GN, C_MODEL, C_TRUTH

    f = np.asarray(curve["frequency"], dtype=float)
    s = np.asarray(curve["storage"], dtype=float)
    loss = np.asarray(curve["loss"], dtype=float)
    fig = new_figure(figsize=(7.2, 4.4))
    ax = fig.add_subplot(1, 1, 1)
    ax.fill_between(f, s[0], s[2], color=C_MODEL, alpha=0.25, lw=0)
    ax.plot(f, s[1], color=C_MODEL, lw=1.8, label="model E'(ω), median and 90 % band")
    ax.fill_between(f, loss[0], loss[2], color=C_GN, alpha=0.2, lw=0)
    ax.plot(f, loss[1], color=C_GN, lw=1.2, label="model E''(ω)")
    e, (lo, hi) = curve["E_median"], curve["E_hdi_90"]
    ax.axhspan(lo, hi, color="0.6", alpha=0.25, lw=0)
    ax.axhline(e, color="0.35", lw=0.9, ls="--", label=f"E = {e:.0f} MPa (90 % HDI)")
    ax.axvline(curve["frozen_above"], color="0.7", lw=0.8, ls=":")
    shown: set[str] = set()
    markers = {"storage": "o", "loss": "s", "relaxation": "^"}
    colours = [C_TRUTH, "k", "#8c564b", "#9467bd", "#e377c2", "#17becf"]
    labels = list(dict.fromkeys(p[0] for p in points))
    for label, freq, value, sd, kind, fired in points:
        colour = colours[labels.index(label) % len(colours)]
        text = label + (" ⚑" if fired else "") if label not in shown else None
        shown.add(label)
        ax.errorbar([freq], [value], yerr=None if not sd or not math.isfinite(sd) else [[sd], [sd]],
                    fmt=markers.get(kind, "o"), color=colour, mfc="w" if kind == "loss" else colour,
                    ms=5, capsize=2, lw=1, label=text)
    ax.set_xscale("log")
    ax.set_xlabel("frequency (Hz); E(t) at f = 1/(2πt)")
    ax.set_ylabel("modulus (MPa)")
    ax.set_ylim(bottom=0, top=1.12 * max(hi, *(p[2] + (p[3] if p[3] and math.isfinite(p[3]) else 0)
                                               for p in points)) if points else 1.12 * hi)
    ax.legend(fontsize=7.5, loc="upper left", frameon=False)
    return save_figure(fig, path)


def plot_points(refs: Sequence[Mapping[str, Any]]) -> list[tuple[Any, ...]]:
    """What ``table4_plot`` marks for the references (those with a time scale)."""
    out = []
    for r in refs:
        fired = bool((r.get("check") or {}).get("fired"))
        if r.get("points"):
            pts = r["points"]
            for q, f, v, s in zip(pts["quantity"], pts["frequency"], pts["value"], pts["sd"], strict=True):
                out.append((r["label"], float(f), float(v), float(s), q, fired))
        elif r.get("prediction") is not None:
            if r.get("frequency"):
                out.append((r["label"], float(r["frequency"]), float(r["value"]), r.get("sd"), "storage",
                            fired))
            elif r.get("time"):
                out.append((r["label"], 1.0 / (2 * math.pi * float(r["time"])), float(r["value"]),
                            r.get("sd"), "relaxation", fired))
    return out


def across_runs(runs: Sequence[RunResults]) -> Table | None:
    """``compare``'s Table 4: one row per run (the paper's layout: a specimen per row), the
    standards, E, and each reference (by label) with its discrepancy against E and the z against
    the model's prediction at its time scale. None when no run has a reference."""
    labels: list[str] = []
    per_run = []
    for run in runs:
        refs, _ = references_of(run)
        per_run.append({r["label"]: r for r in refs})
        labels += [r["label"] for r in refs if r["label"] not in labels]
    if not labels:
        return None
    header = ["run", "ISO 527-1", "ASTM D638", "E (model-based)"] + labels
    rows = []
    for run, refs in zip(runs, per_run, strict=True):
        view = run if run.layout.plain else run.of_test(run.cfg.test_names[0])
        e_mean, e_sd, _ = e_model(view)
        std = dict((view.summary or {}).get("standards") or {})
        row = [run.name] + [fmt(std.get(k)) if std.get(k) is not None else "–" for k, _ in STANDARDS]
        row.append(pm(e_mean, e_sd) if e_sd else fmt(e_mean))
        for label in labels:
            r = refs.get(label)
            if r is None:
                row.append("–")
                continue
            cell = f"{fmt(r['value'])} ({_pct(r.get('discrepancy_to_E_pct'))})"
            if r.get("z") is not None:
                fired = (r.get("check") or {}).get("fired")
                cell += f", z {r['z']:+.1f} at {r['at']}" + (" ⚑" if fired else "")
            row.append(cell)
        rows.append(row)
    return Table(header, rows, "Table 4 across the runs: independent moduli beside E",
                 ["Each reference: its value, in brackets its discrepancy against the run's E (the "
                  "paper's Table 4), then its z against the model's prediction at its own time scale; ⚑: "
                  "its check fired."], css="num")
