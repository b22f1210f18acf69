"""Units of the columns: read from a units row or a header name, and the factors to the package's
units (s, N, MPa, mm, strain as a fraction)."""

from __future__ import annotations

import math
import re

import numpy as np

# unit text (lower case, spaces removed) -> (kind, factor to the package's unit of that kind)
_UNITS: dict[str, tuple[str, float]] = {
    "s": ("time", 1.0), "sec": ("time", 1.0), "second": ("time", 1.0), "seconds": ("time", 1.0),
    "ms": ("time", 1e-3), "min": ("time", 60.0), "h": ("time", 3600.0), "hr": ("time", 3600.0),
    "n": ("force", 1.0), "kn": ("force", 1e3), "mn": ("force", 1e-3), "lbf": ("force", 4.4482216152605),
    "kgf": ("force", 9.80665),
    "mpa": ("stress", 1.0), "n/mm²": ("stress", 1.0), "n/mm2": ("stress", 1.0), "n/mm^2": ("stress", 1.0),
    "kpa": ("stress", 1e-3), "pa": ("stress", 1e-6), "gpa": ("stress", 1e3),
    "psi": ("stress", 6.894757293168e-3), "ksi": ("stress", 6.894757293168),
    "%": ("strain", 1e-2), "percent": ("strain", 1e-2), "pct": ("strain", 1e-2),
    "mm/mm": ("strain", 1.0), "m/m": ("strain", 1.0), "in/in": ("strain", 1.0), "-": ("strain", 1.0),
    "1": ("strain", 1.0), "fraction": ("strain", 1.0), "µε": ("strain", 1e-6), "με": ("strain", 1e-6),
    "microstrain": ("strain", 1e-6),
    "mm": ("length", 1.0), "m": ("length", 1e3), "µm": ("length", 1e-3), "um": ("length", 1e-3),
    "in": ("length", 25.4), "cm": ("length", 10.0),
    # a DMA export (data/dma.py): frequency to Hz; a temperature (data.temperature, a DMA export)
    # is converted by an offset, not a factor (``to_celsius``, data/temperature.py)
    "hz": ("frequency", 1.0), "khz": ("frequency", 1e3),
    "rad/s": ("frequency", 1.0 / (2.0 * math.pi)), "rads-1": ("frequency", 1.0 / (2.0 * math.pi)),
    "rad·s⁻¹": ("frequency", 1.0 / (2.0 * math.pi)),
    "°c": ("temperature", 1.0), "ºc": ("temperature", 1.0), "degc": ("temperature", 1.0),
    "celsius": ("temperature", 1.0), "k": ("temperature", 1.0), "°f": ("temperature", 1.0),
}
ROLE_KIND = {"time": "time", "force": "force", "stress": "stress", "eps11": "strain", "eps22": "strain",
             "strain": "strain", "extension": "length"}
PACKAGE_UNIT = {"time": "s", "force": "N", "stress": "MPa", "strain": "fraction", "length": "mm"}
_BRACKETED = re.compile(r"^(?P<name>.*?)\s*(?:\((?P<p>[^()]*)\)|\[(?P<b>[^\[\]]*)\])\s*$")


def normalise(unit: str) -> str:
    """Lower case, no spaces, no brackets: '(kN)' -> 'kn', '[mm/mm]' -> 'mm/mm'."""
    u = unit.strip()
    if len(u) >= 2 and ((u[0], u[-1]) in (("(", ")"), ("[", "]"))):
        u = u[1:-1]
    return u.replace(" ", "").replace("μ", "µ").lower()


def lookup(unit: str) -> tuple[str, float] | None:
    """(kind, factor) of a unit text, or None when it is not known ('MN' is mega, 'mN' milli)."""
    u = unit.strip().strip("()[]").strip()
    if u == "MN":
        return ("force", 1e6)
    if u in ("MHz", "mHz"):
        return ("frequency", 1e6 if u == "MHz" else 1e-3)
    return _UNITS.get(normalise(unit))


def is_unit_cell(text: str) -> bool:
    """True for a cell of a units row: a known unit, bracketed or not, or any short bracketed text."""
    t = text.strip()
    if not t:
        return True
    if lookup(t) is not None:
        return True
    inner = t[1:-1].replace("²", "")
    return len(t) <= 16 and t[0] + t[-1] in ("()", "[]") and not any(c.isdigit() for c in inner)


def split_name(header: str) -> tuple[str, str | None]:
    """'Time (s)' -> ('Time', 's'); 'Load [kN]' -> ('Load', 'kN'); 'Strain %' -> ('Strain', '%');
    a name without a unit -> (name, None)."""
    h = header.strip()
    m = _BRACKETED.match(h)
    if m and (m.group("p") is not None or m.group("b") is not None):
        unit = m.group("p") if m.group("p") is not None else m.group("b")
        if lookup(unit) is not None or not any(c.isdigit() for c in unit):
            return m.group("name").strip(), unit.strip()
    if h.endswith("%") and len(h) > 1:
        return h[:-1].strip(), "%"
    return h, None


def factor(role: str, unit: str) -> float | None:
    """Factor from ``unit`` to the package's unit for ``role``; None when the unit does not fit."""
    hit = lookup(unit)
    if hit is None or hit[0] != ROLE_KIND[role]:
        return None
    return hit[1]


def known_units(role: str) -> list[str]:
    """The unit texts accepted for a role (for error messages)."""
    kind = ROLE_KIND[role]
    return sorted({k for k, (kk, _) in _UNITS.items() if kk == kind})


CELSIUS = ("°c", "ºc", "c", "degc", "deg c", "celsius")
KELVIN = ("k", "kelvin")
FAHRENHEIT = ("°f", "ºf", "degf", "fahrenheit")


def to_celsius(values: np.ndarray, unit: str | None) -> np.ndarray:
    """A temperature column in °C from its unit (°C, K or °F; None: °C). An offset, not a factor:
    the one conversion of a temperature (data.temperature, a DMA export's column). Raises
    ValueError for a unit that is not a temperature's."""
    x = np.asarray(values, dtype=float)
    if unit is None:
        return x
    u = unit.strip().strip("()[]").strip().lower()
    if u in KELVIN:
        return x - 273.15
    if u in FAHRENHEIT:
        return (x - 32.0) * 5.0 / 9.0
    if u not in CELSIUS:
        raise ValueError(f"the unit {unit!r} is not a temperature's (°C, K or °F)")
    return x
