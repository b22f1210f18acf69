"""Reading a DMA frequency sweep: frequency, storage modulus E', loss modulus E'' (or tan δ) and
optionally the temperature, from the exports of the usual instruments.

The layout is sniffed as for a tensile export (data/sniff.py: delimiter, decimal mark, metadata
block, header row, units row). Columns are found by their names unless the config maps them
(``reference_moduli[i].columns``): TA Instruments TRIOS ("Frequency", "Storage modulus", "Loss
modulus", "Tan(delta)", "Temperature", units in a row below), Netzsch ("Frequency/Hz", "E'/MPa",
"E''/MPa", "tan d", "Temp./°C", the unit after a slash), Anton Paar ("Frequency [Hz]", "Storage
Modulus [Pa]", "Loss Modulus [Pa]", "Loss Factor [1]"). Units come from the units row, the
header names or ``reference_moduli[i].units``; a modulus without one is an error (Pa and MPa differ
by 10⁶). A shear modulus (G', a rheometer in torsion) is refused: E = 2(1 + ν) G needs ν, which
a sweep does not give.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.numbers import parse_cell
from bayes_dnlr.data.reading import Source, read_bytes
from bayes_dnlr.data.sniff import HEAD_LINES, sniff, split
from bayes_dnlr.units import lookup, split_name, to_celsius

MIN_ROWS = 2
# role -> names an export gives the column (lower case, single spaces, unit removed)
ROLE_NAMES: dict[str, tuple[str, ...]] = {
    "frequency": ("frequency", "freq", "freq.", "f", "oscillation frequency", "frequency f"),
    "angular_frequency": ("angular frequency", "ang. frequency", "angular freq.", "omega", "ω",
                          "angular frequency ω"),
    "storage": ("storage modulus", "e'", "storage_modulus", "e′", "e_storage", "storage", "e prime",
                "e' storage modulus", "tensile storage modulus", "storage modulus e'"),
    "loss": ("loss modulus", "e''", "loss_modulus", "e″", 'e"', "e_loss", "loss", "e double prime",
             "tensile loss modulus", "loss modulus e''"),
    "tan_delta": ("tan(delta)", "tan delta", "tan δ", "tanδ", "tan(δ)", "tan d", "tan_delta",
                  "loss factor", "damping factor", "tan delta (-)"),
    "temperature": ("temperature", "temp.", "temp", "sample temperature", "temperature t"),
}
SHEAR_NAMES = ("g'", "g''", "g′", "g″", "shear storage modulus", "shear loss modulus")
MODULUS_ROLES = ("storage", "loss")


@dataclass
class Sweep:
    """A frequency sweep in the package's units: Hz, MPa, °C."""

    path: Path
    frequency: np.ndarray
    storage: np.ndarray
    loss: np.ndarray | None
    temperature: np.ndarray | None
    lines: np.ndarray                    # file line of each row
    notes: list[str] = field(default_factory=list)


def _clean(name: str) -> tuple[str, str | None]:
    """(name, unit) of a header cell: 'Storage modulus (Pa)', 'E'/MPa', '##Temp./°C'."""
    text = name.strip().lstrip("#").strip()
    base, unit = split_name(text)
    for sep in ("/", "_"):                  # 'Frequency/Hz' (Netzsch), 'storage_MPa'
        if unit is None and sep in text:
            head, _, tail = text.rpartition(sep)
            if lookup(tail) is not None and head.strip():
                base, unit = head, tail.strip()
    return re.sub(r"\s+", " ", base.strip().lower()), unit


def _find_columns(header: list[str] | None, given: Mapping[str, str | int] | None, path: Path
                  ) -> dict[str, int]:
    """role -> column index: as given (names or numbers from 1), else by name."""
    cleaned = [_clean(h)[0] for h in header] if header else []
    out: dict[str, int] = {}
    for role, ref in (given or {}).items():
        if isinstance(ref, int):
            out[role] = ref - 1
            continue
        names = [h.strip() for h in header or []]
        if ref in names:
            out[role] = names.index(ref)
        elif _clean(ref)[0] in cleaned:
            out[role] = cleaned.index(_clean(ref)[0])
        else:
            raise DataError(f"{path}: no column named {ref!r} (reference_moduli columns.{role}); the "
                            f"header has {names}")
    for role, names in ROLE_NAMES.items():
        if role in out:
            continue
        hits = [i for i, h in enumerate(cleaned) if h in names and i not in out.values()]
        if hits:
            out[role] = hits[0]
    shear = [header[i] for i, h in enumerate(cleaned) if h in SHEAR_NAMES] if header else []
    if shear and "storage" not in out:
        raise DataError(f"{path}: the columns {shear} hold a shear modulus (G', G''), not the tensile "
                        "E' the model predicts (E = 2(1 + ν) G needs Poisson's ratio): export the "
                        "tensile or flexural moduli, or convert them and name the columns "
                        "(reference_moduli columns)")
    if "frequency" not in out and "angular_frequency" not in out:
        raise DataError(f"{path}: no frequency column (named 'Frequency' or 'Angular frequency'; the "
                        f"header has {header}): name it in reference_moduli columns.frequency")
    if "storage" not in out and not ("loss" in out and "tan_delta" in out):
        raise DataError(f"{path}: no storage modulus column (named 'Storage modulus' or E'; the header "
                        f"has {header}): name it in reference_moduli columns.storage")
    return out


def _unit(role: str, column: int, layout, given: Mapping[str, str], path: Path,
          name: str) -> tuple[str | None, float]:
    """(unit text, factor to Hz / MPa) of a column; temperatures are converted by ``to_celsius``."""
    unit = given.get(role)
    where = "reference_moduli units"
    if unit is None and column < len(layout.units):
        unit = layout.units[column]
        where = layout.unit_where[column] if column < len(layout.unit_where) else "the file"
    if unit is None:
        unit = _clean(name)[1]
        where = "the header"
    kind = {"frequency": "frequency", "angular_frequency": "frequency", "storage": "stress",
            "loss": "stress", "temperature": "temperature"}.get(role)
    if kind is None:                        # tan δ: a ratio
        return unit, 1.0
    if unit is None:
        if role == "angular_frequency":
            return "rad/s", 1.0 / (2.0 * math.pi)
        if role in ("frequency", "temperature"):
            return ("Hz" if role == "frequency" else "°C"), 1.0
        raise DataError(f"{path}: the column {name!r} ({role}) has no unit in the file: give it "
                        f"(reference_moduli units.{role}: MPa, Pa, GPa, ...)")
    hit = lookup(unit)
    if hit is None or hit[0] != kind:
        raise DataError(f"{path}: the column {name!r} ({role}) has the unit {unit!r} ({where}), which is "
                        f"not a {kind} unit: give it in reference_moduli units.{role}")
    if role == "angular_frequency" and unit.strip("()[] ").lower() in ("hz",):
        return unit, 1.0
    return unit, hit[1]


def read_sweep(path: Path, columns: Mapping[str, str | int] | None = None,
               units: Mapping[str, str] | None = None) -> Sweep:
    """The sweep in the file at ``path`` (module doc); every cell a finite number, frequencies
    positive, E' positive and E'' not negative."""
    buf, notes = read_bytes(Path(path), "utf-8")
    src = Source(buf, Path(path))
    head = src.head(HEAD_LINES)
    if not any(line.strip() for line in head):
        raise DataError(f"{path}: the file is empty")
    layout = sniff(head, path, delimiter=None, decimal=None, header=None)
    src.layout = layout
    header = layout.header
    cols = _find_columns(header, columns, Path(path))
    names = {r: (header[c] if header and c < len(header) else f"column {c + 1}") for r, c in cols.items()}
    last = src.n_lines
    while last >= layout.data_line and not src.line(last).strip():
        last -= 1
    values: dict[str, list[float]] = {r: [] for r in cols}
    lines = []
    for number in range(layout.data_line, last + 1):
        text = src.line(number)
        if not text.strip():
            continue
        cells = split(text, layout.delimiter)
        row = {}
        for role, c in cols.items():
            cell = cells[c] if c < len(cells) else ""
            x = parse_cell(cell, layout.decimal)
            if x is None or not math.isfinite(x):
                raise DataError(f"{path}, line {number}: column {names[role]!r}: {cell.strip()!r} is not a "
                                "finite number")
            row[role] = x
        for role, x in row.items():
            values[role].append(x)
        lines.append(number)
    if len(lines) < MIN_ROWS:
        raise DataError(f"{path}: {len(lines)} data row(s); a sweep needs at least {MIN_ROWS}")
    arrays = {}
    for role, c in cols.items():
        unit, k = _unit(role, c, layout, units or {}, Path(path), names[role])
        v = np.asarray(values[role], dtype=float)
        arrays[role] = to_celsius(v, unit or "°C") if role == "temperature" else v * k
        if role != "tan_delta":
            notes.append(f"{role.replace('_', ' ')}: {names[role]!r}" + (f" in {unit}" if unit else ""))
    freq = arrays.get("frequency", arrays.get("angular_frequency"))
    storage, loss = arrays.get("storage"), arrays.get("loss")
    tan = arrays.get("tan_delta")
    if loss is None and tan is not None and storage is not None:
        loss = storage * tan
        notes.append(f"E'' = E' tan δ (from {names['tan_delta']!r})")
    if storage is None:
        storage = loss / tan
        notes.append(f"E' = E'' / tan δ (from {names['tan_delta']!r})")
    _positive(path, "frequency", freq, lines, names.get("frequency", names.get("angular_frequency")))
    _positive(path, "storage modulus", storage, lines, names.get("storage", "E'"))
    if loss is not None and np.any(loss < 0):
        i = int(np.flatnonzero(loss < 0)[0])
        raise DataError(f"{path}, line {lines[i]}: a negative loss modulus ({loss[i]:g} MPa): check the "
                        "column or the sign of the phase")
    return Sweep(Path(path), freq, storage, loss, arrays.get("temperature"), np.asarray(lines),
                 ["format: " + ", ".join(layout.notes), *notes])


def _positive(path, what: str, v: np.ndarray, lines: list[int], name: str) -> None:
    if np.any(v <= 0):
        i = int(np.flatnonzero(v <= 0)[0])
        raise DataError(f"{path}, line {lines[i]}: column {name!r}: the {what} must be positive, got "
                        f"{v[i]:g}")


def looks_like_sweep(path: Path) -> bool:
    """Whether a file's header names a frequency and a storage modulus (``init`` tells a DMA export
    from a tensile one so)."""
    try:
        buf, _ = read_bytes(Path(path), "utf-8")
        src = Source(buf, Path(path))
        layout = sniff(src.head(HEAD_LINES), path, delimiter=None, decimal=None, header=None)
        _find_columns(layout.header, None, Path(path))
    except DataError:
        return False
    return True
