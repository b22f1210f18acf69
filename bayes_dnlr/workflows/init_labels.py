"""The material an export states, for the configs ``init`` writes (``material:``): a line of its
metadata block (``Material, HDPE``; ``Werkstoff;PP-H 23``; ``Material: HDPE``). Nothing is guessed
beyond that: a file that names no material gets none. (The test's temperature is a data key,
``data.temperature``, that ``init`` reads with data/temperature.py.)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from bayes_dnlr.data.sniff import Layout, split

MATERIAL_KEYS = ("material", "werkstoff", "materialbezeichnung", "werkstoffbezeichnung", "matériau",
                 "materiale")


@dataclass(frozen=True)
class Label:
    """A label read from the file: its value as the config writes it, and where it was read."""

    value: str
    where: str


@dataclass(frozen=True)
class Labels:
    material: Label | None = None


def read_labels(path: Path, layout: Layout) -> Labels:
    """The material the export at ``path`` (sniffed as ``layout``) states in its metadata block."""
    if layout.metadata is None:
        return Labels()
    first, last = layout.metadata
    lines = path.read_text(encoding="utf-8-sig", errors="replace").splitlines()[first - 1:last]
    delimiter = layout.delimiter if layout.delimiter != "whitespace" else ","
    for i, line in enumerate(lines, first):
        cells = [c.strip() for c in split(line, delimiter)]
        if cells and ":" in cells[0] and len([c for c in cells if c]) == 1:   # 'Material: HDPE'
            cells = [c.strip() for c in cells[0].split(":", 1)]
        rest = [c for c in cells[1:] if c]
        if cells and cells[0].strip().strip(":").strip().lower() in MATERIAL_KEYS and rest:
            return Labels(Label(rest[0], f"the file's line {i}: {line.strip()!r}"))
    return Labels()
