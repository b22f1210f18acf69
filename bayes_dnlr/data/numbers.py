"""Numbers in a cell, strictly: ASCII digits, one decimal mark, optional grouped thousands.

Python's ``float()`` accepts ``6_54.93`` and full-width digits (``５０``); a machine export never
writes those, so they are refused here, with the reason. Missing-value tokens
(``NaN``, ``NA``, an empty cell) read as NaN, so the reader can tell padding from a bad cell.
"""

from __future__ import annotations

import math
import re
from functools import cache

MISSING = frozenset({"", "nan", "NaN", "NAN", "-nan", "-NaN", "NA", "N/A", "#N/A", "n/a"})
_INF = re.compile(r"^[+-]?(inf|infinity)$", re.IGNORECASE | re.ASCII)
_EXP = r"(?:[eE][+-]?[0-9]+)?"


def _plain_body(decimal: str) -> str:
    d = re.escape(decimal)
    return rf"[+-]?(?:[0-9]+(?:{d}[0-9]*)?|{d}[0-9]+){_EXP}"


@cache
def _patterns(decimal: str) -> tuple[re.Pattern[str], re.Pattern[str]]:
    """(plain number, number with grouped thousands) for a decimal mark '.' or ','."""
    d = re.escape(decimal)
    plain = re.compile(rf"^{_plain_body(decimal)}$", re.ASCII)
    groups = r"[,]" if decimal == "." else r"[. '\u00a0\u202f]"
    grouped = re.compile(rf"^[+-]?[0-9]{{1,3}}(?:{groups}[0-9]{{3}})+(?:{d}[0-9]*)?{_EXP}$", re.ASCII)
    return plain, grouped


def parse_cell(text: str, decimal: str = ".") -> float | None:
    """The number in ``text`` (NaN for a missing-value token, ±inf for inf), or None when it is not
    a number in this decimal mark. Grouped thousands (``1,234.5`` or ``1.234,5``) are accepted."""
    s = text.strip()
    if s in MISSING:
        return math.nan
    plain, grouped = _patterns(decimal)
    if plain.match(s):
        return float(s.replace(",", ".")) if decimal == "," else float(s)
    if grouped.match(s):
        body = re.sub(r"[,. '\u00a0\u202f]", lambda m: "." if m.group() == decimal else "", s)
        return float(body)
    if _INF.match(s):
        return math.inf if not s.startswith("-") else -math.inf
    return None


@cache
def plain_row(delimiter: str, decimal: str) -> re.Pattern[str]:
    """A whole row whose every cell is a plain number (no grouped thousands), ±inf, a missing-value
    token or empty, cells apart by ``delimiter`` (one character, or "whitespace") and padded by
    spaces or tabs. Matching a row of numbers whole is what ``parse_cell`` on each cell would say,
    at a fraction of the cost; a row it does not match (quotes, grouped thousands, other
    whitespace, text) is for ``parse_cell`` cell by cell."""
    token = "|".join([_plain_body(decimal), r"(?i:[+-]?inf(?:inity)?)",
                      *(re.escape(m) for m in sorted(MISSING - {""}, key=len, reverse=True))])
    if delimiter == "whitespace":
        return re.compile(rf"[ \t]*(?:(?:{token})(?:[ \t]+(?:{token}))*)?[ \t]*", re.ASCII)
    pad = "[ ]*" if delimiter == "\t" else "[ \t]*"
    cell = rf"{pad}(?:{token})?{pad}"
    return re.compile(rf"{cell}(?:{re.escape(delimiter)}{cell})*", re.ASCII)


def has_thousands(text: str, decimal: str = ".") -> bool:
    """True when ``text`` is a number written with grouped thousands."""
    plain, grouped = _patterns(decimal)
    s = text.strip()
    return not plain.match(s) and bool(grouped.match(s))


def why_not_a_number(text: str, decimal: str = ".") -> str:
    """A short hint for a cell that is not a number (empty string when there is none to give)."""
    s = text.strip()
    if not s:
        return " (empty cell)"
    if "_" in s:
        return " (underscores are not allowed in numbers)"
    if not s.isascii():
        odd = next(c for c in s if not c.isascii())
        return f" (character {odd!r}, U+{ord(odd):04X}: only ASCII digits are numbers)"
    other = "," if decimal == "." else "."
    if other in s and parse_cell(s.replace(other, decimal), decimal) is not None:
        return (" (decimal comma? the file's numbers use a decimal point: write numbers with a decimal "
                "point, or set data.decimal: ',')" if decimal == "." else
                " (decimal point in a file with decimal commas? set data.decimal: '.' if the file uses "
                "points)")
    return ""


SHOWN_CELL = 80             # characters of a cell an error message quotes


def shown_cell(text: str) -> str:
    """A cell as an error message quotes it: whole when short, else its start and its length (a
    cell of megabytes would bury the message)."""
    if len(text) <= SHOWN_CELL:
        return repr(text)
    return f"{text[:SHOWN_CELL]!r}... ({len(text):,} characters)"
