"""A test's temperature (``data.temperature``) in °C: a column's unit (°C or kelvin, from the config
or the file), the range a test's temperature can have, and a temperature written in a file's name
or metadata (for ``init``)."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from bayes_dnlr.data.errors import DataError
from bayes_dnlr.units import CELSIUS, to_celsius

ABSOLUTE_ZERO = -273.15     # °C
HOTTEST = 1000.0            # °C: above this a column is no polymer test's temperature


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
        celsius = to_celsius(values, unit)
    except ValueError as err:
        raise DataError(f"{path}: column '{name}' (data.temperature): {err}; set "
                        f"data.temperature.unit (°C, K or °F)") from None
    i = first_implausible(celsius)
    if i is not None:
        raise DataError(f"{where(i)} (data.temperature): cell {cell(i)} is not a temperature in °C "
                        f"(expected above {ABSOLUTE_ZERO:g} and below {HOTTEST:g}; in kelvin? set "
                        f"data.temperature.unit: K)")
    converted = unit is not None and unit.strip().strip("()[]").strip().lower() not in CELSIUS
    return celsius, (f"'{name}' in {unit} -> °C ({source})" if converted else None)


# a temperature in a file name or a metadata line: '_T40', 'T40C', 'T=23.5', '40C', '40 °C',
# '40degC', '313K' (kelvin: three digits)
_NAME_PATTERNS = (
    (re.compile(r"(?:^|[^A-Za-z0-9])T[=_]?(-?\d{2,3}(?:[.p]\d+)?|-?\d(?:[.p]\d+)?(?=\s*(?:°|º|deg)?"
                r"\s*C))(?:\s*(?:°|º|deg)?\s*C)?(?![0-9A-Za-z])"), "°C"),
    (re.compile(r"(?:^|[^A-Za-z0-9.])(-?\d{1,3}(?:[.,]\d+)?)\s*(?:°|º|deg)\s*C(?![A-Za-z])"), "°C"),
    (re.compile(r"(?:^|[^A-Za-z0-9.])(-?\d{1,3}(?:[.p]\d+)?)C(?![0-9A-Za-z])"), "°C"),
    (re.compile(r"(?:^|[^A-Za-z0-9.])(\d{3}(?:\.\d+)?)\s*K(?![0-9A-Za-z])"), "K"),
)
_KEY = re.compile(r"temp|temperat", re.IGNORECASE)
_NUMBER_UNIT = re.compile(r"(-?\d+(?:[.,]\d+)?)\s*[;:,\t]?\s*(°\s*C|º\s*C|deg\s*C|C|K)?(?![A-Za-z])")


def in_file_name(name: str) -> tuple[float, str] | None:
    """(°C, the text it was read from) of a temperature in a file name (``_T40``, ``T40C``,
    ``40C``, ``40 °C``, ``313K``), or None."""
    for pattern, unit in _NAME_PATTERNS:
        m = pattern.search(name)
        if m is None:
            continue
        value = float(m.group(1).replace("p", ".").replace(",", "."))
        celsius = round(value + ABSOLUTE_ZERO, 6) if unit == "K" else value
        if first_implausible(np.array([celsius])) is None and (unit != "K" or value >= 150):
            return celsius, m.group(0).strip(" _-")
    return None


def in_metadata(lines: list[str]) -> tuple[float, str] | None:
    """(°C, the line) of the first metadata line that names a temperature with a number ('Test
    temperature: 23 °C', 'Temp;296.15;K'), or None."""
    for line in lines:
        key = _KEY.search(line)
        if key is None:
            continue
        m = _NUMBER_UNIT.search(line, key.end())
        if m is None:
            continue
        value = float(m.group(1).replace(",", "."))
        unit = (m.group(2) or "").replace(" ", "")
        celsius = round(value + ABSOLUTE_ZERO, 6) if unit == "K" else value
        if first_implausible(np.array([celsius])) is None:
            return celsius, line.strip()
    return None
