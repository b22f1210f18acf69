"""The mutation score of each decision module from mutmut's results (mutants/**/*.meta), after
`make mutants` (docs/mutation-testing.md).

Per module: mutants killed (a test failed, or the run timed out), survived, with no test reaching
them, not yet checked, and the score killed / checked. A survivor that docs/mutation-testing.md
names (its mutant name in backquotes) is listed as documented; any other survivor is printed, and
the exit code is 1 while one is left.

    .venv/bin/python scripts/mutation_score.py [--all]     # --all: every survivor, documented too
"""

from __future__ import annotations

import json
import re
import sys
from collections import Counter, defaultdict
from pathlib import Path

from mutmut.stats import status_by_exit_code

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "mutation-testing.md"
KILLED = ("killed", "timeout", "caught by type check", "segfault")


def results() -> dict[str, str]:
    """mutant name -> mutmut's status."""
    out = {}
    for meta in sorted((ROOT / "mutants").glob("**/*.meta")):
        for name, code in json.loads(meta.read_text())["exit_code_by_key"].items():
            out[name] = status_by_exit_code[code]
    return out


def module_of(mutant: str) -> str:
    return re.sub(r"\.x.*$", "", mutant.split("__mutmut_")[0])


def main(argv: list[str]) -> int:
    status = results()
    if not status:
        print("no results: run `make mutants` first")
        return 2
    documented = set(re.findall(r"`([\w.ǁ]+__mutmut_\d+)`", DOC.read_text())) if DOC.exists() else set()
    counts: dict[str, Counter] = defaultdict(Counter)
    left = []
    for name, s in status.items():
        counts[module_of(name)][s] += 1
        if s in ("survived", "no tests"):
            if name in documented:
                counts[module_of(name)]["documented"] += 1
            if name not in documented or "--all" in argv:
                left.append((name, s))
    print(f"{'module':<34}{'mutants':>8}{'killed':>8}{'survived':>9}{'no test':>8}{'unchecked':>10}"
          f"{'score':>7}{'documented':>11}")
    for module, c in sorted(counts.items()):
        killed = sum(c[k] for k in KILLED)
        checked = killed + c["survived"] + c["no tests"]
        score = f"{killed / checked:.2f}" if checked else "—"
        print(f"{module:<34}{sum(c[k] for k in c if k != 'documented'):>8}{killed:>8}{c['survived']:>9}"
              f"{c['no tests']:>8}{c['not checked']:>10}{score:>7}{c['documented']:>11}")
    for name, s in sorted(left):
        print(f"{s}: {name}" + ("  (documented)" if name in documented else ""))
    return 1 if any(n not in documented for n, _ in left) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
