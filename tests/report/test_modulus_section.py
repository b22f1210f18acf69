"""The report's headline sentence on E(t) (report/modulus_section.py)."""

from __future__ import annotations

from types import SimpleNamespace

from bayes_dnlr.report.modulus_section import headline_words


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
