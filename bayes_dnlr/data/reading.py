"""Reading the CSV: the mapped columns as floats, every cell checked (file, line, column)."""

from __future__ import annotations

import csv
import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayes_dnlr.config import Columns
from bayes_dnlr.data.errors import DataError

ROLES = ("time", "force", "eps11", "eps22", "stress", "strain")
MIN_ROWS = 3


@dataclass(frozen=True)
class _Table:
    """The mapped columns of a CSV, as floats, with their cell texts and line numbers."""

    path: Path
    header: list[str]
    values: dict[str, np.ndarray]   # role -> floats
    texts: dict[str, list[str]]     # role -> cell texts
    names: dict[str, str]           # role -> header name
    lines: np.ndarray               # line number of each data row (header = line 1)

    def where(self, i: int, role: str) -> str:
        """'file, line N, column 'name'' for row index i."""
        return f"{self.path}, line {self.lines[i]}, column '{self.names[role]}'"


def _mapped(columns: Columns) -> dict[str, str]:
    """role -> header name for the roles the config maps ('column N' for a column number)."""
    out = {}
    for role in ROLES:
        v = getattr(columns, role)
        if v is not None:
            out[role] = f"column {v}" if isinstance(v, int) else v
    return out


def _looks_numeric(cells: Sequence[str]) -> bool:
    try:
        [float(c) for c in cells]
    except ValueError:
        return False
    return bool(cells)


def _header_index(path: Path, header: list[str], names: dict[str, str]) -> dict[str, int]:
    """Column index of each mapped role; errors name the config key and list the headers."""
    index = {}
    for role, name in names.items():
        hits = [i for i, h in enumerate(header) if h == name]
        if not hits and name.startswith("column "):
            raise DataError(f"{path}, line 1: {name} (data.columns.{role}) does not exist: the rows "
                            f"have {len(header)} columns")
        if not hits:
            hint = (" (the first line looks like numbers: give the columns by number with "
                    "data.header: false)" if _looks_numeric(header) else "")
            raise DataError(
                f"{path}, line 1: column '{name}' (data.columns.{role}) is not in the header; "
                f"the header has: {', '.join(repr(h) for h in header)}{hint}")
        if len(hits) > 1:
            cols = ", ".join(str(i + 1) for i in hits)
            raise DataError(f"{path}, line 1: column '{name}' (data.columns.{role}) appears "
                            f"{len(hits)} times in the header (columns {cols}): rename one")
        index[role] = hits[0]
    return index


def _read_rows(path: Path, delimiter: str, names: dict[str, str], has_header: bool = True
               ) -> tuple[list[str], dict[str, list[str]], list[int]]:
    """Header and the cell texts of the mapped columns, row by row, with line numbers.

    Without a header row (``data.header: false``) the names are 'column N', N counted from 1."""
    try:
        f = open(path, newline="", encoding="utf-8-sig")  # noqa: SIM115 - closed below
    except OSError as err:
        raise DataError(f"{path}: cannot open the data file: {err.strerror}") from None
    with f:
        reader = csv.reader(f, delimiter=delimiter)
        try:
            first = next(reader, [])
            if not any(c.strip() for c in first):
                raise DataError(f"{path}: the file is empty" + (
                    " (line 1 should be a header row naming the columns)" if has_header else ""))
            header = ([h.strip() for h in first] if has_header
                      else [f"column {i + 1}" for i in range(len(first))])
            index = _header_index(path, header, names)
            texts: dict[str, list[str]] = {r: [] for r in names}
            lines: list[int] = []
            blank = None
            rows = reader if has_header else itertools.chain([first], reader)
            for row in rows:
                if not any(c.strip() for c in row):
                    blank = blank or reader.line_num
                    continue
                if blank is not None:
                    raise DataError(f"{path}, line {blank}: empty line between data rows "
                                    f"(delete it; nothing is skipped silently)")
                if len(row) != len(header):
                    raise DataError(
                        f"{path}, line {reader.line_num}: {len(row)} fields, but "
                        f"{'the header' if has_header else 'the first row'} (line 1) "
                        f"has {len(header)} (delimiter {delimiter!r}, data.delimiter)")
                for role, i in index.items():
                    texts[role].append(row[i])
                lines.append(reader.line_num)
        except UnicodeDecodeError as err:
            raise DataError(f"{path}: not a UTF-8 text file ({err.reason})") from None
        except csv.Error as err:
            raise DataError(f"{path}, line {reader.line_num}: not valid CSV: {err}") from None
    return header, texts, lines


def _to_float(table_path: Path, role: str, name: str, texts: list[str], lines: list[int]) -> np.ndarray:
    """Cell texts -> floats; a non-numeric, NaN or infinite cell is an error naming line and column."""
    try:
        values = np.array(texts, dtype=float)
    except ValueError:
        values = None
    if values is not None:
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size == 0:
            return values
        i = int(bad[0])
        raise DataError(f"{table_path}, line {lines[i]}, column '{name}' ({role}): "
                        f"cell {texts[i]!r} is not a finite number")
    for i, text in enumerate(texts):
        try:
            float(text)
        except ValueError:
            hint = ""
            if "," in text and _looks_numeric([text.replace(",", ".")]):
                hint = " (decimal comma? write numbers with a decimal point)"
            elif not text.strip():
                hint = " (empty cell)"
            raise DataError(f"{table_path}, line {lines[i]}, column '{name}' ({role}): "
                            f"cell {text!r} is not a number{hint}") from None
    raise AssertionError("unreachable")  # pragma: no cover


def read_table(path: Path, columns: Columns, delimiter: str = ",", has_header: bool = True) -> _Table:
    """Read the mapped columns of a CSV (with a header row, or columns by number), checking every cell."""
    names = _mapped(columns)
    header, texts, lines = _read_rows(path, delimiter, names, has_header)
    if len(lines) < MIN_ROWS:
        raise DataError(f"{path}: {len(lines)} data row(s) after the header; at least {MIN_ROWS} "
                        f"are needed")
    values = {r: _to_float(path, r, names[r], texts[r], lines) for r in names}
    return _Table(path, header, values, texts, names, np.asarray(lines))
