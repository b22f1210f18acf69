"""Units read from headers and configs: split from the name, converted to the package's units."""

from __future__ import annotations

import pytest

from bayes_dnlr.units import factor, is_unit_cell, known_units, lookup, split_name


@pytest.mark.parametrize(("header", "expected"), [
    ("Time (s)", ("Time", "s")), ("Load [kN]", ("Load", "kN")), ("Strain %", ("Strain", "%")),
    ("Specimen 3 (2)", ("Specimen 3 (2)", None)), ("eps11", ("eps11", None)),
])
def test_split_name(header, expected) -> None:
    assert split_name(header) == expected


def test_factors_to_the_package_units() -> None:
    assert factor("force", "kN") == 1e3 and factor("force", "(N)") == 1.0
    assert factor("eps11", "%") == pytest.approx(0.01)
    assert factor("force", "mm") is None                      # a length is not a force
    assert lookup("MN") == ("force", 1e6) and lookup("mN")[1] == pytest.approx(1e-3)   # mega, milli
    assert lookup("parsec") is None
    assert "kN" in known_units("force") or "kn" in known_units("force")


def test_unit_cells() -> None:
    assert is_unit_cell("(MPa)") and is_unit_cell("mm") and is_unit_cell("")
    assert not is_unit_cell("12.5") and not is_unit_cell("Specimen name")
