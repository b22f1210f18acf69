"""Machine exports read as they are (and their bad cells).

A corpus of export variants generated from one synthetic test: delimiters, decimal marks, metadata
blocks, units rows, padding, percent, kN and ms, several specimens side by side, Windows and old-Mac
line ends. Each must load to the same arrays as the plain CSV (to 1e-12), or give a named error.
No real data is copied here.
"""

from __future__ import annotations

import codecs
from pathlib import Path

import numpy as np
import pytest

from bayes_dnlr.config import parse_config
from bayes_dnlr.data import DataError, load_test

N = 60
_rng = np.random.default_rng(42)
TIME = np.round(np.arange(N) * 0.25, 6)                                    # s
STRAIN = np.round(0.004 * TIME + _rng.normal(0, 1e-4, N) + 1e-4, 8)      # nominal fraction, > 0
FORCE = np.round(3500.0 * np.tanh(STRAIN / 0.02) + _rng.normal(0, 2.0, N), 6)   # N, up to ~1300
BASE = {"area0": 24.0, "strain_measure": "nominal", "strain_input": "measured"}
COLUMNS = {"time": "t_s", "force": "F_N", "strain": "e"}


def f6(x: float) -> str:
    return f"{x:.6f}"


def rows(time=TIME, force=FORCE, strain=STRAIN, *, tf=f6, ff=f6, ef=lambda x: f"{x:.8f}") -> list[list[str]]:
    return [[tf(t), ff(f), ef(e)] for t, f, e in zip(time, force, strain, strict=True)]


def text(header: list[str] | None, body: list[list[str]], sep: str = ",", *, top: str = "",
         units: list[str] | None = None, end: str = "\n") -> str:
    lines = [top.rstrip("\n")] if top else []
    if top:
        lines.append("")
    if header is not None:
        lines.append(sep.join(header))
    if units is not None:
        lines.append(sep.join(units))
    lines += [sep.join(r) for r in body]
    return end.join(lines) + end


def comma(rows_: list[list[str]]) -> list[list[str]]:
    return [[c.replace(".", ",") for c in r] for r in rows_]


def thousands(x: float) -> str:
    return f'"{x:,.6f}"'


PLAIN = text(["t_s", "F_N", "e"], rows())
BLUEHILL_TOP = '"Sample","S-12"\n"Method","Tensile ISO 527"\n"Width","10.00","mm"\n"Thickness","2.40","mm"'
ZWICK_TOP = "Prüfer;Dr. Müller\nProbe;Nr. 3\nVorkraft;0,5;N"


def german(x: float) -> str:
    """1234.5 -> '1.234,500000' (thousands '.', decimal ',')."""
    return f"{x:,.6f}".replace(",", " ").replace(".", ",").replace(" ", ".")


def kn(x: float) -> str:
    return f"{x / 1000:.9f}"


def pct(x: float) -> str:
    return f"{100 * x:.6f}"


def ms(x: float) -> str:
    return f"{1000 * x:.3f}"


def specimens(header: bool, width_extra: int = 0) -> str:
    """Three specimens side by side; the second is the reference test; the others are shorter
    and padded at the end."""
    other = rows(force=FORCE * 0.9)
    out = []
    for i in range(N):
        a = other[i] if i < N - 10 else ["NaN"] * 3
        c = other[i] if i < N - 20 else [""] * 3
        extra = [str(i)] * width_extra
        out.append([*extra, *a, *extra, *rows()[i], *extra, *c])
    head = [*(["index"] * width_extra), "t_s", "F_N", "e"] * 3 if header else None
    return text(head, out)


# name -> (file text or bytes, data config overrides)
VARIANTS: dict[str, tuple[str | bytes, dict]] = {
    "plain": (PLAIN, {}),
    "semicolon": (text(["t_s", "F_N", "e"], rows(), ";"), {}),
    "tab": (text(["t_s", "F_N", "e"], rows(), "\t"), {}),
    "pipe": (text(["t_s", "F_N", "e"], rows(), "|"), {}),
    "whitespace-aligned": ("\n".join(f"{a:>12} {b:>16}   {c:>12}" for a, b, c in
                                     [["t_s", "F_N", "e"], *rows()]) + "\n", {}),
    "semicolon-decimal-comma": (text(["t_s", "F_N", "e"], comma(rows()), ";"), {}),
    "tab-decimal-comma": (text(["t_s", "F_N", "e"], comma(rows()), "\t"), {}),
    "crlf": (PLAIN.replace("\n", "\r\n"), {}),
    "cr-old-mac": (PLAIN.replace("\n", "\r"), {}),
    "bom-crlf": ("\ufeff" + PLAIN.replace("\n", "\r\n"), {}),
    "utf16-bom": (codecs.BOM_UTF16_LE + PLAIN.encode("utf-16-le"), {}),
    "cp1252-metadata": (("Operator,Jürgen\nGauge,50,mm\n\n" + PLAIN).encode("cp1252"),
                        {"encoding": "cp1252"}),
    "quoted": (text(['"t_s"', '"F_N"', '"e"'], [[f'"{c}"' for c in r] for r in rows()]), {}),
    "spaces-around-cells": (text([" t_s ", " F_N", "e "], [[f" {c} " for c in r] for r in rows()]), {}),
    "trailing-delimiter": (text(["t_s", "F_N", "e", ""], [[*r, ""] for r in rows()]), {}),
    "bluehill-units-row": (text(['"Time"', '"Load"', '"Strain"'], rows(ff=thousands), top=BLUEHILL_TOP,
                                units=['"(s)"', '"(N)"', '"(mm/mm)"']),
                           {"columns": {"time": "Time", "force": "Load", "strain": "Strain"}}),
    "square-brackets-kN": (text(["Time", "Force", "Strain"], rows(ff=kn), units=["[s]", "[kN]", "[-]"]),
                           {"columns": {"time": "Time", "force": "Force", "strain": "Strain"}}),
    "ms-time": (text(["t", "F", "e"], rows(tf=ms), units=["ms", "N", ""]),
                {"columns": {"time": "t", "force": "F", "strain": "e"}}),
    "percent-units-row": (text(["t", "F", "e"], rows(ef=pct), units=["s", "N", "%"]),
                          {"columns": {"time": "t", "force": "F", "strain": "e"}}),
    "percent-in-header-name": (text(["Time (s)", "Force (N)", "Strain (%)"], rows(ef=pct)),
                               {"columns": {"time": "Time", "force": "Force", "strain": "Strain"}}),
    "kN-in-header-name": (text(["Time [s]", "Force [kN]", "Strain"], rows(ff=kn)),
                          {"columns": {"time": "Time [s]", "force": "Force", "strain": "Strain"}}),
    "padding-nan": (PLAIN + "NaN,NaN,NaN\n" * 7, {}),
    "padding-empty": (PLAIN + ",,\n" * 5 + "\n\n", {}),
    "headerless": (text(None, rows()), {"columns": {"time": 1, "force": 2, "strain": 3}}),
    "specimens-named": (specimens(True), {"specimen": 2}),
    "specimens-headerless": (specimens(False, 1), {"specimen": 2, "specimen_columns": 4,
                                                   "columns": {"time": 2, "force": 3, "strain": 4}}),
    "specimens-headerless-detected": (specimens(False, 1), {"specimen": 2,
                                                            "columns": {"time": 2, "force": 3, "strain": 4}}),
    "rows-selection": ("note,written,by hand\n" + PLAIN + "99,99,0.5\n98,1,0.1\n", {"rows": {"last": N}}),
    "zwick-like": (text(["Prüfzeit", "Standardkraft", "Dehnung"], comma(rows(ff=kn, ef=pct)), ";",
                        top=ZWICK_TOP, units=["s", "kN", "%"], end="\r\n"),
                   {"columns": {"time": "Prüfzeit", "force": "Standardkraft", "strain": "Dehnung"}}),
    "decimal-comma-dot-thousands": (text(["t", "F", "e"], [[r[0].replace(".", ","), german(float(r[1])),
                                                            r[2].replace(".", ",")] for r in rows()], ";"),
                                    {"columns": {"time": "t", "force": "F", "strain": "e"}}),
    "explicit-overrides": (text(["t_s", "F_N", "e"], comma(rows()), ";"),
                           {"delimiter": ";", "decimal": ",", "header": True}),
    "format-plain": (text(["t_s", "F_N", "e"], rows(), ";"), {"format": "plain", "delimiter": ";"}),
    "extension-mm": (text(["t", "F", "ext"], rows(ef=lambda x: f"{50 * x:.8f}"), units=["s", "N", "mm"]),
                     {"columns": {"time": "t", "force": "F", "extension": "ext"}, "gauge_length": 50.0}),
    "metadata-with-numbers": ("Width,10.0,mm\nSpeed,5\nNotes,none\n" + PLAIN, {}),
}


def load(tmp_path: Path, content: str | bytes, name: str = "test.csv", **data) -> object:
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_bytes(content.encode("utf-8"))
    raw = {"name": "t", "data": {"file": name, "columns": COLUMNS, **BASE, **data}}
    return load_test(parse_config(raw, source=tmp_path / "config.yaml"))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return load(tmp_path_factory.mktemp("ref"), PLAIN)


def test_the_corpus_is_large_enough():
    assert len(VARIANTS) >= 25
    assert len(BAD) >= 15


@pytest.mark.parametrize("name", sorted(VARIANTS))
def test_variant_loads_to_the_plain_arrays(tmp_path, reference, name):
    content, data = VARIANTS[name]
    test = load(tmp_path, content, **data)
    for key in ("time", "strain", "stress", "nominal_strain", "nominal_stress", "force"):
        np.testing.assert_allclose(getattr(test, key), getattr(reference, key), rtol=1e-12, atol=1e-12,
                                   err_msg=f"{name}: {key}")
    assert test.notes[0].startswith("format: "), test.notes


def test_notes_say_what_was_detected(tmp_path):
    content, data = VARIANTS["zwick-like"]
    notes = "\n".join(load(tmp_path, content, **data).notes)
    for words in ("delimiter ';' (detected)", "decimal comma (detected)", "metadata lines 1-3 (not read)",
                  "header line 5", "units row line 6", "line ends CRLF",
                  "'Standardkraft' in kN -> N (×1000, units row line 6)",
                  "'Dehnung' in % -> fraction (×0.01, units row line 6)"):
        assert words in notes, notes
    content, data = VARIANTS["padding-nan"]
    notes = "\n".join(load(tmp_path, content, **data).notes)
    assert f"padding: the last 7 row(s) (lines {N + 2}-{N + 8}) are empty or NaN in every used column: " \
           "dropped" in notes
    content, data = VARIANTS["specimens-named"]
    assert any("specimen 2 of 3: columns 4-6 (groups of 3: repeated header names)" in n
               for n in load(tmp_path, content, **data).notes)
    content, data = VARIANTS["specimens-headerless-detected"]
    assert any("specimen 2 of 3: columns 5-8 (groups of 4: the same column pattern repeats)" in n
               for n in load(tmp_path, content, **data).notes)
    content, _ = VARIANTS["specimens-headerless"]
    notes = load(tmp_path, content, columns={"time": 6, "force": 7, "strain": 8}).notes
    assert any("look like 3 groups of 4" in n for n in notes)


def _mid(cell: str, column: int = 1, row: int = 20) -> str:
    body = rows()
    body[row][column] = cell
    return text(["t_s", "F_N", "e"], body)


LINE = 22   # row 20 (0-based) of the data is line 22 (header = line 1)

# name -> (content, data overrides, words the error must contain)
BAD: dict[str, tuple[str | bytes, dict, str]] = {
    "nan-in-the-middle": (_mid("NaN"), {}, f"line {LINE}, column 'F_N' (force): cell 'NaN' is not a finite "
                                           "number (a missing value in the middle"),
    "empty-cell": (_mid(""), {}, f"line {LINE}, column 'F_N' (force): cell '' is not a number (empty cell)"),
    "blank-line-in-the-middle": (PLAIN.replace("\n5.000000", "\n\n5.000000"), {},
                                 "empty line between data rows"),
    "padding-row-in-the-middle": (PLAIN.replace("\n5.000000", "\n,,\n5.000000"), {},
                                  "empty line between data rows"),
    "underscore-digits": (_mid("6_54.93"), {}, "cell '6_54.93' is not a number (underscores are not allowed"),
    "full-width-digits": (_mid("５０"), {}, "only ASCII digits are numbers"),
    "force-1e300": (_mid("1e300"), {}, f"line {LINE}, column 'F_N' (force): cell '1e300' is not a plausible "
                                       "force"),
    "outlier-1e308": (_mid("1.7e308"), {}, "is not a plausible force"),
    "overflow-1e400": (_mid("1e400"), {}, "cell '1e400' is not a finite number"),
    "decimal-point-in-a-comma-file": (text(["t", "F", "e"], [*comma(rows())[:20], rows()[20],
                                                              *comma(rows())[21:]], ";"),
                                      {"columns": {"time": "t", "force": "F", "strain": "e"}},
                                      "decimal point in a file with decimal commas"),
    "non-utf8": (PLAIN.encode() + "µ,1,2\n".encode("cp1252"), {}, "not a utf-8 text file"),
    "binary": (b"\x00\x01\x02" * 100, {}, "NUL byte"),
    "too-many-fields": (PLAIN.replace("\n5.000000,", "\n1,5.000000,", 1), {},
                        f"line {LINE}: 4 fields, but the header (line 1) has 3"),
    "specimen-out-of-range": (specimens(True), {"specimen": 4},
                              "data.specimen: 4, but the file has 3 specimen(s)"),
    "specimens-without-choice": (specimens(True), {}, "appears 3 times in the header (columns 1, 4, 7): the "
                                                      "file holds 3 specimens side by side"),
    "rows-past-the-end": (PLAIN, {"rows": {"first": 5, "last": 500}},
                          f"data.rows.last: 500 is past the last data row ({N}"),
    "misaligned-header": (text(["t_s", "F_N", "e"], [[str(i), *r] for i, r in enumerate(rows())]), {},
                          "the header names 3 columns but the data rows (from line 2) have 4 fields"),
    "unknown-unit": (text(["t", "F", "e"], rows(), units=["s", "(furlongs)", "-"]),
                     {"columns": {"time": "t", "force": "F", "strain": "e"}},
                     "has the unit '(furlongs)' (units row line 2), which is not a unit of force"),
    "strain-in-mm": (text(["t", "F", "e"], rows(), units=["s", "N", "mm"]),
                     {"columns": {"time": "t", "force": "F", "strain": "e"}},
                     "is in mm (units row line 2): a length, not a strain"),
    "data-above-header": ("1,2,3\n" + PLAIN, {}, "line(s) 1 above the header (line 2) look like data rows"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_variant_gives_a_named_error(tmp_path, name):
    content, data, words = BAD[name]
    with pytest.raises(DataError) as err:
        load(tmp_path, content, **data)
    msg = str(err.value)
    assert str(tmp_path / "test.csv") in msg, msg
    assert words in msg, msg


def test_a_directory_is_reported_as_a_directory(tmp_path):
    (tmp_path / "test.csv").mkdir()
    with pytest.raises(DataError, match=r"test.csv: is a directory, not a data file \(config key data.file"):
        load_test(parse_config({"name": "t", "data": {"file": "test.csv", "columns": COLUMNS, **BASE}},
                               source=tmp_path / "config.yaml"))


def test_python_float_would_accept_what_the_reader_refuses():
    """The reason for a strict parser: float() takes these, a machine never writes them."""
    assert float("6_54.93") == 654.93 and float("５０") == 50.0




@pytest.mark.parametrize("name", sorted(VARIANTS))
def test_a_group_is_sampled_as_cell_by_cell(tmp_path, name, monkeypatch):
    """Table.group_sample (the columns a hint compares) reads plain rows with numpy's reader: the
    same values, NaN where a cell is not a number, as the parse of every cell."""
    from bayes_dnlr.data.reading import Table, read_table

    content, data = VARIANTS[name]
    path = tmp_path / "test.csv"
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    raw = {"name": "t", "data": {"file": "test.csv", "columns": COLUMNS, **BASE, **data}}
    table = read_table(path, parse_config(raw, source=tmp_path / "config.yaml").data)
    rows_ = np.arange(table.lines.size)
    fast = table.group_sample(rows_)
    monkeypatch.setattr(Table, "_plain_group_sample", lambda self, rows: None)
    slow = table.group_sample(rows_)
    assert len(fast) == len(slow) == table.group[1] > 0
    for a, b in zip(fast, slow, strict=True):
        assert np.array_equal(a, b, equal_nan=True)
