"""Header names against the values: the names are evidence, the confirmed relations are the truth.

A header can sit one column off its data (a name missing or inserted inside each specimen's group):
the name of a true stress then stands over the Hencky strain, the name of a strain over a copy of
the time. What the values confirm (data/relations.py: a true stress is an engineering stress ×
(1 + e); a column equal to the time on every row is the time) overrules what a name says, and each
overruled name gets a line that says which, and where its name would fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# what a name or a relation says a column is, and the broad kind it belongs to
BROAD = {"time": "time", "true stress": "stress", "engineering stress": "stress", "stress": "stress",
         "force": "force", "strain": "strain", "Hencky strain": "strain", "extension": "extension"}


@dataclass(frozen=True)
class Said:
    """What a column is: ``kind`` (a key of BROAD) and the evidence, in words (for a value role,
    the relation itself: 'column 8 = column 3 × (1 + column 2) (to 9e-10)')."""

    kind: str
    why: str


def _conflict(name: str, value: str) -> bool:
    if BROAD[name] != BROAD[value]:
        return True
    return {name, value} == {"true stress", "engineering stress"}


def time_copies(values: list[np.ndarray], time: int) -> dict[int, Said]:
    """Columns (0-based) equal to the time column ``time`` on every finite row, other than itself."""
    t = values[time]
    out = {}
    for j, v in enumerate(values):
        ok = np.isfinite(t) & np.isfinite(v)
        if j != time and ok.sum() >= 3 and np.ptp(t[ok]) > 0 and np.array_equal(v[ok], t[ok]):
            out[j] = Said("time", f"column {j + 1} = column {time + 1} on every row")
    return out


def overruled(names: dict[int, Said], values: dict[int, Said], labels: list[str]
              ) -> tuple[dict[int, str], list[str]]:
    """The columns (0-based) whose name a confirmed value role contradicts, and one line each.

    ``names``: what each named column's header name says; ``values``: what the relations and the
    time confirm (the true stress, the engineering stress and strain it is made of, the time and its
    copies); ``labels``: the header names, for the lines. A name that says a true stress where
    another column is the confirmed true stress is overruled as well."""
    out: dict[int, str] = {}
    confirmed = {s.kind: j for j, s in values.items()}
    for j, said in sorted(names.items()):
        value = values.get(j)
        if value is not None and _conflict(said.kind, value.kind):
            why = f"{value.why}: {_the(value.kind)}"
        elif value is None and said.kind == "true stress" and "true stress" in confirmed:
            other = confirmed["true stress"]
            why = f"{values[other].why}: the true stress is column {other + 1}"
        else:
            continue
        line = f"column {j + 1} is named '{labels[j]}' ({_a(said.kind)}), but {why}"
        fits = [k for k in (j - 1, j + 1) if k in names and values.get(j) is not None
                and not _conflict(names[k].kind, values[j].kind)]
        if fits:
            line += (f"; the name '{labels[fits[0]]}' over column {fits[0] + 1} fits it: the header is "
                     f"shifted against its data")
        out[j] = line
    return out, [out[j] for j in sorted(out)]


def _the(kind: str) -> str:
    return "the time" if kind == "time" else f"the {kind}" if kind != "strain" else "a strain"


def _a(kind: str) -> str:
    return {"time": "the time"}.get(kind, f"a {kind}" if kind[0] not in "aeiouAEIOU" else f"an {kind}")
