"""E(t) of summary.json as read back (``modulus_at``, its curve for the report): light, so that
the report and compare read it without the model's compiled code (runs/modulus.py makes it)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from bayes_dnlr.numbers import fmt

# how an entry's ``source`` begins when a cyclic test's first loading gave it
FIRST_LOADING = "first loading"


def from_first_loading(row: Mapping[str, Any]) -> bool:
    """Whether an E(t) entry comes from a cyclic test's first loading (runs/first_loading.py)."""
    return str(row.get("source", "")).startswith(FIRST_LOADING)


def entries(summary: Mapping[str, Any]) -> dict[str, list[dict]]:
    """The ``modulus_at`` of summary.json per test (a run with one test under its own name, '')."""
    block = summary.get("modulus_at")
    if not block:
        return {}
    if isinstance(block, list):
        return {"": block}
    return dict(block.get("tests") or {})



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
            out.append(f"E(t): {who}E({fmt(r['t'], 3)} s) = {pm(r['mean'], r['sd'])} MPa, 90 % HDI "
                       f"{interval(lo, hi, r['sd'])}: {mark} (the modulus the data determine; E is its "
                       "extrapolation to t → 0)")
            out += [f"  - {x}" for x in r.get("trust_reasons") or []]
    block = summary.get("consistency")
    if block:
        out.append(f"tests: {block.get('words')}")
    return out
