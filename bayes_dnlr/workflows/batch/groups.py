"""The tests of a batch by material, and each material's numbers for the batch page: E across its
tests (the spread between them beside the uncertainty within one), E(t) at its first time, and how
many of them their own checks trust (runs/trust.py; the table's ``trust_interval`` and ``Et_trust``).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np

from bayes_dnlr.workflows.population.run import UNLABELLED


def material_of(row: dict[str, Any]) -> str:
    """A row's material, UNLABELLED without one."""
    return str(row.get("material") or UNLABELLED)


def by_material(rows: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    """The rows per material, materials in the order they first appear."""
    out: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        out.setdefault(material_of(r), []).append(r)
    return out


def labelled(rows: list[dict[str, Any]]) -> bool:
    """Whether any test of the batch names its material."""
    return any(r.get("material") for r in rows)


def spread(rows: list[dict[str, Any]], p: str = "E") -> dict[str, float] | None:
    """``p`` across the ok tests: mean and sd of the posterior means (between tests), the median
    posterior sd (within a test) and their ratio; None without a test that has it."""
    pts = [(r[f"{p}_mean"], r[f"{p}_sd"]) for r in rows
           if r.get("status") == "ok" and r.get(f"{p}_mean") is not None]
    if not pts:
        return None
    m = np.array([a for a, _ in pts], float)
    s = np.array([b for _, b in pts], float)
    between = float(m.std(ddof=1)) if m.size > 1 else float("nan")
    within = float(np.median(s))
    return {"n": int(m.size), "mean": float(m.mean()), "between_sd": between, "within_sd": within,
            "ratio": between / within if within > 0 else float("nan"), "min": float(m.min()),
            "max": float(m.max()), "median": float(np.median(m))}


def trust_counts(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Of the ok tests: how many have a verdict (``n``), how many of those their checks trust
    (``k``), the names of the others (``untrusted``); and the same for E(t) at its first time
    (``et_k`` of ``et_n``)."""
    ok = [r for r in rows if r.get("status") == "ok"]
    known = [r for r in ok if r.get("trust_interval") is not None]
    et = [r for r in ok if r.get("Et_trust") is not None]
    return {"k": sum(bool(r["trust_interval"]) for r in known), "n": len(known), "ok": len(ok),
            "untrusted": [r["name"] for r in known if not r["trust_interval"]],
            "et_k": sum(bool(r["Et_trust"]) for r in et), "et_n": len(et)}


def modulus_at(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """E(t) at its first time across the ok tests that have it, at the time most of them share:
    that time, the mean, smallest and largest posterior mean, and how many tests (None: none)."""
    have = [r for r in rows if r.get("status") == "ok" and r.get("Et_mean") is not None]
    if not have:
        return None
    t, _ = Counter(r.get("Et_t_s") for r in have).most_common(1)[0]
    at = [r for r in have if r.get("Et_t_s") == t]
    m = np.array([r["Et_mean"] for r in at], float)
    return {"t_s": t, "n": len(at), "mean": float(m.mean()), "min": float(m.min()),
            "max": float(m.max()), "other_times": len(have) - len(at)}
