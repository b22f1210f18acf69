"""The run's references (``reference_moduli:``, paper Table 4): read from the config (a sweep's
file by data/dma.py, the values of ``crosscheck:`` after them), their entries in fit.json and
summary.json, the check the verdict reads, and their words.

``fit`` puts them in fit.json (runs/reference_fit.py: the data references in the analyses), ``sample``
in summary.json (runs/reference_posterior.py: the posterior's predictions), ``checks.reference_moduli``
the checks (``reference_check``), runs/verdict.py their sentences.

Each entry of ``reference_moduli`` (fit.json and summary.json): the config's keys (method, value,
sd, frequency or time, temperature, use, note, ...), ``label``, ``at`` (the quantity, e.g.
"E'(5 MHz)"), ``regime``, ``prediction`` {mean, sd, median, hdi_90, how}, ``z`` (the reference
against the prediction, their sd combined), ``discrepancy_pct`` (against the prediction),
``discrepancy_to_E_pct`` (against E, the paper's Table 4), ``E`` {mean, sd}, ``check`` and, for a
sweep, ``points`` (every element) with ``chi2``, ``dof``, ``p_value``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference.layout import joint_name
from bayes_dnlr.inference.references import compare
from bayes_dnlr.inference.references.condition import parameter_map
from bayes_dnlr.inference.references.terms import (
    LOSS,
    RELAXATION,
    STORAGE,
    Reference,
    regime,
    temperature_shift,
)
from bayes_dnlr.numbers import fmt, fmt_at, fmt_sd, pm
from bayes_dnlr.vocabulary import TIME_CONSTANTS, base_name

SPEC_KEYS = ("method", "value", "sd", "frequency", "time", "temperature", "use", "note")   # always
OPTIONAL_KEYS = ("relative_sd", "test", "file")                                          # when given


def build_references(cfg: Config, base: Path | None = None) -> list[Reference]:
    """The run's references (its ``reference_moduli:`` and the values of ``crosscheck:``), their
    sweeps read (data/dma.py), in config order."""
    from bayes_dnlr.config.reference_section import crosscheck_entries, label_references

    entries = list(cfg.reference_moduli or []) + crosscheck_entries(cfg)
    labels = label_references(entries)
    base = cfg.base_dir if base is None else base
    return [_reference(cfg, i, labels[i], e, base) for i, e in enumerate(entries)]


def _reference(cfg: Config, index: int, label: str, spec, base: Path) -> Reference:
    if spec.is_sweep:
        from bayes_dnlr.data.dma import read_sweep

        path = Path(spec.file)
        sweep = read_sweep(path if path.is_absolute() else base / path, spec.columns, spec.units)
        f = np.asarray(sweep.frequency, dtype=float)
        parts = [(STORAGE, f, np.asarray(sweep.storage, dtype=float))]
        if sweep.loss is not None:
            parts.append((LOSS, f, np.asarray(sweep.loss, dtype=float)))
        quantity = np.concatenate([np.full(x.size, q) for q, x, _ in parts])
        at = np.concatenate([x for _, x, _ in parts])
        value = np.concatenate([v for _, _, v in parts])
        temp = (np.tile(np.asarray(sweep.temperature, dtype=float), len(parts))
                if sweep.temperature is not None else
                np.full(value.size, np.nan if spec.temperature is None else float(spec.temperature)))
        sd = (np.full(value.size, float(spec.sd)) if spec.sd is not None
              else float(spec.relative_sd) * np.abs(value))
        reading = list(sweep.notes)
    else:
        quantity = np.array([STORAGE if spec.frequency is not None else RELAXATION
                             if spec.time is not None else "none"])
        at = np.array([spec.frequency if spec.frequency is not None else spec.time
                       if spec.time is not None else np.nan], dtype=float)
        value = np.array([spec.value], dtype=float)
        s = spec.value_sd()
        sd = np.array([np.nan if s is None else s])
        temp = np.array([np.nan if spec.temperature is None else float(spec.temperature)])
        reading = []
    shift, words = temperature_shift(cfg, temp, label, spec.use)
    s = cfg.model.shift
    law = (s.temperature, float(s.reference_temperature)) if s.temperature != "none" else None
    if law is not None and not np.all(np.isfinite(temp)):
        words.append(f"no temperature given: predicted at the reference temperature, "
                     f"{s.reference_temperature:g} °C")
    return Reference(index=index, label=label, method=spec.method, use=spec.use, quantity=quantity,
                     at=at, value=value, sd=sd, test=spec.test, shift=shift, temperature=temp,
                     spec=spec, notes=words, sweep=spec.is_sweep, reading=reading, law=law)


def references_of(cfg: Config) -> list[Reference]:
    """The run's references, or an error naming the entry."""
    try:
        return build_references(cfg)
    except BayesDnlrError:
        raise
    except (OSError, ValueError) as err:
        raise BayesDnlrError(f"reference_moduli: {err}") from None


def name_function(cfg: Config, plain: bool):
    """``Layout.name`` of the run without its layout: a per-test parameter's name carries its test."""
    per = set(cfg.per_test_parameters)
    return lambda k, t: k if plain or k not in per or t is None else joint_name(k, t)


def reference_values(ref: Reference, estimate: Mapping[str, float], names: Sequence[str], name_of,
            fixed: Mapping[str, float]) -> dict[str, float]:
    out = {}
    for k, g in parameter_map(ref, names, name_of).items():
        if g in estimate:
            out[k] = float(estimate[g])
        elif k in fixed:
            out[k] = float(fixed[k])
    return out


def is_log(names: Sequence[str]) -> list[bool]:
    return [base_name(k) in TIME_CONSTANTS for k in names]


# ---------------------------------------------------------------- records

def _spec(ref: Reference) -> dict[str, Any]:
    s = ref.spec
    out = {k: getattr(s, k) for k in SPEC_KEYS}
    out.update({k: getattr(s, k) for k in OPTIONAL_KEYS if getattr(s, k, None) is not None})
    out["use"] = ref.use
    if out["sd"] is None and ref.m and math.isfinite(float(ref.sd[0])):
        out["sd"] = float(ref.sd[0])          # from relative_sd
    return {"index": ref.index, "label": ref.label, **out}


def entry(ref: Reference, pred: compare.Prediction | None, e_stats: Mapping[str, float] | None,
          point: Mapping[str, float] | None, decades: float) -> dict[str, Any]:
    """One entry of ``reference_moduli`` (module doc) from the prediction of its elements."""
    out = _spec(ref)
    if ref.sweep:          # a sweep's value and sd: those of the element Table 4 shows
        out["value"] = float(ref.value[ref.headline])
        out["sd"] = float(ref.sd[ref.headline])
    kind, words = regime(ref, point or {"tau_max": math.nan}, decades) if point else ("none", "")
    out.update(at=ref.where() if ref.predictable else "E (no time scale)", regime=kind,
               regime_words=words, notes=list(ref.notes), held_out=ref.use == "check")
    if ref.reading:
        out["reading"] = list(ref.reading)
    e_mean = (e_stats or {}).get("mean")
    i = ref.headline
    value = float(ref.value[i])
    out["E"] = dict(e_stats) if e_stats else None
    out["discrepancy_to_E_pct"] = (100.0 * (value - e_mean) / e_mean) if e_mean else None
    if pred is None or not ref.predictable:
        out.update(prediction=None, z=None, discrepancy_pct=None, check=None)
        return out
    ag = compare.agreement(ref.value, ref.sd, pred, ref.sweep)
    out["prediction"] = {"mean": float(pred.mean[i]), "sd": float(pred.sd[i]),
                         "median": float(pred.median[i]), "hdi_90": [float(x) for x in pred.hdi[i]],
                         "how": pred.how}
    out["z"] = None if not math.isfinite(ag.z[i]) else float(ag.z[i])
    out["discrepancy_pct"] = float(ag.discrepancy_pct[i])
    given_sd = float(ref.sd[i]) if math.isfinite(ref.sd[i]) else None
    combined = math.hypot(given_sd or 0.0, float(pred.sd[i]))
    out["check"] = {
        "held_out": ref.use == "check", "p_value": ag.p_value, "threshold_p": compare.CHECK_P,
        "fired": ag.fired, "ok": None if ag.fired is None else not ag.fired,
        "combined_sd": combined, "chi2": ag.chi2, "dof": ag.dof,
        "words": check_words(ref, out, ag, given_sd),
    }
    if ref.sweep:
        out["points"] = {
            "quantity": [str(q) for q in ref.quantity], "frequency": [float(x) for x in ref.at],
            "value": [float(x) for x in ref.value], "sd": [float(x) for x in ref.sd],
            "mean": [float(x) for x in pred.mean], "pred_sd": [float(x) for x in pred.sd],
            "hdi_90": [[float(a), float(b)] for a, b in pred.hdi],
            "z": [None if not math.isfinite(x) else float(x) for x in ag.z]}
        out.update(chi2=ag.chi2, dof=ag.dof, p_value=ag.p_value)
    return out


def check_words(ref: Reference, rec: Mapping[str, Any], ag: compare.Agreement,
                given_sd: float | None) -> str:
    """The check's sentence: how the reference compares with the model's prediction."""
    p = rec["prediction"]
    who = f"{ref.label} ({ref.method}"
    who += f", {ref.spec.note}" if ref.spec.note else ""
    who += ")"
    role = "held out" if ref.use == "check" else "in the data"
    if ref.sweep:
        n = ref.m
        text = (f"{who}, {role}: the sweep's {n} values against the model's E'(ω), E''(ω): χ² = "
                f"{ag.chi2:.1f} on {ag.dof} (p = {ag.p_value:.2g}); at its highest frequency {ref.where()} "
                f"= {fmt(float(ref.value[ref.headline]))} MPa, the model {pm(p['mean'], p['sd'])} MPa")
    else:
        sd_text = f" ± {fmt_sd(given_sd)}" if given_sd else " (no sd given)"
        text = (f"{who}, {role}: {ref.where()} = {fmt(float(ref.value[0]))}{sd_text} MPa, the model "
                f"{pm(p['mean'], p['sd'])} MPa ({rec['discrepancy_pct']:+.1f} %, z = "
                f"{ag.z[0]:+.1f})")
    if ag.fired and ref.use == "data":
        text += (f": the model does not describe it beside the tensile data (beyond the "
                 f"{100 * (1 - compare.CHECK_P):.0f} % level): E is a compromise between the two, "
                 "not a measurement. The model's spectrum cannot follow both (its shape, a second "
                 "process), or the reference is not of this material or its conditions. Sample the "
                 "spectrum's exponent (parameters.alpha), or hold the reference out (use: check)")
    elif ag.fired:
        text += (f": they disagree beyond the {100 * (1 - compare.CHECK_P):.0f} % interval of their "
                 "combined uncertainty. The model's spectrum does not reach this time scale as the "
                 "material does (another spectrum shape, a second process), or the reference is not "
                 "of this material or its conditions; E's interval does not carry it. Sample the "
                 "spectrum's exponent (parameters.alpha), or give the reference as data (use: data) "
                 "if it is to be trusted")
    elif ag.fired is False:
        text += ": they agree"
    return text


def reference_check(entries: Sequence[Mapping[str, Any]] | None) -> dict[str, Any] | None:
    """summary.json ``checks.reference_moduli``: each reference against the posterior's prediction,
    held out (``use: check``) or in the data (``use: data``: does the model describe it beside the
    tests?); ``ok`` false when one fires (it withdraws trust in E's interval, runs/verdict.py)."""
    checked = [e for e in entries or [] if e.get("check") and e["check"].get("fired") is not None]
    if not checked:
        return None
    return {"ok": not any(e["check"]["fired"] for e in checked),
            "entries": [{"label": e["label"], "method": e["method"], "use": e["use"], "at": e["at"],
                         "z": e.get("z"), "p_value": e["check"]["p_value"], "fired": e["check"]["fired"],
                         "words": e["check"]["words"]} for e in checked]}


# ---------------------------------------------------------------- words

def console_lines(block: Mapping[str, Any]) -> list[str]:
    """The ``fit`` console's lines of the references."""
    entries = block.get("reference_moduli") or []
    if not entries:
        return []
    lines = ["", "reference moduli (Table 4; linearized predictions at each time scale):"]
    for e in entries:
        p = e.get("prediction")
        value = e.get("value")
        head = f"  {e['label']} ({e['use']}): {e['at']}"
        if e.get("file"):
            head += f" of the sweep {e['file']}"
        if p is None:
            lines.append(f"{head} = {fmt(value)} MPa; no time scale: {e['discrepancy_to_E_pct']:+.1f} % "
                         "against E" if e.get("discrepancy_to_E_pct") is not None else head)
            continue
        lines.append(f"{head}: reference {fmt(value)} MPa, model {fmt_at(p['mean'], p['sd'])} ± "
                     f"{fmt_sd(p['sd'])} MPa ({p['how']}); z {e['z']:+.2f}, {e['discrepancy_pct']:+.1f} %"
                     + (f"; χ² {e['chi2']:.1f} on {e['dof']}" if e.get("chi2") is not None else ""))
        if e.get("regime") == "frozen":
            lines.append(f"    {e['regime_words']}")
    data = block.get("reference_data")
    if data:
        lines.append(f"  the estimates, sd and Δ̃ above hold the data references "
                     f"({', '.join(data['references'])}); fit.json reference_data.without keeps the "
                     "tests' alone")
        for k, m in (data.get("E") or {}).items():
            if not m:
                continue
            b, a = m["before"], m["after"]
            lines.append(f"  E with the data references ({k}): {pm(b['estimate'], b['sd'])} -> "
                         f"{pm(a['estimate'], a['sd'])} MPa (moved {m['move_sd']:+.2f} sd, "
                         f"{m['move_pct']:+.2f} %; interval ×{m['width_ratio']:.2f})")
    return lines


def summary_lines(entries: Sequence[Mapping[str, Any]] | None) -> list[str]:
    """The ``sample`` console's line of each reference: the posterior's prediction beside it."""
    out = []
    for e in entries or []:
        p = e.get("prediction")
        value = f"{fmt(e['value'])}" + (f" ± {fmt_sd(e['sd'])}" if e.get("sd") else "")
        if p is None:
            against = e.get("discrepancy_to_E_pct")
            out.append(f"reference {e['label']}: {value} MPa, no time scale"
                       + (f" ({against:+.1f} % against E)" if against is not None else ""))
            continue
        check = e.get("check") or {}
        fired = check.get("fired")
        state = ("" if fired is None else
                 ("NOT described beside the tests" if fired else "described") if e["use"] == "data" else
                 ("DISAGREES" if fired else "agrees"))
        out.append(f"reference {e['label']} ({e['use']}): {e['at']} = {value} MPa, posterior "
                   f"{pm(p['mean'], p['sd'])} MPa (z {e['z']:+.2f}, {e['discrepancy_pct']:+.1f} %)"
                   + (f": {state}" if state else ""))
    return out
