"""Sniffing a machine export: delimiter, decimal mark, header row, units row, metadata block and
specimen column groups (``data.format: auto``).

Exports such as Instron Bluehill write a metadata block, a blank line, a header row, a units row
("(s)", "[N]") and then the data; ZwickRoell and MTS exports often use ';' and a decimal comma.
The data block starts at the first run of numeric rows with the same number of fields; the header
is the text row above it (after an optional units row), and everything above the header is
metadata, never read. Every guess is reported in ``Layout.notes`` so a wrong one is visible.
"""

from __future__ import annotations

import csv
import math
from collections import Counter
from dataclasses import dataclass, field

from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.header_names import indexed_width
from bayes_dnlr.data.numbers import MISSING, has_thousands, parse_cell, plain_row
from bayes_dnlr.units import is_unit_cell, lookup, split_name

DELIMITERS = (",", ";", "\t", "|", "whitespace")
HEAD_LINES = 2000          # the structure (metadata, header, units, first data rows) must lie in these
RUN = 5                    # consecutive numeric rows that mark the start of the data


@dataclass
class Layout:
    """Where things are in the file; lines are counted from 1."""

    delimiter: str                      # one character, or "whitespace"
    decimal: str                        # "." or ","
    n_fields: int                       # fields of a data row
    data_line: int                      # first data row
    header_line: int | None = None
    header: list[str] | None = None     # the header names, stripped
    units_line: int | None = None
    units: list[str | None] = field(default_factory=list)   # per column, from the units row or the name
    unit_where: list[str] = field(default_factory=list)     # per column: where the unit came from
    metadata: tuple[int, int] | None = None
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.units:
            self.units = [None] * self.n_fields
            self.unit_where = [""] * self.n_fields

    def delimiter_text(self) -> str:
        return {"\t": "tab", " ": "space"}.get(self.delimiter, repr(self.delimiter) if
                                                self.delimiter != "whitespace" else "whitespace")


def split(line: str, delimiter: str) -> list[str]:
    """The cells of one line (quotes handled as in CSV)."""
    if delimiter == "whitespace":
        return line.split()
    try:
        return next(csv.reader([line], delimiter=delimiter), [])
    except csv.Error:       # a cell past the csv module's limit (131 072 characters): no quotes then
        return line.split(delimiter)


def _kind(cells: list[str], decimal: str) -> str:
    """'blank', 'numeric' (every non-empty cell a number), 'mixed' (at least half) or 'text'."""
    full = [c for c in cells if c.strip()]
    if not full:
        return "blank"
    numbers = sum(parse_cell(c, decimal) is not None for c in full)
    if numbers == len(full):
        return "numeric" if any(c.strip() not in MISSING for c in full) else "blank"
    return "mixed" if 2 * numbers >= len(full) else "text"


def _shape(line: str, delimiter: str, decimal: str) -> tuple[str, int, list[str] | None]:
    """(kind, number of fields, cells) of one line, as ``_kind`` and ``split`` give them. A row of
    plain numbers, the bulk of every file, is matched whole (``plain_row``) and its cells are not
    split (None): sniffing a 2000-line head cell by cell for every delimiter cost 0.2-0.3 s."""
    if '"' not in line and plain_row(delimiter, decimal).fullmatch(line):
        if delimiter == "whitespace":
            n = len(line.split())
        else:
            n = line.count(delimiter) + 1 if line else 0
        number = any(c.isdigit() for c in line) or "inf" in line.lower()
        return ("numeric" if number else "blank"), n, None
    cells = split(line, delimiter)
    return _kind(cells, decimal), len(cells), cells


@dataclass
class _Candidate:
    delimiter: str
    decimal: str
    start: int          # index of the first data line in head
    n_fields: int
    score: int          # numeric rows with n_fields fields
    thousands: int      # cells that need a thousands separator


def _candidate(head: list[str], delimiter: str, decimal: str) -> _Candidate | None:
    """The data start for one delimiter and decimal mark: the first row of numbers (at least two
    fields) that begins a run of RUN rows of numbers (blank lines aside), at least one of them all
    numbers; the number of fields is the commonest among the numeric rows from there."""
    shapes = [_shape(line, delimiter, decimal) for line in head]
    kinds = [k for k, _, _ in shapes]
    widths = [n for _, n, _ in shapes]
    like = [k in ("numeric", "mixed") and n >= 2 for k, n in zip(kinds, widths, strict=True)]
    n = len(head)
    for i in range(n):
        if not like[i]:
            continue
        run = [j for j in range(i, n) if kinds[j] != "blank"][:RUN]
        if not (all(like[j] for j in run) and any(kinds[j] == "numeric" for j in run)):
            continue
        counts = Counter(widths[j] for j in range(i, n) if kinds[j] == "numeric")
        f = max(counts, key=lambda c: (counts[c], c))
        body = [j for j in range(i, n) if kinds[j] == "numeric" and widths[j] == f]
        # a row matched whole holds no grouped thousands
        thousands = sum(has_thousands(c, decimal) for j in body[:200] for c in shapes[j][2] or ())
        return _Candidate(delimiter, decimal, i, f, len(body), thousands)
    return None


def _choose(head: list[str], delimiter: str | None, decimal: str | None) -> _Candidate | None:
    best = None
    for d in (delimiter,) if delimiter else DELIMITERS:
        if d != "whitespace" and not any(d in line for line in head):
            continue                 # every line one cell: no row of two fields to start the data
        for dec in (decimal,) if decimal else (".", ","):
            if d == dec:
                continue
            c = _candidate(head, d, dec)
            if c is None:
                continue
            key = (c.score, -c.thousands, c.n_fields)
            if best is None or key > best[0]:
                best = (key, c)
    return None if best is None else best[1]


def _nonblank_above(head: list[str], i: int) -> int | None:
    j = i - 1
    while j >= 0 and not head[j].strip(" \t,;|"):
        j -= 1
    return j if j >= 0 else None


def sniff(head: list[str], path: object, *, delimiter: str | None, decimal: str | None,
          header: bool | None) -> Layout:
    """The layout of a file whose first lines are ``head`` (line endings removed)."""
    c = _choose(head, delimiter, decimal)
    if c is None:
        what = f"delimiter {delimiter!r}" if delimiter else "any delimiter (, ; tab | whitespace)"
        raise DataError(f"{path}: 0 data row(s) found in the first {len(head)} line(s): no run of "
                        f"up to {RUN} rows of numbers with {what} and the same number of fields "
                        f"(set data.delimiter / data.decimal, or check the file)")
    d, dec = c.delimiter, c.decimal
    layout = Layout(d, dec, c.n_fields, c.start + 1)
    notes = [f"delimiter {layout.delimiter_text()}" + ("" if delimiter else " (detected)"),
             "decimal " + ("comma" if dec == "," else "point") + ("" if decimal else " (detected)")]
    j = _nonblank_above(head, c.start)
    if header is False:
        pass
    elif j is not None:
        cells = split(head[j], d)
        kind = _kind(cells, dec)
        above = _nonblank_above(head, j)
        if (kind == "text" and all(is_unit_cell(x) for x in cells) and any(x.strip() for x in cells)
                and above is not None and _kind(split(head[above], d), dec) == "text"):
            layout.units_line = j + 1
            layout.units = [x.strip() or None for x in cells]
            j = above
            cells = split(head[j], d)
            kind = "text"
        if kind == "text":
            layout.header_line = j + 1
            layout.header = [x.strip() for x in cells]
        elif header is True:
            raise DataError(f"{path}: data.header: true, but line {j + 1} above the first data row "
                            f"(line {c.start + 1}) is not a header row: {head[j][:80]!r}")
    elif header is True:
        raise DataError(f"{path}: data.header: true, but the data start at line 1 (no header row)")
    top = (layout.header_line or layout.data_line) - 1
    if any(line.strip() for line in head[:top]):
        first = next(i for i in range(top) if head[i].strip())
        last = max(i for i in range(top) if head[i].strip())
        numeric = [i + 1 for i in range(first, last + 1)
                   if _kind(split(head[i], d), dec) == "numeric" and len(split(head[i], d)) == c.n_fields]
        if numeric:
            where = (f"the header (line {layout.header_line})" if layout.header_line
                     else f"the first data row (line {layout.data_line})")
            raise DataError(f"{path}: line(s) {_ranges(numeric)} above {where} look like data rows "
                            f"({c.n_fields} numbers): the data block is interrupted; fix the file, or "
                            f"give data.rows and the columns by number")
        layout.metadata = (first + 1, last + 1)
        notes.append(f"metadata lines {first + 1}-{last + 1} (not read)")
    if layout.header is not None:
        notes.append(f"header line {layout.header_line}")
    elif header is not False:
        notes.append("no header row (columns by number)")
    _units(layout)
    if layout.units_line is not None:
        notes.append(f"units row line {layout.units_line}")
    layout.notes = notes
    return layout


def _units(layout: Layout) -> None:
    """Unit per column: the units row where it has one, else a unit in the header name."""
    n = layout.n_fields
    units: list[str | None] = [None] * n
    where = [""] * n
    for i in range(n):
        if layout.units_line is not None and i < len(layout.units) and layout.units[i]:
            units[i], where[i] = layout.units[i], f"units row line {layout.units_line}"
        elif layout.header is not None and len(layout.header) == n:
            # only from a header as long as the rows: the cells of one that is not do not sit over
            # their columns (a shifted header), and a unit read there would belong to another column
            name, unit = split_name(layout.header[i])
            if unit is not None and lookup(unit) is not None:
                units[i], where[i] = unit, "header"
    layout.units, layout.unit_where = units, where


def _ranges(lines: list[int]) -> str:
    return f"{lines[0]}" if len(lines) == 1 else f"{lines[0]}-{lines[-1]}"


def plain_layout(head: list[str], path: object, *, delimiter: str | None, decimal: str | None,
                 header: bool | None) -> Layout:
    """``data.format: plain``: a header at line 1 (unless header: false), data right below."""
    d = delimiter or ","
    dec = decimal or "."
    first = next((i for i, line in enumerate(head) if line.strip()), None)
    if first is None or first > 0:
        raise DataError(f"{path}: the file is empty" + (
            " (line 1 should be a header row naming the columns)" if header is not False else ""))
    cells = split(head[0], d)
    if header is False:
        return Layout(d, dec, len(cells), 1, notes=["format: plain"])
    layout = Layout(d, dec, len(cells), 2, header_line=1, header=[x.strip() for x in cells],
                    notes=["format: plain"])
    return layout


def specimen_groups(header: list[str] | None) -> int | None:
    """The width of repeated column groups (several specimens side by side), from repeated header
    names, or names that repeat once a specimen index is taken off ('Time 1', ..., 'Time 2');
    None when the names do not repeat. A separator column may end each group."""
    if header is None:
        return None
    return _repeated_names(header) or indexed_width(header)


def _repeated_names(header: list[str]) -> int | None:
    n = len(header)
    names = [split_name(h)[0].lower() for h in header]
    for p in range(1, n // 2 + 1):
        if not any(names[:p]):
            continue
        count = -(-n // p)
        ok = all(names[j] == names[j % p] for j in range(n))
        short = n % p == p - 1 and names[p - 1] == "" and all(names[j] == names[j % p] for j in range(n))
        if ok and (n % p == 0 or short) and count >= 2 and len(set(names[:p]) - {""}) >= 2:
            return p
    return None


def signature_groups(rows: list[list[float]], n_fields: int) -> int | None:
    """The width of repeated column groups in a file without a header: the smallest p (a divisor of
    the number of fields) for which every group has the same column signature (constant or not,
    increasing or not, sign, order of magnitude). None when no period fits."""
    if len(rows) < 3:
        return None
    cols = list(zip(*[r for r in rows if len(r) == n_fields], strict=False))
    if len(cols) != n_fields:
        return None

    def signature(col: tuple[float, ...]) -> tuple:
        vals = [v for v in col if v == v]
        if len(vals) < 3:
            return ("empty",)
        if max(vals) == min(vals):
            return ("constant", vals[0])
        ups = sum(b > a for a, b in zip(vals, vals[1:], strict=False)) / (len(vals) - 1)
        trend = "up" if ups > 0.9 else "down" if ups < 0.1 else "mixed"
        sign = "+" if min(vals) >= 0 else "-" if max(vals) <= 0 else "±"
        mid = sorted(abs(v) for v in vals)[len(vals) // 2] or max(abs(v) for v in vals)
        return ("varies", trend, sign, math.log10(mid))

    def same(a: tuple, b: tuple) -> bool:
        if a[0] != "varies" or b[0] != "varies":
            return a == b
        return a[1:3] == b[1:3] and abs(a[3] - b[3]) <= 1.0

    sig = [signature(c) for c in cols]
    for p in range(2, n_fields // 2 + 1):
        if n_fields % p:
            continue
        distinct = any(not same(sig[0], sig[j]) for j in range(1, p))
        if distinct and all(same(sig[j], sig[j % p]) for j in range(n_fields)):
            return p
    return None
