"""Reading a test export: the mapped columns as floats in the package's units, every cell checked.

The file is decoded (UTF-8 unless ``data.encoding``), its layout sniffed (``sniff.py``) or taken as
plain, the specimen's column group and the rows chosen, and the mapped columns parsed by pandas'
C parser (strict: ``6_54.93`` or ``５０`` are not numbers). Trailing padding rows (empty or NaN in
every used column) are dropped with a note; any other missing or non-finite cell is an error that
names the file, the line and the column. Units come from the units row or the header names, unless
the config gives them (``data.units``, ``data.strain_unit``).
"""

from __future__ import annotations

import codecs
import csv
import io
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayes_dnlr.config import DataConfig
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.numbers import MISSING, parse_cell, shown_cell, why_not_a_number
from bayes_dnlr.data.sniff import (
    HEAD_LINES,
    Layout,
    plain_layout,
    signature_groups,
    sniff,
    specimen_groups,
    split,
)
from bayes_dnlr.data.temperature import column_in_celsius
from bayes_dnlr.units import PACKAGE_UNIT, ROLE_KIND, factor, lookup, split_name

ROLES = ("time", "force", "eps11", "eps22", "stress", "strain", "extension")
TEMPERATURE = "temperature"     # the role of a temperature column (data.temperature)
STRAIN_ROLES = ("eps11", "eps22", "strain")
MIN_ROWS = 3
# beyond these magnitudes (package units) a cell is not a measurement but a corrupt value
PLAUSIBLE = {"time": 1e9, "force": 1e9, "stress": 1e6, "strain": 1e6, "length": 1e9}
_CHUNK = 1 << 23


@dataclass
class Table:
    """The mapped columns of a file, as floats in the package's units, with their line numbers."""

    path: Path
    header: list[str]
    values: dict[str, np.ndarray]   # role -> floats (package units)
    names: dict[str, str]           # role -> column name for messages ('F_N' or 'column 3')
    lines: np.ndarray               # line number of each row (first line = 1)
    columns: dict[str, int] = field(default_factory=dict)   # role -> column index (0-based)
    layout: Layout | None = None
    notes: list[str] = field(default_factory=list)
    _source: Source | None = None
    group: tuple[int, int] = (0, 0)     # (first column, number of columns) of the specimen read

    def group_sample(self, rows: np.ndarray) -> list[np.ndarray]:
        """Every column of the specimen's group at the row indices ``rows``, as file values (NaN:
        not a number): the columns the config does not map, for checks that compare them."""
        first, width = self.group
        if self._source is None or self.layout is None or not width:
            return []
        fast = self._plain_group_sample(rows)
        if fast is not None:
            return fast
        out = np.full((rows.size, width), np.nan)
        for k, i in enumerate(rows):
            cells = split(self._source.line(int(self.lines[i])), self.layout.delimiter)[first:first + width]
            for j, c in enumerate(cells):
                x = parse_cell(c, self.layout.decimal)
                out[k, j] = np.nan if x is None else x
        return [out[:, j] for j in range(width)]

    def _plain_group_sample(self, rows: np.ndarray) -> list[np.ndarray] | None:
        """``group_sample`` by numpy's reader when the rows are plain (decimal point, every cell
        of the group a number or NaN): the same values, without a parse per cell; None otherwise."""
        first, width = self.group
        if self.layout.decimal != "." or not rows.size:
            return None
        text = "\n".join(self._source.line(int(self.lines[i])) for i in rows)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                arr = np.loadtxt(io.StringIO(text), dtype=float, ndmin=2, quotechar='"',
                                 usecols=range(first, first + width),
                                 delimiter=None if self.layout.delimiter == "whitespace"
                                 else self.layout.delimiter)
        except (ValueError, IndexError, UserWarning):
            return None
        if arr.shape != (rows.size, width):
            return None
        return [np.ascontiguousarray(arr[:, j]) for j in range(width)]

    def where(self, i: int, role: str) -> str:
        """'file, line N, column 'name'' for row index i."""
        return f"{self.path}, line {self.lines[i]}, column '{self.names[role]}'"

    def cell(self, i: int, role: str) -> str:
        """The text of row i's cell of ``role``, as written in the file."""
        if self._source is None:
            return repr(float(self.values[role][i]))
        return self._source.cell(int(self.lines[i]), self.columns[role])


class Source:
    """The file's text as UTF-8 bytes with '\\n' line ends, and where each line starts."""

    def __init__(self, buf: bytes, path: Path, layout: Layout | None = None):
        self.buf = buf
        self.path = path
        ends = []
        for start in range(0, len(buf), _CHUNK):
            chunk = np.frombuffer(buf, np.uint8, count=min(_CHUNK, len(buf) - start), offset=start)
            ends.append(np.flatnonzero(chunk == 10) + start)
        nl = np.concatenate(ends) if ends else np.zeros(0, np.int64)
        if not buf.endswith(b"\n"):
            nl = np.append(nl, len(buf))
        self.ends = nl
        self.starts = np.concatenate(([0], nl[:-1] + 1)) if nl.size else np.zeros(0, np.int64)
        self.layout = layout

    @property
    def n_lines(self) -> int:
        return int(self.ends.size)

    def line(self, number: int) -> str:
        i = number - 1
        return self.buf[self.starts[i]:self.ends[i]].decode("utf-8")

    def head(self, n: int) -> list[str]:
        k = min(n, self.n_lines)
        stop = int(self.ends[k - 1]) if k else 0
        return self.buf[:stop].decode("utf-8").split("\n")[:k] if k else []

    def cell(self, number: int, column: int) -> str:
        cells = split(self.line(number), self.layout.delimiter if self.layout else ",")
        return cells[column].strip() if column < len(cells) else ""


# --------------------------------------------------------------------------- the bytes

def read_bytes(path: Path, encoding: str) -> tuple[bytes, list[str]]:
    """The file as UTF-8 bytes with '\\n' line ends; notes on encoding and line ends."""
    if path.is_dir():
        raise DataError(f"{path}: is a directory, not a data file (data.file)")
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise DataError(f"{path}: data file not found") from None
    except OSError as err:
        raise DataError(f"{path}: cannot read the data file: {err.strerror}") from None
    notes = []
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        enc = "utf-16"
    elif raw.startswith(codecs.BOM_UTF8):
        enc, raw = "utf-8", raw[len(codecs.BOM_UTF8):]
    else:
        enc = encoding
    if codecs.lookup(enc).name == "utf-8":
        _check_utf8(raw, path)          # in chunks: no second copy of a large file
    else:
        try:
            raw = raw.decode(enc).encode("utf-8")
        except UnicodeDecodeError as err:
            _not_text(raw, err, enc, path)
        notes.append(f"encoding {enc}")
    nul = raw.find(b"\x00")
    if nul >= 0:
        line = raw.count(b"\n", 0, nul) + 1
        raise DataError(f"{path}, line {line}: a NUL byte: this is not a text (CSV) file")
    cr = raw.count(b"\r")
    if cr:
        crlf = raw.count(b"\r\n")
        raw = raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
        notes.append("line ends CRLF (Windows)" if crlf == cr else "line ends CR (old Mac)" if not crlf
                     else "line ends mixed CR/CRLF")
    return raw, notes


def _not_text(raw: bytes, err: UnicodeDecodeError, enc: str, path: Path) -> None:
    start = err.start
    line = raw.count(b"\n", 0, start) + 1
    raise DataError(f"{path}, line {line}: not a {enc} text file (byte {raw[start]:#04x} at offset {start}: "
                    f"{err.reason}); if it is text in another encoding, set data.encoding (e.g. cp1252 or "
                    f"latin-1)") from None


def _check_utf8(raw: bytes, path: Path) -> None:
    decoder = codecs.getincrementaldecoder("utf-8")()
    view = memoryview(raw)
    step = 1 << 22
    for i in range(0, len(raw), step):
        try:
            decoder.decode(view[i:i + step], final=i + step >= len(raw))
        except UnicodeDecodeError:
            try:                # the rare bad file: decode it whole to locate the byte exactly
                raw.decode("utf-8")
            except UnicodeDecodeError as err:
                _not_text(raw, err, "utf-8", path)


# --------------------------------------------------------------------------- columns

def _mapped(d: DataConfig) -> dict[str, str | int]:
    out = {r: getattr(d.columns, r) for r in ROLES if getattr(d.columns, r) is not None}
    if d.temperature_column is not None:
        out[TEMPERATURE] = d.temperature_column.column
    return out


def _key(role: str) -> str:
    """The config key that maps a role to its column."""
    return "data.temperature" if role == TEMPERATURE else f"data.columns.{role}"


def _looks_numeric(cells: list[str]) -> bool:
    return bool(cells) and all(parse_cell(c) is not None for c in cells)


def _or_nan(x: float | None) -> float:
    return math.nan if x is None else x


def _groups(layout: Layout, d: DataConfig, src: Source, path: Path, notes: list[str]
            ) -> tuple[int, int]:
    """(first column, number of columns) of the chosen specimen's group (the whole row without one)."""
    f = layout.n_fields
    aligned = layout.header is not None and len(layout.header) == f
    width = d.specimen_columns or (specimen_groups(layout.header) if aligned else None)
    how = "data.specimen_columns" if d.specimen_columns else "repeated header names"
    if width is None and not aligned:   # no header, or one whose cells do not sit over the columns
        sample = [[_or_nan(parse_cell(c, layout.decimal)) for c in split(src.line(n), layout.delimiter)]
                  for n in range(layout.data_line, min(layout.data_line + 200, src.n_lines + 1))]
        width = signature_groups(sample, f)
        how = "the same column pattern repeats"
    if d.specimen is None:
        if width is not None and f // width >= 2:
            notes.append(f"the columns look like {-(-f // width)} groups of {width} ({how}): several "
                         f"specimens? columns are counted across the whole row; data.specimen selects one")
        return 0, f
    if width is None:
        raise DataError(f"{path}: data.specimen: {d.specimen}, but the column groups of the specimens "
                        f"cannot be found (no repeated header names): give data.specimen_columns, the "
                        f"number of columns per specimen")
    count = -(-f // width)
    if d.specimen > count:
        raise DataError(f"{path}: data.specimen: {d.specimen}, but the file has {count} specimen(s) "
                        f"(groups of {width} columns, {how}; rows have {f} fields)")
    first = (d.specimen - 1) * width
    notes.append(f"specimen {d.specimen} of {count}: columns {first + 1}-{min(first + width, f)} "
                 f"(groups of {width}: {how})")
    return first, min(width, f - first)


def _column_index(layout: Layout, mapped: dict[str, str | int], group: tuple[int, int], path: Path,
                  d: DataConfig) -> tuple[dict[str, int], dict[str, str]]:
    """Column index and display name of each mapped role; errors name the config key."""
    first, width = group
    header = layout.header
    line = layout.header_line or layout.data_line
    index: dict[str, int] = {}
    names: dict[str, str] = {}
    for role, v in mapped.items():
        if isinstance(v, int):
            if v > width:
                where = (f"specimen {d.specimen}'s group has {width} columns" if d.specimen
                         else f"the rows have {layout.n_fields} columns")
                raise DataError(f"{path}, line {layout.data_line}: column {v} ({_key(role)}) "
                                f"does not exist: {where}")
            index[role] = first + v - 1
            # a header that is not as long as the rows does not name the columns by position
            names[role] = (f"column {first + v}" if header is None or len(header) != layout.n_fields
                           or not header[first + v - 1] else header[first + v - 1])
            continue
        if header is None:
            raise DataError(
                f"{path}, line {line}: column '{v}' ({_key(role)}) is not in the header: the "
                f"file has no header row (the first line looks like numbers): give the columns by "
                f"number (counted from 1, e.g. data.columns: {{{role}: 1}}); with format: plain, "
                f"data.header: false")
        group_names = header[first:first + width]
        hits = [i for i, h in enumerate(group_names) if h == v]
        if not hits:
            hits = [i for i, h in enumerate(group_names) if split_name(h)[0] == v]
        if not hits:
            hits = [i for i, h in enumerate(group_names) if split_name(h)[0].lower() == v.lower()]
        if not hits:
            hint = (" (the first line looks like numbers: give the columns by number with "
                    "data.header: false)" if _looks_numeric(header) else "")
            raise DataError(
                f"{path}, line {line}: column '{v}' ({_key(role)}) is not in the header; "
                f"the header has: {', '.join(shown_cell(h) for h in group_names)}{hint}")
        if len(hits) > 1:
            cols = ", ".join(str(first + i + 1) for i in hits)
            width_hint = specimen_groups(header)
            more = (f": the file holds {-(-len(header) // width_hint)} specimens side by side (groups of "
                    f"{width_hint} columns); choose one with data.specimen" if width_hint and not d.specimen
                    else ": rename one")
            raise DataError(f"{path}, line {line}: column '{v}' ({_key(role)}) appears "
                            f"{len(hits)} times in the header (columns {cols}){more}")
        index[role] = first + hits[0]
        names[role] = group_names[hits[0]]
    by_name = any(isinstance(v, str) for v in mapped.values())
    if header is not None and len(header) != layout.n_fields and by_name:
        raise DataError(f"{path}, line {layout.header_line}: the header names {len(header)} columns but "
                        f"the data rows (from line {layout.data_line}) have {layout.n_fields} fields "
                        f"(delimiter {layout.delimiter_text()}): the names cannot be matched to the "
                        f"columns safely; give the columns by number, or fix the header")
    return index, names


# --------------------------------------------------------------------------- rows

def _field_counts(src: Source, first: int, last: int, layout: Layout) -> np.ndarray:
    """Number of fields of lines first..last (1-based, inclusive); 0 for a blank line."""
    d = layout.delimiter
    a, b = int(src.starts[first - 1]), int(src.ends[last - 1])
    n = last - first + 1
    if d != "whitespace" and src.buf.find(b'"', a, b) < 0 and len(d.encode()) == 1:
        code = d.encode()[0]
        counts = np.empty(n, np.int64)
        starts, ends = src.starts[first - 1:last], src.ends[first - 1:last]
        step = 200_000
        for done in range(0, n, step):
            stop = min(n, done + step)
            s0, e0 = int(starts[done]), int(ends[stop - 1])
            chunk = np.frombuffer(src.buf, np.uint8, count=e0 - s0, offset=s0)
            where = np.flatnonzero(chunk == code)
            line = np.searchsorted(ends[done:stop] - s0, where)
            counts[done:stop] = np.bincount(line, minlength=stop - done) + 1
        counts[ends == starts] = 0
        return counts
    out = np.empty(n, np.int64)
    text = src.buf[a:b].decode("utf-8").split("\n")
    if d == "whitespace":
        for i, line in enumerate(text):
            out[i] = len(line.split())
        return out
    try:
        rows = list(csv.reader(text, delimiter=d))
    except csv.Error:       # a cell past the csv module's limit: each line as sniff.split reads it
        rows = [split(line, d) for line in text]
    for i, row in enumerate(rows):
        out[i] = len(row) if any(c.strip() for c in row) or len(row) > 1 else 0
    return out


PLAIN_MAX_LINES = 200_000   # up to this many rows numpy's reader is tried before pandas


def _parse_plain(src: Source, layout: Layout, first: int, last: int, cols: list[int]
                 ) -> dict[int, np.ndarray] | None:
    """The plain case of ``_parse`` without pandas (whose import costs 0.2-0.4 s, more than reading
    a test of a few thousand rows): decimal point, every cell of ``cols`` a finite number or a
    missing-value token, one row per line. numpy's C reader (``np.loadtxt``); None whenever the file
    is anything else (an empty cell, a bad cell, thousands, inf, a quoted line break), and
    ``_parse`` reads it with pandas."""
    n = last - first + 1
    if layout.decimal != "." or n > PLAIN_MAX_LINES or not cols:
        return None
    a, b = int(src.starts[first - 1]), int(src.ends[last - 1])
    text = src.buf[a:b].decode("utf-8")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")           # e.g. "input contained no data"
            arr = np.loadtxt(io.StringIO(text), dtype=float, ndmin=2, usecols=cols, quotechar='"',
                             delimiter=None if layout.delimiter == "whitespace" else layout.delimiter)
    except (ValueError, IndexError, UserWarning):
        return None
    if arr.shape != (n, len(cols)) or np.isinf(arr).any():
        return None
    # a NaN is a missing value (e.g. the padding rows of a shorter specimen) only when its cell is a
    # missing-value token as the cell-by-cell reading knows them; numpy also reads '+nan' or 'nan(1)'
    for i, k in zip(*np.nonzero(np.isnan(arr)), strict=True):
        if src.cell(first + int(i), cols[k]) not in MISSING:
            return None
    return {c: np.ascontiguousarray(arr[:, k]) for k, c in enumerate(cols)}


def _parse(src: Source, layout: Layout, first: int, last: int, cols: list[int]
           ) -> tuple[dict[int, np.ndarray], np.ndarray]:
    """The columns ``cols`` of lines first..last as floats (NaN for a missing value or a cell that is
    not a number), via numpy's reader in the plain case (``_parse_plain``), else pandas' C parser;
    a column pandas cannot read whole is parsed cell by cell (grouped thousands, or to find the bad
    cells). Also returns a mask of the bad cells (rows, cols)."""
    plain = _parse_plain(src, layout, first, last, cols)
    if plain is not None:
        return plain, np.zeros((last - first + 1, len(cols)), bool)
    import pandas as pd

    stream = io.BytesIO(src.buf)            # shares the bytes (no copy); read from line ``first``
    stream.seek(int(src.starts[first - 1]))
    n = last - first + 1
    sep = r"\s+" if layout.delimiter == "whitespace" else layout.delimiter
    try:
        df = pd.read_csv(stream, nrows=n, sep=sep, header=None, names=range(layout.n_fields),
                         usecols=cols, decimal=layout.decimal, quotechar='"', skip_blank_lines=False,
                         keep_default_na=False, na_values=sorted(MISSING), skipinitialspace=True,
                         low_memory=False, engine="c", encoding="utf-8")
    except (pd.errors.ParserError, ValueError) as err:   # e.g. a quote never closed
        row = re.search(r"row (\d+)", str(err))
        where = f"line {first + int(row.group(1))}" if row else f"lines {first}-{last}"
        raise DataError(f"{src.path}: {where}: the cells cannot be split ({str(err).splitlines()[0]}); "
                        'a quote (") without its closing quote?') from None
    if len(df) != n:
        raise DataError(f"{src.path}: lines {first}-{last}: {len(df)} rows read from {n} lines "
                        f"(a quoted cell spans several lines?)")
    out = {}
    bad = np.zeros((n, len(cols)), bool)
    for k, c in enumerate(cols):
        s = df[c]
        if s.dtype.kind in "fiu":
            out[c] = s.to_numpy(dtype=float)
            continue
        vals = np.empty(n)
        for i, v in enumerate(s.tolist()):
            if not isinstance(v, str):
                vals[i] = math.nan if v is None else float(v)
                continue
            x = parse_cell(v, layout.decimal)
            if x is None:
                vals[i], bad[i, k] = math.nan, True
            else:
                vals[i] = x
        out[c] = vals
    return out, bad


# --------------------------------------------------------------------------- the table

def read_table(path: Path, d: DataConfig) -> Table:
    """Read the columns ``d.columns`` maps from the file at ``path`` (see the module docstring)."""
    buf, notes = read_bytes(path, d.encoding)
    src = Source(buf, path)
    head = src.head(HEAD_LINES)
    if not any(line.strip() for line in head):
        raise DataError(f"{path}: the file is empty" + (
            " (line 1 should be a header row naming the columns)" if d.header is not False else ""))
    if d.format == "plain":
        layout = plain_layout(head, path, delimiter=d.delimiter, decimal=d.decimal, header=d.header)
    else:
        layout = sniff(head, path, delimiter=d.delimiter, decimal=d.decimal, header=d.header)
    src.layout = layout
    notes = ["format: " + ", ".join([*layout.notes, *notes]) if d.format == "auto" else
             "format: plain" + "".join(f", {n}" for n in notes)]
    mapped = _mapped(d)
    group = _groups(layout, d, src, path, notes)
    index, names = _column_index(layout, mapped, group, path, d)

    # rows: data rows counted from 1 at layout.data_line; trailing blank lines are not rows
    last_line = src.n_lines
    while last_line >= layout.data_line and not src.line(last_line).strip():
        last_line -= 1
    n_rows = last_line - layout.data_line + 1
    if n_rows < 1:
        raise DataError(f"{path}: 0 data row(s) after the header; at least {MIN_ROWS} are needed")
    first_row, last_row = d.rows.first, d.rows.last or n_rows
    if first_row > n_rows or last_row > n_rows:
        key = "first" if first_row > n_rows else "last"
        raise DataError(f"{path}: data.rows.{key}: {getattr(d.rows, key)} is past the last data row "
                        f"({n_rows}, line {last_line})")
    first, last = layout.data_line + first_row - 1, layout.data_line + last_row - 1
    if d.rows.first != 1 or d.rows.last is not None:
        notes.append(f"rows {first_row}-{last_row} of {n_rows} (lines {first}-{last}; data.rows)")

    cols = sorted(set(index.values()))
    raw, bad = _parse(src, layout, first, last, cols)
    lines = np.arange(first, last + 1)
    used = np.column_stack([raw[c] for c in cols])
    missing = np.isnan(used) & ~bad
    # trailing padding: empty or NaN in every used column, to the end
    full = np.flatnonzero(~missing.all(axis=1))
    if full.size == 0:
        raise DataError(f"{path}: lines {first}-{last}: no numbers in the used columns "
                        f"({', '.join(repr(names[r]) for r in index)})")
    keep = int(full[-1]) + 1
    if keep < lines.size:
        pad = lines.size - keep
        notes.append(f"padding: the last {pad} row(s) (lines {lines[keep]}-{lines[-1]}) are empty or NaN "
                     f"in every used column: dropped")
        lines, missing = lines[:keep], missing[:keep]
        raw = {c: v[:keep] for c, v in raw.items()}
    counts = _field_counts(src, int(lines[0]), int(lines[-1]), layout)
    wrong = np.flatnonzero((counts != layout.n_fields) & (counts != 0))
    if wrong.size:
        i = int(wrong[0])
        ref = (f"the header (line {layout.header_line})" if layout.header_line else
               f"the first data row (line {layout.data_line})")
        raise DataError(f"{path}, line {lines[i]}: {counts[i]} fields, but {ref} has {layout.n_fields} "
                        f"(delimiter {layout.delimiter_text()}, data.delimiter)")
    table = Table(path, layout.header or [], {}, names, lines, index, layout, notes, src, group)
    empty = missing.all(axis=1)
    for role, c in index.items():
        table.values[role] = _checked(table, role, raw[c], empty)
    if lines.size < MIN_ROWS:
        raise DataError(f"{path}: {lines.size} data row(s) after the header; at least {MIN_ROWS} "
                        f"are needed")
    _apply_units(table, d)
    return table


def _checked(table: Table, role: str, values: np.ndarray, empty: np.ndarray) -> np.ndarray:
    """Values of a column with every cell a finite number; else an error naming line and cell."""
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size == 0:
        return values
    i = int(bad[0])
    line = int(table.lines[i])
    if empty[i]:
        raise DataError(f"{table.path}, line {line}: empty line between data rows (delete it, or choose "
                        f"the rows with data.rows; nothing is skipped silently)")
    text = table.cell(i, role)
    layout = table.layout
    decimal = layout.decimal if layout else "."
    value = parse_cell(text, decimal)
    where = f"{table.path}, line {line}, column '{table.names[role]}' ({role})"
    if value is None:
        raise DataError(f"{where}: cell {shown_cell(text)} is not a number{why_not_a_number(text, decimal)}")
    if text.strip() in MISSING and text.strip():
        raise DataError(f"{where}: cell {shown_cell(text)} is not a finite number (a missing value in "
                        f"the middle of the data; only padding rows at the end are dropped)")
    if not text.strip():
        raise DataError(f"{where}: cell '' is not a number (empty cell)")
    raise DataError(f"{where}: cell {shown_cell(text)} is not a finite number")


def _apply_units(table: Table, d: DataConfig) -> None:
    """Convert each column to the package's unit: data.units > data.strain_unit > the file > default."""
    layout = table.layout
    converted = []
    for role, values in table.values.items():
        if role == TEMPERATURE:
            given = d.temperature_column.unit if d.temperature_column is not None else None
            c = table.columns[role]
            unit = given or (layout.units[c] if layout and c < len(layout.units) else None)
            table.values[role], note = column_in_celsius(
                values, unit, "data.temperature.unit" if given else "the file", table.names[role],
                table.path, lambda i: table.where(i, TEMPERATURE),
                lambda i: shown_cell(table.cell(i, TEMPERATURE)))
            converted += [note] if note else []
            continue
        kind = ROLE_KIND[role]
        c = table.columns[role]
        file_unit = layout.units[c] if layout and c < len(layout.units) else None
        file_where = layout.unit_where[c] if layout and file_unit else ""
        unit, source = None, ""
        if role in d.units:
            unit, source = d.units[role], "data.units"
        elif role in STRAIN_ROLES and d.strain_unit is not None:
            unit, source = ("%" if d.strain_unit == "percent" else "fraction"), "data.strain_unit"
        elif file_unit is not None:
            unit, source = file_unit, file_where
        if file_unit is not None and source.startswith("data.") and lookup(file_unit) is not None:
            fu, cu = factor(role, file_unit), factor(role, unit)
            if fu is not None and cu is not None and fu != cu:
                table.notes.append(f"warning: column '{table.names[role]}' ({role}) is in {file_unit} "
                                   f"by the {file_where}, but {source} says {unit}: {source} wins")
        if unit is None:
            continue
        f = factor(role, unit)
        if f is None:
            hit = lookup(unit)
            if hit is not None and hit[0] == "length" and kind == "strain":
                raise DataError(f"{table.path}: column '{table.names[role]}' ({role}) is in {unit} "
                                f"({source}): a length, not a strain; map it as data.columns.extension "
                                f"with data.gauge_length, or set data.units.{role}")
            raise DataError(f"{table.path}: column '{table.names[role]}' ({role}) has the unit {unit!r} "
                            f"({source}), which is not a unit of {kind}; set data.units.{role} "
                            f"(e.g. {PACKAGE_UNIT[kind] if kind != 'strain' else '% or fraction'})")
        shown = unit.strip().strip("()[]").strip()
        if f != 1.0:
            table.values[role] = values * f
            converted.append(f"'{table.names[role]}' in {shown} -> {PACKAGE_UNIT[kind]} (×{f:g}, {source})")
        elif source and not source.startswith("data."):
            converted.append(f"'{table.names[role]}' in {shown} ({source})")
    if converted:
        table.notes.append("units: " + "; ".join(converted))
    for role, values in table.values.items():
        if role == TEMPERATURE:
            continue
        limit = PLAUSIBLE[ROLE_KIND[role]]
        big = np.flatnonzero(np.abs(values) > limit)
        if big.size:
            i = int(big[0])
            kind = ROLE_KIND[role]
            raise DataError(f"{table.where(i, role)} ({role}): cell {shown_cell(table.cell(i, role))} "
                            f"is not a plausible {kind} (|value| > {limit:g} {PACKAGE_UNIT[kind]}): a "
                            f"corrupt or misplaced value")

