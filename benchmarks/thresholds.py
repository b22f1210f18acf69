"""The trust thresholds of runs/verdict.py on data they were chosen on and on data they were not.

Reads the replicate records of benchmarks/misspecification.py (``--out``), each file labelled
``in`` (the kinds, strength and seeds a threshold was chosen on: mild strength, replicates 0-29)
or ``out`` (other seeds, other strengths, generators that were not used: ``HELD_OUT_KINDS``), and
prints per kind and strength the range of each number a threshold is compared with
(summary.json's checks, ``check_values`` of a record), with the outcome of the checks:

- ``coverage`` against COVERAGE_LOW (0.80) and ``segment_min`` against SEGMENT_LOW (0.50);
- ``E_weighted``, split by replicates whose E interval held the truth and those where it did
  not, against E_WEIGHTED_LOW (0.99): the rule decides only where the coverage check fails
  (overall or a segment);
- ``score_z`` against SCORE_Z (2.5) and the shifts of E (model form, bound) against SHIFT_SD (1);
- covered or flagged: E's 90 % HDI holds the truth, or the checks withdraw trust.

    .venv/bin/python benchmarks/misspecification.py --likelihoods default --replicates 10 \\
        --first 0 --out in.json                        # the tuning seeds
    .venv/bin/python benchmarks/misspecification.py --likelihoods default --replicates 10 \\
        --first 100 --out out.json                     # other seeds
    .venv/bin/python benchmarks/thresholds.py in=in.json out=out.json out=other.json ...
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bayes_dnlr.runs import verdict as checks  # noqa: E402

STATS = (("coverage", checks.COVERAGE_LOW), ("segment_min", checks.SEGMENT_LOW),
         ("score_z", checks.SCORE_Z), ("score_shift_sd", checks.SHIFT_SD),
         ("bound_shift_sd", checks.SHIFT_SD))


def _span(values: list[float], digits: int = 3) -> str:
    v = [x for x in values if x is not None]
    if not v:
        return "—"
    return f"{min(v):.{digits}f}" if len(set(v)) == 1 else f"{min(v):.{digits}f}-{max(v):.{digits}f}"


def _coverage_fails(c: dict[str, Any]) -> bool:
    """The coverage check fails: overall below COVERAGE_LOW or a segment below SEGMENT_LOW."""
    return ((c.get("coverage") is not None and c["coverage"] < checks.COVERAGE_LOW)
            or (c.get("segment_min") is not None and c["segment_min"] < checks.SEGMENT_LOW))


def rows(records: list[tuple[str, dict[str, Any]]]) -> list[str]:
    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    for label, r in records:
        if "error" in r:
            continue
        groups.setdefault((label, r["kind"], str(r["strength"])), []).append(r)
    head = (f"{'set':<4}{'kind':<25}{'strength':<9}{'n':>3}{'cov|flag':>9}{'flag':>5}  "
            + "  ".join(f"{k} (<{t:g})" if k in ("coverage", "segment_min") else f"{k} (>{t:g})"
                        for k, t in STATS)
            + "  E_weighted covered / not covered where the coverage check fails "
              f"(<{checks.E_WEIGHTED_LOW:g})")
    out = [head]
    for (label, kind, strength), rs in sorted(groups.items(), key=lambda g: (g[0][1], g[0][0], g[0][2])):
        n = len(rs)
        ok = sum((r["covered"] and not r["flagged"]) or r["flagged"] for r in rs)
        flagged = sum(r["flagged"] for r in rs)
        cv = [r.get("check_values") or {} for r in rs]
        stats = "  ".join(f"{_span([c.get(k) for c in cv]):>13}" for k, _ in STATS)
        failing = [(r, c) for r, c in zip(rs, cv, strict=True) if _coverage_fails(c)]
        ew = (f"{_span([c.get('E_weighted') for r, c in failing if r['covered']], 4)} / "
              f"{_span([c.get('E_weighted') for r, c in failing if not r['covered']], 4)}"
              if failing else "(coverage passes)")
        out.append(f"{label:<4}{kind:<25}{strength:<9}{n:>3}{ok / n:>9.2f}{flagged / n:>5.2f}  {stats}  {ew}")
    return out


def main(argv: list[str]) -> int:
    if not argv or any("=" not in a for a in argv):
        print(__doc__)
        return 2
    records = []
    for arg in argv:
        label, _, path = arg.partition("=")
        records += [(label, r) for r in json.loads(Path(path).read_text())]
    print("\n".join(rows(records)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
