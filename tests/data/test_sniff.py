"""The sniffer's whole-row match (``numbers.plain_row``) says of every line what reading it cell by
cell says: the same kind and the same number of fields, for every delimiter and decimal mark."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bayes_dnlr.data.numbers import plain_row
from bayes_dnlr.data.sniff import DELIMITERS, _kind, _shape, split

CELLS = ["1", "-2.5", "+.5", "3.", "1e-3", "2,5", "1,234.5", "1.234,5", "NaN", "nan", "-nan", "NA",
         "N/A", "#N/A", "n/a", "inf", "-Infinity", "+INF", "", " ", "\t", "x", "Time", "(s)", "1_0",
         "５", '"1,5"', '"a"', "1 2", "0x10", "nan(1)", "infx", "e5", "1e", ".", "-", "--1"]
PAIRS = [(d, dec) for d in DELIMITERS for dec in (".", ",") if d != dec]


def by_cells(line: str, delimiter: str, decimal: str) -> tuple[str, int]:
    cells = split(line, delimiter)
    return _kind(cells, decimal), len(cells)


@settings(max_examples=400, derandomize=True, deadline=None)
@given(st.lists(st.sampled_from(CELLS), max_size=6), st.sampled_from([",", ";", "\t", "|", " ", "  "]),
       st.sampled_from(PAIRS))
def test_a_line_is_read_whole_as_cell_by_cell(cells, joiner, pair):
    delimiter, decimal = pair
    line = joiner.join(cells)
    kind, n, _ = _shape(line, delimiter, decimal)
    assert (kind, n) == by_cells(line, delimiter, decimal), (line, delimiter, decimal)


@pytest.mark.parametrize(("line", "delimiter", "decimal", "expected"), [
    ("0.604,1.97e-4,NaN,0", ",", ".", ("numeric", 4)),
    ("NaN,NaN,NaN", ",", ".", ("blank", 3)),
    ("1;2,5;-3", ";", ",", ("numeric", 3)),
    ("  1.5\t 2  3 ", "whitespace", ".", ("numeric", 3)),
    ("", ",", ".", ("blank", 0)),
])
def test_rows_of_numbers_take_the_fast_path(line, delimiter, decimal, expected):
    assert plain_row(delimiter, decimal).fullmatch(line)
    kind, n, cells = _shape(line, delimiter, decimal)
    assert (kind, n) == expected == by_cells(line, delimiter, decimal)
    assert cells is None


@pytest.mark.parametrize(("line", "delimiter", "decimal"), [
    ("1,234.5;2", ";", "."),            # grouped thousands: read cell by cell
    ('"1",2', ",", "."),                 # quotes
    ("Time,Force", ",", "."),
    ("1,\v2", ",", "."),                # whitespace other than space and tab
])
def test_other_rows_are_read_cell_by_cell(line, delimiter, decimal):
    kind, n, cells = _shape(line, delimiter, decimal)
    assert cells is not None
    assert (kind, n) == by_cells(line, delimiter, decimal)
