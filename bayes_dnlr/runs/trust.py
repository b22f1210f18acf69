"""A finished run's trust in a few flat fields, for the commands that show many runs at once
(batch, population, compare): whether E's interval can be used as it is, the verdict's first
sentence, the checks that fired, and the relaxation modulus E(t) at its first time with its own
trust. Read from summary.json's ``checks`` and ``modulus_at`` (docs/sampling.md, "Checks and
verdict"); a run of an earlier version without them gives None for each.

Names of the checks that fired (``fired``): ``coverage`` (the predictive band misses the data),
``sigma_inf``, ``tau_max``, ``tau_max_R``, ``E_chord`` (plausibility), ``noise_model``,
``model_form``, ``stress_shift``, ``bound:<parameter>`` (a prior bound that moves E by more than
SHIFT_SD posterior sd when widened), ``prior_sensitivity`` (the prior shapes E),
``not_converged``, and the key of any other check that records ``ok: false``. In a run with
several tests a per-test check carries the test's name: ``coverage[r5e-3]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from bayes_dnlr.runs.modulus_view import entries
from bayes_dnlr.runs.verdict import (
    COVERAGE_LOW,
    SEGMENT_LOW,
    SEGMENT_MIN_POINTS,
    SHIFT_SD,
    prior_shaped_e,
)

# the checks that fired -> their names; the keys read here, the rest by their ``ok`` flag
_KNOWN = ("predictive_coverage", "plausibility", "noise_model", "model_form", "stress_shift",
          "bound_limited",
          "prior_sensitivity", "prior_sources", "adequate", "trust_interval", "verdict",
          "verdict_points")
ET_FIELDS = ("t_s", "mean", "sd", "hdi_lo", "hdi_hi", "trust")


def _per_test(entry: Any, key: str) -> dict[str, Any]:
    """A per-test check as {test: value}: a run with one test stores it collapsed (its one value;
    recognised by ``key``, a field every value has), a run with several one value per test."""
    if not isinstance(entry, Mapping) or not entry:
        return {}
    if key in entry:
        return {"": entry}
    return {str(k): v for k, v in entry.items() if isinstance(v, Mapping)}


def _plausibility(entry: Any) -> dict[str, Mapping[str, Any]]:
    """The plausibility checks per test: collapsed in a run with one test (each value a check with
    its ``ok``), one mapping of them per test in a run with several."""
    if not isinstance(entry, Mapping) or not entry:
        return {}
    if all(isinstance(v, Mapping) and "ok" in v for v in entry.values()):
        return {"": entry}
    return {str(k): v for k, v in entry.items() if isinstance(v, Mapping)}


def _named(name: str, test: str) -> str:
    return f"{name}[{test}]" if test else name


def _coverage_failed(c: Mapping[str, Any]) -> bool:
    """The predictive band holds too few points overall, or in a segment with enough points."""
    low = [s for s in (c.get("segments") or {}).values()
           if s.get("share") is not None and (s.get("points") or 0) >= SEGMENT_MIN_POINTS
           and s["share"] < SEGMENT_LOW]
    return (c.get("overall") is not None and c["overall"] < COVERAGE_LOW) or bool(low)


def fired(checks: Mapping[str, Any] | None, converged: bool | None = None) -> list[str]:
    """The names of the checks of summary.json's ``checks`` that failed (module doc)."""
    if not checks:
        return [] if converged is not False else ["not_converged"]
    out: list[str] = []
    for test, c in _per_test(checks.get("predictive_coverage"), "overall").items():
        if _coverage_failed(c):
            out.append(_named("coverage", test))
    for test, kinds in _plausibility(checks.get("plausibility")).items():
        for kind, v in kinds.items():
            if isinstance(v, Mapping) and v.get("ok") is False:
                out.append(_named(kind, test))
    for key in ("noise_model", "model_form", "stress_shift"):
        for test, c in _per_test(checks.get(key), "ok").items():
            if c.get("ok") is False:
                out.append(_named(key, test))
    for b in checks.get("bound_limited") or []:
        if any(abs(v) > SHIFT_SD for v in (b.get("E_shift_sd") or {}).values()):
            out.append(f"bound:{b.get('parameter')}")
    if prior_shaped_e(checks.get("prior_sensitivity") or {}):
        out.append("prior_sensitivity")
    for key, v in checks.items():
        if key not in _KNOWN and isinstance(v, Mapping) and v.get("ok") is False:
            out.append(key)
    if converged is False:
        out.append("not_converged")
    return out


def verdict_head(checks: Mapping[str, Any] | None) -> str | None:
    """The verdict's first sentence (what to do with E's interval; the words before its
    ``verdict_points``), or None without a verdict."""
    if not checks or not checks.get("verdict"):
        return None
    words = str(checks["verdict"])
    tail = " ".join(str(p) for p in checks.get("verdict_points") or [])
    if tail and words.endswith(tail) and len(words) > len(tail):
        return words[: len(words) - len(tail)].strip()
    return words.split(". ")[0].rstrip(".") + "."     # a run without its points recorded


def first_modulus(at: list[Mapping[str, Any]]) -> dict[str, Any] | None:
    """E(t) at its first time as the flat fields ``ET_FIELDS`` (None without an entry)."""
    if not at:
        return None
    e = at[0]
    hdi = e.get("hdi_90") or [None, None]
    return {"t_s": e.get("t"), "mean": e.get("mean"), "sd": e.get("sd"), "hdi_lo": hdi[0],
            "hdi_hi": hdi[1], "trust": e.get("trust")}


def run_trust(summary: Mapping[str, Any] | None) -> dict[str, Any]:
    """The trust fields of a finished run: ``trust_interval``, ``adequate``, ``verdict`` (its first
    sentence), ``checks_fired`` (names, module doc), and ``Et`` (E(t) at its first time, ``ET_FIELDS``;
    per test in a run with several: ``Et[test]``). None where summary.json has no such entry."""
    summary = summary or {}
    checks = summary.get("checks") or {}
    out: dict[str, Any] = {
        "trust_interval": checks.get("trust_interval"), "adequate": checks.get("adequate"),
        "verdict": verdict_head(checks),
        "checks_fired": fired(checks, summary.get("converged")) if checks else None,
    }
    for test, at in entries(summary).items():
        first = first_modulus(at)
        if first is not None:
            out[_named("Et", test)] = first
    return out


def trusted_count(flags: list[bool | None]) -> tuple[int, int]:
    """(trusted, of): the tests whose flag is True, out of those with a flag at all."""
    known = [f for f in flags if f is not None]
    return sum(bool(f) for f in known), len(known)
