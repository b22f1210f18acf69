"""A temperature column (``data.temperature``) in °C: its unit (°C or kelvin, from the config or
the file), and the range a test's temperature can have."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from bayes_dnlr.data.errors import DataError

CELSIUS = ("°c", "ºc", "c", "degc", "deg c", "celsius")
KELVIN = ("k", "kelvin")
ABSOLUTE_ZERO = -273.15     # °C
HOTTEST = 1000.0            # °C: above this a column is no polymer test's temperature


def to_celsius(values: np.ndarray, unit: str | None) -> tuple[np.ndarray, bool]:
    """(the values in °C, whether they were converted from kelvin); ``unit`` None is °C. Raises
    ValueError for a unit that is not a temperature's."""
    if unit is None:
        return values, False
    u = unit.strip().strip("()[]").strip().lower()
    if u in KELVIN:
        return values + ABSOLUTE_ZERO, True
    if u not in CELSIUS:
        raise ValueError(f"the unit {unit!r} is not a temperature's")
    return values, False


def first_implausible(values: np.ndarray) -> int | None:
    """The index of the first value that is no temperature in °C (at or below absolute zero, or
    above HOTTEST, or not finite), None when every one is."""
    bad = np.flatnonzero(~((values > ABSOLUTE_ZERO) & (values < HOTTEST)))
    return int(bad[0]) if bad.size else None


def column_in_celsius(values: np.ndarray, unit: str | None, source: str, name: str, path: Path,
                      where: Callable[[int], str], cell: Callable[[int], str]
                      ) -> tuple[np.ndarray, str | None]:
    """A temperature column (``data.temperature``) in °C, and a note when it was converted from
    kelvin. ``unit``: from the config (``source`` 'data.temperature.unit') or the file, None: °C.
    Errors name the column, or the cell (``where(i)``, ``cell(i)``), of a value that is no
    temperature."""
    try:
        celsius, kelvin = to_celsius(values, unit)
    except ValueError as err:
        raise DataError(f"{path}: column '{name}' (data.temperature): {err}; set "
                        f"data.temperature.unit (°C or K)") from None
    i = first_implausible(celsius)
    if i is not None:
        raise DataError(f"{where(i)} (data.temperature): cell {cell(i)} is not a temperature in °C "
                        f"(expected above {ABSOLUTE_ZERO:g} and below {HOTTEST:g}; in kelvin? set "
                        f"data.temperature.unit: K)")
    return celsius, (f"'{name}' in K -> °C ({source})" if kelvin else None)
