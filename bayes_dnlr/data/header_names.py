"""Header names of a multi-specimen export: the specimen index in a name, and a header that does not
line up with the data rows.

Exports of several specimens side by side name each group's columns with the specimen's index
(``Time 1, Strain 1, Stress 1, Time 2, ...``, ``Load_2``, ``Specimen 3 - Time``): the names repeat
once the index is taken off. Some exports also write a header whose cells do not sit over their data
(empty cells inserted, or unnamed data columns in each group): the names are then matched to the
columns by their specimen index and their place in the group, never by their position in the row.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from bayes_dnlr.units import split_name

# 'Time 1', 'Time_1', 'Time-1', 'Time #1', 'Time (1)'  /  'Specimen 1 - Time', '#1 Time', '1: Time'
_TRAILING = re.compile(r"^(?P<base>.*?\D)[\s_\-#.]*[(\[]?(?P<index>\d{1,3})[)\]]?$")
_LEADING = re.compile(r"^(?:(?:specimen|sample|probe|test|prüfkörper|#)\s*)?(?P<index>\d{1,3})"
                      r"\s*[:\-_.)]?\s+(?P<base>\S.*)$", re.IGNORECASE)


def split_index(name: str) -> tuple[str, int | None]:
    """('time', 1) for 'Time 1 (s)': the name without its unit and a specimen index, lower case.
    A name without an index gives (name, None). Callers accept the index only when it changes from
    group to group (``eps11`` alone is not specimen 11 of 'eps')."""
    base = split_name(name)[0].strip()
    for pattern in (_TRAILING, _LEADING):
        m = pattern.match(base)
        if m and m.group("base").strip(" _-#.:"):
            return m.group("base").strip(" _-#.:").lower(), int(m.group("index"))
    return base.lower(), None


def indexed_width(header: list[str]) -> int | None:
    """The width of repeated column groups when the names repeat once their specimen index is taken
    off, the index constant within a group and different from group to group; None otherwise."""
    n = len(header)
    parts = [split_index(h) if h.strip() else ("", None) for h in header]
    bases = [b for b, _ in parts]
    for p in range(2, n // 2 + 1):
        if n % p or len(set(bases[:p]) - {""}) < 2:
            continue
        if not all(bases[j] == bases[j % p] for j in range(n)):
            continue
        groups = [{i for _, i in parts[g:g + p] if i is not None} for g in range(0, n, p)]
        if all(len(s) == 1 for s in groups) and len({next(iter(s)) for s in groups}) == len(groups):
            return p
    return None


@dataclass
class LinedUp:
    """The name of each data column (None: unnamed) and, when the header had to be lined up, how."""

    names: list[str | None]
    note: str | None = None
    aligned: bool = True          # the header's cells sit over their columns as written


def line_up(header: list[str] | None, n_fields: int, width: int | None) -> LinedUp:
    """The names of the ``n_fields`` data columns from ``header`` (groups of ``width`` columns when
    the data hold several specimens; ``width`` from the data's own pattern)."""
    if header is None:
        return LinedUp([None] * n_fields)
    if len(header) == n_fields and not _shifted_groups(header, width):
        return LinedUp([h or None for h in header])
    cells = f"{len(header)} cells for {n_fields} fields"
    named = [h for h in header if h.strip()]
    by_index = _by_index(header, n_fields, width)
    if by_index is not None:
        return LinedUp(by_index, f"the header ({cells}) does not line up with the data rows: each "
                                 f"name is matched to its specimen's group of {width} columns by its "
                                 f"index and its place in the group", aligned=False)
    if len(named) == n_fields:
        empty = [i + 1 for i, h in enumerate(header) if not h.strip()]
        return LinedUp(named, f"the header ({cells}) has {len(empty)} empty cell(s) (cells "
                              f"{_span(empty)}) that the data rows do not have: the names are taken in "
                              f"order without them", aligned=False)
    return LinedUp([None] * n_fields, f"the header ({cells}) does not line up with the data rows and "
                                      f"its names cannot be matched: columns guessed from the values",
                   aligned=False)


def _span(cells: list[int]) -> str:
    return ", ".join(str(c) for c in cells) if len(cells) <= 3 else f"{cells[0]}-{cells[-1]}"


def _indexed(header: list[str]) -> list[tuple[int, str, int]]:
    """(position, name, specimen index) of the cells that carry an index."""
    out = []
    for pos, h in enumerate(header):
        if h.strip():
            _, index = split_index(h)
            if index is not None:
                out.append((pos, h.strip(), index))
    return out


def _shifted_groups(header: list[str], width: int | None) -> bool:
    """A header as long as the rows whose specimen groups do not start where the data's do."""
    if width is None:
        return False
    cells = _indexed(header)
    starts = {}
    for pos, _, index in cells:
        starts.setdefault(index, pos)
    return len(starts) >= 2 and any(pos % width for pos in starts.values())


def _by_index(header: list[str], n_fields: int, width: int | None) -> list[str | None] | None:
    """Names placed by specimen index: the k-th specimen's cells, in the order written, fill its
    group from the group's first column at the places they have in the header's group."""
    if width is None or n_fields % width:
        return None
    cells = _indexed(header)
    indices = sorted({i for _, _, i in cells})
    if len(indices) != n_fields // width or len(indices) < 2:
        return None
    names: list[str | None] = [None] * n_fields
    for k, index in enumerate(indices):
        mine = [(pos, name) for pos, name, i in cells if i == index]
        first = mine[0][0]
        for pos, name in mine:
            place = pos - first
            if place >= width or names[k * width + place] is not None:
                return None
            names[k * width + place] = name
    bases = [[split_index(n)[0] if n else None for n in names[g:g + width]]
             for g in range(0, n_fields, width)]
    return names if all(b == bases[0] for b in bases) else None
