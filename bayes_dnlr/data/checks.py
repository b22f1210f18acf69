"""Checks of the read columns: increasing time, plausible strains (eq. 1)."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.data.conversions import hencky_from_nominal
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.reading import _Table

MAX_HENCKY = 5.0          # λ = e^5 ≈ 148: larger axial strains are taken for a unit mistake (percent)


def _check_increasing(table: _Table, x: np.ndarray, role: str, what: str) -> None:
    """x must increase strictly; the error gives both lines and both cells."""
    bad = np.flatnonzero(np.diff(x) <= 0)
    if bad.size:
        i = int(bad[0])
        a, b = table.texts[role][i], table.texts[role][i + 1]
        raise DataError(f"{table.path}, column '{table.names[role]}': {what}: line {table.lines[i]} "
                        f"has {a.strip()} and line {table.lines[i + 1]} has {b.strip()}")


def _axial_strain(table: _Table, measure: str) -> tuple[np.ndarray, str]:
    """Measured axial Hencky strain (eq. 1) and the role it came from."""
    role = "eps11" if "eps11" in table.values else "strain"
    raw = table.values[role]
    strain = _to_hencky(table, raw, role, measure)
    big = np.flatnonzero(np.abs(strain) > MAX_HENCKY)
    if big.size:
        i = int(big[0])
        raise DataError(f"{table.where(i, role)}: strain {table.texts[role][i].strip()} is not a plausible "
                        f"strain (Hencky {strain[i]:.3g}): percent? set data.strain_unit: percent")
    return strain, role


def _to_hencky(table: _Table, raw: np.ndarray, role: str, measure: str) -> np.ndarray:
    if measure == "hencky":
        return raw
    bad = np.flatnonzero(raw <= -1.0)
    if bad.size:
        i = int(bad[0])
        raise DataError(f"{table.where(i, role)}: nominal strain {table.texts[role][i].strip()} <= -1 "
                        f"has no Hencky strain (eq. 1: ε = ln(1 + e))")
    return hencky_from_nominal(raw)
