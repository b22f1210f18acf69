"""E(t) across finished runs: the time at which they are compared, and each run's E(t) there.

The commands that show many runs at once (batch, population, compare) decide whether tests look
like one material on E(t), the quantity the package tells users to quote (inference/analyses/
heterogeneity.py). E(t) of two tests compare only at one time that both resolve: each entry of
summary.json's ``modulus_at`` has its time ``t`` and ``resolved`` = [shortest, longest], the times
the test's data determine. The common time is the shortest of the times at which every run has an
entry and which every run resolves (the one nearest E, which E(t) stands for). Where there is none
(an entry missing, or a time outside a run's ``resolved``, or a run of an earlier version without
``resolved``), there is no E(t) to compare and the caller falls back to E, saying why (``why``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from bayes_dnlr.numbers import fmt
from bayes_dnlr.runs.modulus_view import entries

Entries = Sequence[Mapping[str, Any]]
KEPT = ("t", "mean", "sd", "hdi_90", "trust", "resolved")     # what a comparison reads of an entry


def run_entries(summary: Mapping[str, Any] | None) -> list[dict[str, Any]] | None:
    """The E(t) entries of a one-test run's summary.json, with the fields a comparison reads
    (``KEPT``); None for a run with several tests or without E(t)."""
    per_test = entries(summary or {})
    if set(per_test) != {""}:
        return None
    return [{k: e.get(k) for k in KEPT} for e in per_test[""]]


@dataclass(frozen=True)
class AtCommonTime:
    """E(t) of each run at the common time ``t`` (None: no common time, ``why`` says why)."""

    t: float | None
    entries: dict[str, Mapping[str, Any]] = field(default_factory=dict)    # run -> its entry at t
    why: str = ""

    @property
    def quantity(self) -> str:
        return "E" if self.t is None else f"E({fmt(self.t, 3)} s)"

    def values(self) -> dict[str, float]:
        return {k: float(e["mean"]) for k, e in self.entries.items()}

    def sds(self) -> dict[str, float]:
        return {k: float(e["sd"]) for k, e in self.entries.items()}


def _resolves(entry: Mapping[str, Any]) -> bool:
    r = entry.get("resolved")
    if not isinstance(r, Sequence) or len(r) != 2 or entry.get("t") is None:
        return False
    lo, hi, t = float(r[0]), float(r[1]), float(entry["t"])
    return lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)


def _at(entries: Entries, t: float) -> Mapping[str, Any] | None:
    for e in entries:
        if e.get("t") is not None and math.isclose(float(e["t"]), t, rel_tol=1e-9):
            return e
    return None


def _usable(e: Mapping[str, Any] | None) -> bool:
    return (e is not None and _resolves(e) and e.get("mean") is not None and e.get("sd") is not None
            and math.isfinite(float(e["mean"])) and math.isfinite(float(e["sd"])) and e["sd"] > 0)


def at_common_time(runs: Mapping[str, Entries]) -> AtCommonTime:
    """The common time of the module doc over ``runs`` (name -> its ``modulus_at`` entries) and
    each run's entry there."""
    if not runs:
        return AtCommonTime(None, why="no runs")
    missing = [k for k, at in runs.items() if not at]
    if missing:
        return AtCommonTime(None, why=f"no E(t) in {_names(missing)} (summary.json without "
                                      "modulus_at)")
    times = sorted({float(e["t"]) for at in runs.values() for e in at if e.get("t") is not None})
    for t in times:
        found = {k: _at(at, t) for k, at in runs.items()}
        if all(_usable(e) for e in found.values()):
            return AtCommonTime(t, {k: e for k, e in found.items() if e is not None})
    return AtCommonTime(None, why="no time at which every test has E(t) and resolves it ("
                                  + "; ".join(_found_at(runs, t) for t in times) + ")")


def _found_at(runs: Mapping[str, Entries], t: float) -> str:
    """Which runs have E(t) at ``t``, and which of them do not resolve it."""
    have = [k for k, at in runs.items() if _at(at, t) is not None]
    unresolved = [k for k in have if not _usable(_at(runs[k], t))]
    text = f"at {fmt(t, 3)} s: {_names(have)}"
    if unresolved:
        text += f", not resolved by {_names(unresolved)}"
    return text


def _names(names: list[str], limit: int = 3) -> str:
    more = len(names) - limit
    if more > 1:
        return f"{len(names)} tests ({', '.join(names[:limit])} and {more} more)"
    return ", ".join(names)
