"""Rows that repeat the time stamp of the row before them (``data.repeated_time``).

Some loggers write a row twice, or write a new row with the last time stamp: the time column then
holds equal values in consecutive rows. The model needs a strictly increasing time (each sample is
a step of the strain history), so such rows are either dropped (the first row of each time stamp
is kept) or averaged (every column's mean over the rows of one time stamp), with a data note of
how many. A time that goes back is not a repeat and stays an error (data/checks.py).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.reading import Table

KEY = "data.repeated_time"


class RepeatedTime(DataError):
    """The time column repeats a time stamp and ``data.repeated_time`` does not say what to do;
    ``seen``: how many rows, and which lines, in words."""

    def __init__(self, message: str, seen: str):
        super().__init__(message)
        self.seen = seen


def repeated(time: np.ndarray) -> np.ndarray:
    """Indices i whose time equals the time of row i - 1 (the repeats)."""
    return np.flatnonzero(np.diff(time) == 0) + 1


def _lines(lines: np.ndarray, idx: np.ndarray) -> str:
    shown = ", ".join(str(int(lines[i])) for i in idx[:3])
    return shown + (f" and {idx.size - 3} more" if idx.size > 3 else "")


def refuse_repeats(table: Table) -> None:
    """Stop at the first repeated time stamp when ``data.repeated_time`` is not set, naming the key."""
    rep = repeated(table.values["time"])
    if not rep.size:
        return
    i = int(rep[0])
    seen = (f"{rep.size} row(s) repeat the time stamp of the row before them (line(s) "
            f"{_lines(table.lines, rep)})")
    raise RepeatedTime(
        f"{table.path}, column '{table.names['time']}': time must increase strictly: line "
        f"{table.lines[i - 1]} has {table.cell(i - 1, 'time')} and line {table.lines[i]} has "
        f"{table.cell(i, 'time')}; {seen}: set {KEY}: drop (keep the first row of each time stamp) or "
        f"average (their mean)", seen)


def merge_repeats(table: Table, how: str | None) -> tuple[Table, list[str]]:
    """The table without repeated time stamps (``how``: drop | average), and its note; the table
    itself when no time repeats. ``how`` None refuses repeats (``refuse_repeats``)."""
    if "time" not in table.values:
        return table, []
    time = table.values["time"]
    rep = repeated(time)
    if not rep.size:
        return table, []
    if how is None:
        back = np.flatnonzero(np.diff(time) < 0)
        if not back.size or back[0] + 1 > rep[0]:     # a time that goes back first: its own error
            refuse_repeats(table)
        return table, []
    first = np.ones(time.size, bool)
    first[rep] = False
    starts = np.flatnonzero(first)
    if how == "average":
        counts = np.diff(np.append(starts, time.size))
        values = {r: np.add.reduceat(v, starts) / counts for r, v in table.values.items()}
        done = "each time stamp's rows averaged"
    else:
        values = {r: v[starts] for r, v in table.values.items()}
        done = "dropped, the first row of each time stamp kept"
    note = (f"repeated time stamps: {rep.size} row(s) repeat the time stamp of the row before them "
            f"(line(s) {_lines(table.lines, rep)}): {done} ({KEY}: {how})")
    return replace(table, values=values, lines=np.asarray(table.lines)[starts]), [note]
