"""The report's headline sentence on E(t) (report/modulus_section.py)."""

from __future__ import annotations

from types import SimpleNamespace

from bayes_dnlr.report.modulus_section import _table, headline_words


def _run(row: dict) -> SimpleNamespace:
    return SimpleNamespace(summary={"modulus_at": [row]}, cfg=SimpleNamespace(test_names=["t1"]))


def test_the_headline_gives_e_t_with_its_trust():
    row = {"t": 0.5, "mean": 1327.4, "sd": 186.7, "median": 1327.4, "hdi_90": [1020.3, 1634.5],
           "trust": True, "trust_reasons": []}
    words = headline_words(_run(row))
    assert "E(0.500 s) = 1327 ± 187 MPa</b> (90 % HDI" in words and ">trusted<" in words
    assert "first loading" not in words
    cyclic = headline_words(_run({**row, "trust": False}))
    assert "not trusted" in cyclic


def test_the_table_names_the_standard_whose_slope_the_start_check_compares():
    """On a curve cropped past 0.05 % strain (the rHDPE export) the start check compares ASTM D638's
    slope: the column says so, where it said "ISO chord"."""
    def row(standard):
        start = {"data_chord": 1156.0, "model_chord": 1016.0, "z": 3.1, "times": [0.69, 0.99],
                 "standard": standard}
        return {"t": 2.0, "mean": 600.6, "sd": 20.0, "hdi_90": [567.8, 631.7], "trust": False,
                "checks": {"start": start}}

    astm = _table([row("ASTM D638")])
    assert "<th>start (ASTM D638 slope, data / model)</th>" in astm and "ISO" not in astm
    assert "<th>start (ISO 527-1 chord, data / model)</th>" in _table([row("ISO 527-1")])
