"""Text cells of the CSV files the package writes (results.csv, compare.csv, design.csv), safe to
open in a spreadsheet.

A spreadsheet runs a cell that starts with ``=``, ``+``, ``-`` or ``@`` (and some also one after
leading blanks, a tab or a carriage return, or a full-width ``＝``) as a formula: a manifest cell
``=HYPERLINK("http://…","x")`` copied into results.csv would become a live link, or worse. Such a
text cell is written with a leading apostrophe, which spreadsheets show as text (OWASP's advice
for CSV injection). Numbers, and text that reads as one (``-1.5``, ``-inf``), are left as they are:
a negative number stays a number.
"""

from __future__ import annotations

from typing import Any

FORMULA_START = frozenset("=+-@＝＋－＠")
CONTROL_START = ("\t", "\r", "\n")


def _number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def is_formula(text: str) -> bool:
    """True when a spreadsheet could read ``text`` as a formula (see the module doc)."""
    if text.startswith(CONTROL_START):
        return True
    head = text.lstrip(" \t\r\n")
    return len(head) > 1 and head[0] in FORMULA_START and not _number(text)


def safe_cell(value: Any) -> Any:
    """``value`` as a CSV cell: a text that could be read as a formula gets a leading apostrophe;
    anything else is returned as it is."""
    if isinstance(value, str) and is_formula(value):
        return "'" + value
    return value
