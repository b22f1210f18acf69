"""Huge cells and lines in the files a user gives (data, manifest), and text that a spreadsheet
would run as a formula in every CSV the package writes (results.csv, compare.csv, design.csv)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bayes_dnlr import cli
from bayes_dnlr.csvcells import FORMULA_START, is_formula, safe_cell
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.workflows.batch.manifest import BatchError, read_manifest

FIELD_LIMIT = 131_072           # the csv module's default field limit


def _data(folder: Path, row50: str, header: str = "t_s,eps,s") -> Path:
    t = np.linspace(0.0, 100.0, 200)
    rows = [f"{a},{a * 1e-3},{2 * a}" for a in t]
    rows[50] = row50
    path = folder / "big.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    (folder / "config.yaml").write_text(
        "name: big\ndata:\n  file: big.csv\n  columns: {time: t_s, strain: eps, stress: s}\n"
        "  observable: stress\n  area0: 1\n")
    return folder / "config.yaml"


HUGE_ROWS = {
    "quoted text": '1,"' + "x" * (2 * FIELD_LIMIT) + '",3',
    "digits": "1," + "9" * (2 * FIELD_LIMIT) + ",3",
    "extra quoted field": '1,0.001,2,"' + "y" * (2 * FIELD_LIMIT) + '"',
    "unclosed quote": '1,"' + "z" * (2 * FIELD_LIMIT),
}


@pytest.mark.parametrize("name", sorted(HUGE_ROWS))
def test_a_huge_data_cell_is_a_short_error_naming_the_line(tmp_path, name, capsys) -> None:
    config = _data(tmp_path, HUGE_ROWS[name])
    assert cli.main(["fit", "--quiet", str(config)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {tmp_path / 'big.csv'}") and err.count("\n") == 1
    assert "line 52" in err
    assert len(err) < 600


def test_a_huge_header_cell_is_an_error_not_a_traceback(tmp_path, capsys) -> None:
    config = _data(tmp_path, "1,0.001,2", header='t_s,eps,"' + "s" * (2 * FIELD_LIMIT) + '"')
    assert cli.main(["fit", "--quiet", str(config)]) == 2
    assert len(capsys.readouterr().err) < 2000


def test_init_reads_a_file_with_a_huge_cell(tmp_path, capsys) -> None:
    _data(tmp_path, HUGE_ROWS["quoted text"])
    out = tmp_path / "r" / "config.yaml"
    assert cli.main(["init", str(tmp_path / "big.csv"), "--out", str(out)]) in (0, 2)
    assert "Traceback" not in capsys.readouterr().err


def test_a_huge_manifest_cell_is_named(tmp_path) -> None:
    path = tmp_path / "manifest.csv"
    path.write_text('name,data.file\nt0,"' + "d" * (2 * FIELD_LIMIT) + '"\n')
    with pytest.raises(BatchError, match=r"manifest.csv: line 2: not a manifest row"):
        read_manifest(path)


@pytest.mark.slow
def test_a_100_mb_line_is_refused_cleanly(tmp_path, capsys) -> None:
    config = _data(tmp_path, '1,"' + "x" * 100_000_000 + '",3')
    with pytest.raises(DataError, match="line 52"):
        from bayes_dnlr.config import load_config
        from bayes_dnlr.data import load_test

        load_test(load_config(config), None)


# ---------------------------------------------------------------- formulas in CSV outputs

FORMULAS = ['=HYPERLINK("http://example.invalid","x")', "+1+1", "-2+3;cmd", "@SUM(A1:A2)",
            "\t=1+1", "\r=1", " =1+1", "＝1+1", "=cmd|' /C calc'!A0"]


@pytest.mark.parametrize("text", FORMULAS)
def test_a_formula_becomes_text(text) -> None:
    assert is_formula(text) and safe_cell(text) == "'" + text


@pytest.mark.parametrize("value", ["-1.5", "+3", "-inf", "1e-3", "-", "name-1", "", 3, -2.0, None, True])
def test_numbers_and_plain_text_stay_as_they_are(value) -> None:
    assert safe_cell(value) == value


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=40))
def test_no_cell_can_start_a_formula(text) -> None:
    out = safe_cell(text)
    assert out == text or out == "'" + text
    if out == text:               # left alone: it cannot be read as a formula, or it is a number
        head = text.lstrip(" \t\r\n")
        assert (len(head) < 2 or head[0] not in FORMULA_START or _is_number(text))
        assert not text.startswith(("\t", "\r", "\n"))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _cells(text: str) -> list[str]:
    return [c for row in csv.reader(io.StringIO(text)) for c in row]


def test_results_csv_escapes_manifest_text(tmp_path) -> None:
    from bayes_dnlr.workflows.batch.run import write_table

    rows = [{"name": "t0", "status": "ok", "error": FORMULAS[0], "inputs": {"data.file": "=x.csv"},
             "E": -12.5}]
    csv_path, pq_path = write_table(rows, tmp_path)
    cells = _cells(csv_path.read_text())
    assert "'" + FORMULAS[0] in cells and "-12.5" in cells
    assert not any(is_formula(c) for c in cells)


def test_compare_and_design_csv_escape_text() -> None:
    from bayes_dnlr.report.compare import Comparison
    from bayes_dnlr.workflows.design.run import _csv

    comp = Comparison([{"run": "=a", "note": FORMULAS[3], "E_post": -1.0}], consistency=None)
    design = _csv([{"name": FORMULAS[1], "E_sd": 0.5, "=key": "x,y"}])
    for text in (comp.csv(), design):
        cells = _cells(text)
        assert not any(is_formula(c) for c in cells), cells
        assert any(c.startswith("'") for c in cells)
