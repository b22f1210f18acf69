"""The tests of a batch by material, and each material's numbers for the batch page: E across its
tests (the spread between them beside the uncertainty within one), E(t) at the time every one of
them resolves with the test of agreement there (the one that decides "one material":
inference/analyses/heterogeneity.py), and how many of them their own checks trust (runs/trust.py;
the table's ``trust_interval`` and ``Et_trust``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bayes_dnlr.inference.analyses.agreement import agreement
from bayes_dnlr.runs.modulus_across import at_common_time
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


def modulus_compared(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """E(t) of the ok one-test rows (their ``modulus_at`` entries) at the time every one resolves
    (runs/modulus_across.py) and the test of agreement there (inference/analyses/agreement.py):
    ``t_s`` (None: no common time, ``why``), ``quantity``, ``n``, ``mean``, ``min``, ``max``,
    ``entries`` (name -> its entry at t_s), ``agreement`` (None with one test). None: no such row."""
    have = {r["name"]: r["modulus_at"] for r in rows
            if r.get("status") == "ok" and isinstance(r.get("modulus_at"), list)}
    if not have:
        return None
    at = at_common_time(have)
    if at.t is None:
        return {"t_s": None, "quantity": at.quantity, "n": len(have), "why": at.why, "entries": {},
                "agreement": None}
    m = np.array(list(at.values().values()), float)
    return {"t_s": at.t, "quantity": at.quantity, "n": int(m.size), "mean": float(m.mean()),
            "min": float(m.min()), "max": float(m.max()), "entries": at.entries, "why": "",
            "agreement": agreement(at.quantity, at.values(), at.sds())}


def first_modulus(row: dict[str, Any]) -> dict[str, Any] | None:
    """A row's E(t) at its own first time (the table's Et_* columns) as an entry, or None."""
    if row.get("Et_mean") is None:
        return None
    return {"t": row.get("Et_t_s"), "mean": row["Et_mean"], "sd": row.get("Et_sd"),
            "hdi_90": [row.get("Et_hdi_lo"), row.get("Et_hdi_hi")], "trust": row.get("Et_trust")}


def modulus_of_rows(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Each ok row's E(t) as the page shows it: at its material's common time
    (``modulus_compared``), else at its own first time. Name -> entry (``t``, ``mean``, ``sd``,
    ``hdi_90``, ``trust``)."""
    out: dict[str, dict[str, Any]] = {}
    for rs in by_material(rows).values():
        c = modulus_compared(rs) or {}
        for r in rs:
            e = (c.get("entries") or {}).get(r["name"]) or first_modulus(r)
            if r.get("status") == "ok" and e is not None:
                out[r["name"]] = dict(e)
    return out
