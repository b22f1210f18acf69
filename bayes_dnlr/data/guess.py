"""Guessing the columns of a machine export for ``init``: time, force or stress, strain or extension.

The file is read by the same sniffer as ``data.format: auto`` (delimiter, decimal mark, header, units
row, metadata, specimen column groups). A column's role comes from its header name or its unit when
there is one (``Time (s)``, ``Load``/``(N)``, ``Tensile strain``/``(%)``), else from its values:
an index counts 1, 2, 3; time increases at every row; a strain (or an extension) grows steadily with
time; a force or stress rises and then bends (yield, hardening). Every guess says how it was made and
which other columns could have been meant, so ``init`` can list what the user must check.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.numbers import parse_cell
from bayes_dnlr.data.reading import HEAD_LINES, Source, read_bytes
from bayes_dnlr.data.sniff import Layout, signature_groups, sniff, specimen_groups, split
from bayes_dnlr.units import lookup, split_name

SAMPLE_ROWS = 4000          # rows read (evenly spread over the file) to guess from the values
FRACTION_MAX = 3.0          # a strain column in fractions stays below this (Hencky 3 is extreme)
FORCE_MIN = 200.0           # a loading column above this, with no name or unit: a force in N
LINEAR_R2 = 0.98            # a strain driven by the machine grows (nearly) linearly with time

# name patterns (lower case, unit removed), in order: the first that matches gives the role
NAME_ROLES: tuple[tuple[str, re.Pattern[str]], ...] = tuple((r, re.compile(p)) for r, p in (
    ("index", r"^(index|#|no\.?|nr\.?|point|points|sample|row|n)$"),
    ("time", r"^t$|^t[_ ]|\btime\b|zeit|temps|tiempo|^sec"),
    ("eps22", r"transverse|lateral|width|quer|eps_?22|\be22\b|poisson"),
    ("extension", r"extension|elongation|displacement|crosshead|traverse|stroke|position|\bweg\b|verl"),
    ("force", r"load|force|kraft|charge|fuerza|^f$|^f[_ ]"),
    ("stress", r"stress|spannung|contrainte|sigma|^s$"),
    ("strain", r"strain|dehnung|eps|deform|^e$|^e11|ε"),
))
KIND_ROLE = {"time": "time", "force": "force", "stress": "stress", "strain": "strain",
             "length": "extension"}


@dataclass
class Column:
    """One column of the chosen specimen's group, with what was read about it."""

    number: int                  # counted from 1 within the group (as data.columns takes it)
    name: str | None             # header name, as written
    unit: str | None             # unit read from the file (units row or header), None: none
    values: np.ndarray           # a sample of its values, file units (NaN: missing)
    unit_in_suffix: bool = False  # the unit was read from a name such as 't_s' or 'F_kN'


    @property
    def label(self) -> str:
        return f"'{self.name}'" if self.name else f"column {self.number}"


@dataclass
class Pick:
    """One role's column and how it was chosen."""

    role: str
    column: Column
    how: str                              # 'header name', 'unit (N)', 'values: ...'
    others: list[Column] = field(default_factory=list)   # other columns that fit the role as well

    @property
    def sure(self) -> bool:
        return not self.how.startswith("values") and not self.others


@dataclass
class Guess:
    """The columns of one specimen of a file, and the facts ``init`` needs."""

    path: Path
    layout: Layout
    columns: list[Column]
    picks: dict[str, Pick]                # time, force|stress, strain|extension (when found)
    group: tuple[int, int] | None = None  # (specimens, columns per specimen) when there are several
    notes: list[str] = field(default_factory=list)

    @property
    def by_name(self) -> bool:
        return self.layout.header is not None


def _sample(src: Source, layout: Layout) -> np.ndarray:
    """Up to SAMPLE_ROWS data rows, evenly spread, as floats (NaN: missing or not a number)."""
    first, last = layout.data_line, src.n_lines
    while last >= first and not src.line(last).strip():
        last -= 1
    if last < first:
        raise DataError(f"{src.path}: no data rows after the header")
    step = max(1, (last - first + 1) // SAMPLE_ROWS)
    rows = []
    for n in range(first, last + 1, step):
        cells = split(src.line(n), layout.delimiter)
        row = [parse_cell(c, layout.decimal) for c in cells[:layout.n_fields]]
        row = [math.nan if v is None else v for v in row] + [math.nan] * (layout.n_fields - len(row))
        rows.append(row)
    return np.array(rows, dtype=float)


def read_columns(path: Path) -> tuple[Layout, list[Column], tuple[int, int] | None, list[str]]:
    """The sniffed layout and the columns of the first specimen (all columns without specimens)."""
    buf, notes = read_bytes(path, "utf-8")
    src = Source(buf, path)
    head = src.head(HEAD_LINES)
    if not any(line.strip() for line in head):
        raise DataError(f"{path}: the file is empty")
    layout = sniff(head, path, delimiter=None, decimal=None, header=None)
    src.layout = layout
    values = _sample(src, layout)
    f = layout.n_fields
    width = specimen_groups(layout.header)
    if width is None and layout.header is None:
        width = signature_groups([list(r) for r in values[:200]], f)
    group = (-(-f // width), width) if width is not None and f // width >= 2 else None
    n = group[1] if group else f
    cols = [Column(i + 1, layout.header[i] if layout.header and i < len(layout.header) else None,
                   layout.units[i] if i < len(layout.units) else None, values[:, i]) for i in range(n)]
    for c in cols:              # 't_s', 'F_kN': a unit after the last underscore (not read by the reader)
        if c.unit is None and c.name and "_" in c.name:
            suffix = c.name.rsplit("_", 1)[1]
            if lookup(suffix) is not None:
                c.unit, c.unit_in_suffix = suffix, True
    return layout, cols, group, [*layout.notes, *notes]


def _name_role(col: Column) -> str | None:
    if col.name is None:
        return None
    name = split_name(col.name)[0].strip().lower()
    for role, pattern in NAME_ROLES:
        if pattern.search(name):
            return role
    return None


def _unit_role(col: Column) -> str | None:
    hit = lookup(col.unit) if col.unit else None
    return KIND_ROLE.get(hit[0]) if hit else None


def _finite(v: np.ndarray) -> np.ndarray:
    return v[np.isfinite(v)]


def _is_index(v: np.ndarray) -> bool:
    v = _finite(v)
    return v.size >= 3 and bool(np.all(v == np.round(v))) and bool(np.all(np.diff(v) > 0)) and \
        float(np.min(np.diff(v))) >= 1 and len(set(np.diff(v).tolist())) <= 2


def _increasing(v: np.ndarray) -> float:
    """Share of the steps between finite samples that go up."""
    v = _finite(v)
    return float(np.mean(np.diff(v) > 0)) if v.size >= 3 else 0.0


def _r2(t: np.ndarray, v: np.ndarray) -> float:
    """R² of a straight line of v against t (finite pairs)."""
    ok = np.isfinite(t) & np.isfinite(v)
    if ok.sum() < 3 or np.ptp(v[ok]) == 0:
        return 0.0
    return float(np.corrcoef(t[ok], v[ok])[0, 1] ** 2)


def _rises(v: np.ndarray) -> bool:
    """The column ends clearly above where it starts and is not mostly negative."""
    f = _finite(v)
    if f.size < 3 or np.ptp(f) == 0:
        return False
    top = float(np.max(f))
    return top > 0 and float(np.min(f)) >= -0.05 * top and f[-1] - f[0] > 0.2 * np.ptp(f)


def guess_columns(path: Path) -> Guess:
    """Read the file's layout and guess time, force or stress, strain or extension (module doc)."""
    path = Path(path)
    layout, cols, group, notes = read_columns(path)
    picks: dict[str, Pick] = {}
    named: dict[str, list[tuple[Column, str]]] = {}
    for c in cols:
        u = _unit_role(c)
        r = _name_role(c)
        if u is not None and r not in ("eps22", "index"):
            role, how = u, f"unit {c.unit.strip().strip('()[]')}" + (" in the name" if c.unit_in_suffix
                                                                     else "")
        else:
            role, how = r, "header name"
        if role is not None:
            named.setdefault(role, []).append((c, how))
    for role in ("time", "force", "stress", "strain", "extension"):
        if named.get(role):
            (c, how), *rest = named[role]
            picks[role] = Pick(role, c, how, [o for o, _ in rest])
    used = {p.column.number for p in picks.values()} | {c.number for r in ("index", "eps22")
                                                         for c, _ in named.get(r, [])}
    free = [c for c in cols if c.number not in used and _finite(c.values).size >= 3]
    if "time" not in picks:
        index = [c for c in free if _is_index(c.values)]
        times = [c for c in free if c not in index and _increasing(c.values) > 0.99]
        if times:
            picks["time"] = Pick("time", times[0], "values: the first column that increases at every "
                                                   "row" + (f" ({index[0].label} counts rows: an index)"
                                                            if index else ""))
        free = [c for c in free if c not in index and c not in times[:1]]
    t = picks["time"].column.values if "time" in picks else np.arange(len(cols[0].values), dtype=float)
    if not any(r in picks for r in ("strain", "extension")):
        lin = [c for c in free if _rises(c.values) and _increasing(c.values) > 0.7
               and _r2(t, c.values) >= LINEAR_R2]
        lin.sort(key=lambda c: np.nanmax(c.values) > FRACTION_MAX)      # fractions first
        if lin:
            picks["strain"] = Pick("strain", lin[0], "values: grows steadily with time", lin[1:])
            free = [c for c in free if c is not lin[0]]
    if not any(r in picks for r in ("force", "stress")):
        load = [c for c in free if _rises(c.values) and np.nanmax(c.values) > FRACTION_MAX
                and (not picks.get("strain") or c not in picks["strain"].others)]
        load.sort(key=lambda c: (_r2(t, c.values) >= LINEAR_R2, np.nanmax(c.values) <= FORCE_MIN))
        if load:
            c = load[0]
            role = "force" if np.nanmax(c.values) > FORCE_MIN else "stress"
            picks[role] = Pick(role, c, f"values: rises and bends, up to {np.nanmax(c.values):.4g}",
                               load[1:])
    return Guess(path, layout, cols, picks, group, notes)
