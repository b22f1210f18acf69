"""E(t) of summary.json and fit.json as read back (``modulus_at``, its curve for the report): light,
so that the report and compare read it without the model's compiled code (runs/modulus_block.py
makes it)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from bayes_dnlr.numbers import fmt


def entries(summary: Mapping[str, Any]) -> dict[str, list[dict]]:
    """The ``modulus_at`` of summary.json per test (a run with one test under its own name, '');
    of fit.json too: a run with one test has its list, a joint fit each test's in its single fit."""
    block = summary.get("modulus_at")
    if isinstance(block, list):
        return {"": block} if block else {}
    if block:
        return dict(block.get("tests") or {})
    singles = summary.get("single_fits") or {}
    return {t: s["modulus_at"] for t, s in singles.items() if s.get("modulus_at")}


def reference(summary: Mapping[str, Any]) -> dict[str, Any] | None:
    """E(t) at the reference temperature of tests made at several (runs/master_curve.py): the
    ``reference`` of summary.json's ``modulus_at``, or fit.json's ``modulus_reference``."""
    block = summary.get("modulus_at")
    if isinstance(block, Mapping) and block.get("reference"):
        return dict(block["reference"])
    found = summary.get("modulus_reference")
    return dict(found) if found else None


def curves(summary: Mapping[str, Any]) -> dict[str, dict]:
    """The ``modulus_curve`` of summary.json per test (a run with one test under '')."""
    block = summary.get("modulus_curve")
    if not block:
        return {}
    if "t" in block:
        return {"": block}
    return dict(block)


def console_lines(summary: Mapping[str, Any]) -> list[str]:
    """The console's lines of E(t): each time's value, 90 % HDI and trust, with the reasons."""
    from bayes_dnlr.numbers import interval, pm

    out = []
    for test, rows in entries(summary).items():
        who = f"{test}: " if test else ""
        for r in rows:
            lo, hi = r["hdi_90"]
            mark = "trusted" if r.get("trust") else "NOT trusted"
            source = " (fit, linearized)" if r.get("source") == "fit" else ""
            out.append(f"E(t): {who}E({fmt(r['t'], 3)} s) = {pm(r['mean'], r['sd'])} MPa, 90 % HDI "
                       f"{interval(lo, hi, r['sd'])}{source}: {mark} (the modulus the data determine; "
                       "E is its extrapolation to t → 0)")
            out += [f"  - {x}" for x in r.get("trust_reasons") or []]
            out += [f"  - not checked: {k} ({why})" for k, why in (r.get("lacks") or {}).items()]
    ref = reference(summary)
    for r in (ref or {}).get("rows") or []:
        lo, hi = r["hdi_90"]
        mark = "trusted" if r.get("trust") else "NOT trusted"
        out.append(f"E(t) at {ref['temperature']:g} °C (the master curve): E({fmt(r['t'], 3)} s) = "
                   f"{pm(r['mean'], r['sd'])} MPa, 90 % HDI {interval(lo, hi, r['sd'])}, from "
                   f"{r.get('test')}: {mark}")
        out += [f"  - {x}" for x in r.get("trust_reasons") or []]
    block = summary.get("consistency")
    if block:
        out.append(f"tests: {block.get('words')}")
    return out
