"""Guessing the columns of a machine export for ``init``: time, force or stress, strain or extension.

The file is read by the same sniffer as ``data.format: auto`` (delimiter, decimal mark, header, units
row, metadata). Specimens side by side come from repeated header names (with or without a specimen
index) or from the data's own column pattern; a header that does not line up with the data is
matched by specimen index (data/header_names.py). A column's role comes from its header name or
unit, checked against its values, and from the relations between the columns (data/relations.py):
a true stress is the engineering stress × (1 + e), a Hencky strain is ln(1 + e), an engineering
stress is the force over a constant S0, an extension is the strain times a gauge length. A guess
that a relation confirms carries it (``Pick.relation``); any other guess says how it was made and
which other columns could have been meant, so ``init`` can list what the user must check.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayes_dnlr.data import name_check
from bayes_dnlr.data import relations as rel
from bayes_dnlr.data.errors import DataError
from bayes_dnlr.data.header_names import line_up, split_index
from bayes_dnlr.data.numbers import parse_cell
from bayes_dnlr.data.ramp import Hold, find_hold
from bayes_dnlr.data.reading import HEAD_LINES, Source, read_bytes
from bayes_dnlr.data.sniff import Layout, signature_groups, sniff, specimen_groups, split
from bayes_dnlr.data.temperature import first_implausible
from bayes_dnlr.units import lookup, split_name

SAMPLE_ROWS = 4000          # rows read (evenly spread over the file) to guess from the values
FRACTION_MAX = 3.0          # a strain column in fractions stays below this (Hencky 3 is extreme)
FORCE_MIN = 200.0           # a loading column above this, with no name or unit: a force in N
LINEAR_R2 = 0.98            # a strain driven by the machine grows (nearly) linearly with time
# crosshead speeds of the tensile standards, mm/min (ISO 527-1 Table 1, ASTM D638 Table 1)
STANDARD_SPEEDS = (0.125, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0)
SPEED_TOL = 0.01            # a rate within 1 % of a standard speed is that speed
GAUGE_MM = (5.0, 1000.0)    # a plausible gauge length, mm

# name patterns (lower case, unit and specimen index removed), in order: the first match gives the role
NAME_ROLES: tuple[tuple[str, re.Pattern[str]], ...] = tuple((r, re.compile(p)) for r, p in (
    ("index", r"^(index|#|no\.?|nr\.?|point|points|sample|row|n)$"),
    ("temperature", r"^temp|temperat|^tmean$|^t_?(c|k|degc)$"),
    ("time", r"^t$|^t[_ ]|\btime\b|zeit|temps|tiempo|^sec"),
    ("eps22", r"transverse|lateral|width|quer|eps_?22|\be22\b|poisson|^e_?yy"),
    ("extension", r"extension|elongation|displacement|crosshead|traverse|stroke|position|\bweg\b|verl"),
    ("force", r"load|force|kraft|charge|fuerza|^f$|^f[_ ]"),
    ("stress", r"stress|spannung|contrainte|sigma|^s$"),
    ("strain", r"strain|dehnung|eps|deform|^e$|^e11|ε|hencky|^e_?xx"),
))
KIND_ROLE = {"time": "time", "force": "force", "stress": "stress", "strain": "strain",
             "length": "extension", "temperature": "temperature"}
TRUE_NAME = re.compile(r"true|wahr|vraie|cauchy")
HENCKY_NAME = re.compile(r"true|hencky|log")
NOMINAL_NAME = re.compile(r"eng|nominal|tensile strain")
# an engineering stress ('StressEng01', 'Eng. stress', 'nominal stress'), not 'length' or 'strength'
ENG_NAME = re.compile(r"engineering|nominal|techn|(?:stress|sigma|spannung)[\s_.]*eng"
                      r"|eng(?:\.|\b|[\s_]*stress)")


@dataclass
class Column:
    """One column of the chosen specimen's group, with what was read about it."""

    number: int                  # counted from 1 within the group (as data.columns takes it)
    name: str | None             # header name, as written
    unit: str | None             # unit read from the file (units row or header), None: none
    values: np.ndarray           # a sample of its values, file units (NaN: missing)
    unit_in_suffix: bool = False  # the unit was read from a name such as 't_s' or 'F_kN'
    unit_read: bool = False       # the reader reads the unit itself (units row, or a header that lines up)
    overruled: bool = False       # its name is contradicted by a confirmed relation (data/name_check.py)

    @property
    def label(self) -> str:
        if self.overruled:
            return f"column {self.number}"
        return f"'{self.name}'" if self.name else f"column {self.number}"


@dataclass
class Pick:
    """One role's column and how it was chosen; ``relation``: the computed relation that confirms it."""

    role: str
    column: Column
    how: str                              # 'header name', 'unit (N)', 'values: ...', 'relation'
    others: list[Column] = field(default_factory=list)   # other columns that fit the role as well
    relation: str | None = None

    @property
    def sure(self) -> bool:
        return self.relation is not None or (not self.how.startswith("values") and not self.others)


@dataclass
class Fact:
    """A value the file fixes (strain measure, strain unit, S0), and the relation that shows it."""

    value: object
    why: str


@dataclass
class Guess:
    """The columns of one specimen of a file, and the facts ``init`` needs."""

    path: Path
    layout: Layout
    columns: list[Column]
    picks: dict[str, Pick]                # time, force|stress, strain|extension (when found)
    group: tuple[int, int] | None = None  # (specimens, columns per specimen) when there are several
    notes: list[str] = field(default_factory=list)
    by_name: bool = False                 # data.columns may use the header names
    group_from: str = ""                  # how the groups were found
    measure: Fact | None = None           # 'hencky' | 'nominal', from a relation or a name
    percent: Fact | None = None           # the strain column is in percent (True) or a fraction
    area0: Fact | None = None             # S0 in mm² from force / engineering stress
    engineering: Column | None = None     # the engineering stress beside a true stress
    extension_of_strain: str | None = None   # the extension column that the strain mirrors
    hold: Hold | None = None
    stress_measure: Fact | None = None    # 'engineering' when a name says the only stress is one
    temperature: Pick | None = None       # a temperature column (its name or unit says so)
    overruled: list[str] = field(default_factory=list)  # names a confirmed relation contradicts


def _sample(src: Source, layout: Layout) -> np.ndarray:
    """Up to SAMPLE_ROWS data rows, evenly spread, as floats (NaN: missing or not a number)."""
    first, last = layout.data_line, src.n_lines
    while last >= first and not src.line(last).strip():
        last -= 1
    if last < first:
        raise DataError(f"{src.path}: no data rows after the header")
    step = max(1, (last - first + 1) // SAMPLE_ROWS)
    rows = []
    for n in range(first, last + 1, step):
        cells = split(src.line(n), layout.delimiter)
        row = [parse_cell(c, layout.decimal) for c in cells[:layout.n_fields]]
        row = [math.nan if v is None else v for v in row] + [math.nan] * (layout.n_fields - len(row))
        rows.append(row)
    return np.array(rows, dtype=float)


def _groups(layout: Layout, values: np.ndarray) -> tuple[int | None, str]:
    """The width of the specimens' column groups and how it was found."""
    f = layout.n_fields
    header = layout.header
    if header is not None and len(header) == f:
        width = specimen_groups(header)
        if width is not None:
            return width, "repeated header names"
    width = signature_groups([list(r) for r in values[:200]], f)
    if width is None and header is not None:            # a shifted header: its specimen indices
        count = len({i for _, i in (split_index(h) for h in header if h.strip()) if i is not None})
        if count >= 2 and f % count == 0:
            width = f // count
            return width, f"{count} specimen indices in the header"
    return width, "the column pattern repeats"


def read_columns(path: Path) -> tuple[Layout, list[Column], tuple[int, int] | None, list[str], str, bool]:
    """The sniffed layout, the columns of the first specimen (all columns without specimens), the
    groups (specimens, width), notes, how the groups were found, and whether names may be used."""
    buf, notes = read_bytes(path, "utf-8")
    src = Source(buf, path)
    head = src.head(HEAD_LINES)
    if not any(line.strip() for line in head):
        raise DataError(f"{path}: the file is empty")
    layout = sniff(head, path, delimiter=None, decimal=None, header=None)
    src.layout = layout
    values = _sample(src, layout)
    f = layout.n_fields
    width, how = _groups(layout, values)
    group = (-(-f // width), width) if width is not None and f // width >= 2 else None
    lined = line_up(layout.header, f, width if group else None)
    notes = [*layout.notes, *notes]
    if lined.note:
        notes.append(lined.note)
    n = group[1] if group else f
    cols = []
    for i in range(n):
        name = lined.names[i]
        unit = layout.units[i] if lined.aligned and i < len(layout.units) else None
        read = unit is not None
        if unit is None and name is not None:
            u = split_name(name)[1]
            unit = u if u is not None and lookup(u) is not None else None
        cols.append(Column(i + 1, name, unit, values[:, i], unit_read=read))
    for c in cols:              # 't_s', 'F_kN': a unit after the last underscore (not read by the reader)
        if c.unit is None and c.name and "_" in c.name:
            suffix = c.name.rsplit("_", 1)[1]
            if lookup(suffix) is not None:
                c.unit, c.unit_in_suffix = suffix, True
    indexed = layout.header is not None and any(split_index(h)[1] is not None for h in lined.names if h)
    by_name = layout.header is not None and lined.aligned and not (group and indexed)
    return layout, cols, group, notes, how, by_name


def _name_role(col: Column) -> str | None:
    if col.name is None:
        return None
    name = split_index(col.name)[0]
    for role, pattern in NAME_ROLES:
        if pattern.search(name):
            return role
    return None


def _unit_role(col: Column) -> str | None:
    hit = lookup(col.unit) if col.unit else None
    return KIND_ROLE.get(hit[0]) if hit else None


def _finite(v: np.ndarray) -> np.ndarray:
    return v[np.isfinite(v)]


def _is_index(v: np.ndarray) -> bool:
    v = _finite(v)
    return v.size >= 3 and bool(np.all(v == np.round(v))) and bool(np.all(np.diff(v) > 0)) and \
        float(np.min(np.diff(v))) >= 1 and len(set(np.diff(v).tolist())) <= 2


def _time_like(v: np.ndarray) -> bool:
    """A time: the steps between finite samples go up, but for 1 % of them, and none goes down but
    for 1 % (a logger may write a time stamp twice: data.repeated_time)."""
    v = _finite(v)
    if v.size < 3:
        return False
    d = np.diff(v)
    return float(np.mean(d > 0)) > 0.9 and float(np.mean(d >= 0)) > 0.99


def _r2(t: np.ndarray, v: np.ndarray) -> float:
    """R² of a straight line of v against t (finite pairs)."""
    ok = np.isfinite(t) & np.isfinite(v)
    if ok.sum() < 3 or np.ptp(v[ok]) == 0:
        return 0.0
    return float(np.corrcoef(t[ok], v[ok])[0, 1] ** 2)


def _named(cols: list[Column]) -> dict[str, list[tuple[Column, str]]]:
    """Role -> columns whose unit or header name says it."""
    named: dict[str, list[tuple[Column, str]]] = {}
    for c in cols:
        u = _unit_role(c)
        r = _name_role(c)
        if u is not None and r not in ("eps22", "index"):
            role, how = u, f"unit {c.unit.strip().strip('()[]')}" + (" in the name" if c.unit_in_suffix
                                                                     else "")
        else:
            role, how = r, "header name"
        if role is not None:
            named.setdefault(role, []).append((c, how))
    return named


def guess_columns(path: Path) -> Guess:
    """Read the file's layout and guess time, force or stress, strain or extension (module doc)."""
    path = Path(path)
    layout, cols, group, notes, group_from, by_name = read_columns(path)
    named = _named(cols)
    g = Guess(path, layout, cols, {}, group, notes, by_name, group_from)
    times = [c for c, _ in named.get("time", []) if _time_like(c.values)]
    if named.get("time") and not times:             # a 'Time' over a column that does not increase
        g.notes.append(f"{named['time'][0][0].label} does not increase: the header does not sit over "
                       f"its columns; columns guessed from the values")
        for c in cols:
            c.name, c.unit = None, None
        named, g.by_name = {}, False
    _pick_time(g, named)
    _pick_temperature(g, named)
    found = _relations(g, named)
    named = _overrule(g, named, found)
    _pick_by_relations(g, named, found)
    _pick_by_names(g, named)
    _pick_by_values(g)
    _strain_facts(g)
    _stress_facts(g)
    _hold(g)
    return g


def _pick_time(g: Guess, named: dict) -> None:
    cols = g.columns
    if named.get("time"):
        (c, how), *rest = named["time"]
        g.picks["time"] = Pick("time", c, how, [o for o, _ in rest])
        return
    used = {c.number for r in ("index", "eps22") for c, _ in named.get(r, [])}
    free = [c for c in cols if c.number not in used and _finite(c.values).size >= 3]
    index = [c for c in free if _is_index(c.values)]
    times = [c for c in free if c not in index and _time_like(c.values)]
    if times:
        g.picks["time"] = Pick("time", times[0], "values: the first column that increases at every row"
                               + (f" ({index[0].label} counts rows: an index)" if index else ""))


def _pick_temperature(g: Guess, named: dict) -> None:
    """A column whose name or unit says temperature and whose values are one (°C, or K by its
    unit): ``data.temperature``, never another role."""
    for c, how in named.get("temperature", []):
        unit = c.unit.strip().strip("()[]").strip().lower() if c.unit else ""
        values = _finite(c.values) + (-273.15 if unit in ("k", "kelvin") else 0.0)
        if values.size >= 3 and first_implausible(values) is None:
            others = [o for o, _ in named["temperature"] if o is not c]
            g.temperature = Pick("temperature", c, how, others)
            return


def _time_values(g: Guess) -> np.ndarray:
    t = g.picks.get("time")
    return t.column.values if t is not None else np.arange(len(g.columns[0].values), dtype=float)


def _label(g: Guess):
    return lambda i: g.columns[i].label


def _relations(g: Guess, named: dict) -> list[rel.Relation]:
    """Every relation among the group's columns but the time, a temperature and the row indices (the
    names do not restrict them: a relation is found whatever the header says)."""
    skip = {g.picks["time"].column.number - 1} if "time" in g.picks else set()
    if g.temperature is not None:
        skip.add(g.temperature.column.number - 1)
    skip |= {c.number - 1 for c in g.columns if _is_index(c.values)}
    return rel.find([c.values for c in g.columns], _time_values(g), skip)


def _true_stress(found: list[rel.Relation], named: dict) -> rel.Relation | None:
    """The true-stress relation init reads: the first true stress; with strain columns of equal
    values (an extension in mm on a 100 mm gauge is the strain in %), the one named a strain."""
    names = {c.number - 1: role for role, cs in named.items() for c, _ in cs}
    trues = sorted((r for r in found if r.kind in ("true-stress", "true-stress-hencky")),
                   key=lambda r: (r.target, names.get(r.sources[1]) not in (None, "strain"),
                                  r.kind != "true-stress", r.deviation))
    return trues[0] if trues else None


def _name_kind(c: Column, role: str) -> str | None:
    """What the header name of a column says it is, for name_check (None: nothing it can contradict)."""
    low = (c.name or "").lower()
    if role == "stress":
        return ("true stress" if TRUE_NAME.search(low) else "engineering stress" if ENG_NAME.search(low)
                else "stress")
    if role == "strain":
        return "Hencky strain" if HENCKY_NAME.search(low) else "strain"
    return role if role in ("time", "force", "extension") else None


def _overrule(g: Guess, named: dict, found: list[rel.Relation]) -> dict:
    """Names that a confirmed relation contradicts (data/name_check.py): a line each in
    ``g.overruled``, the column labelled by its number, and its name no longer a candidate."""
    by_number = lambda i: f"column {i + 1}"      # noqa: E731 - the relations' columns by number
    values: dict[int, name_check.Said] = {}
    if "time" in g.picks:
        time = g.picks["time"].column.number - 1
        values.update(name_check.time_copies([c.values for c in g.columns], time))
    r = _true_stress(found, named)
    if r is not None:
        values[r.sources[0]] = name_check.Said("engineering stress", r.text(by_number))
        values[r.sources[1]] = name_check.Said("strain", r.text(by_number))
        values[r.target] = name_check.Said("true stress", r.text(by_number))
    for h in (x for x in found if x.kind == "hencky"):
        values.setdefault(h.target, name_check.Said("Hencky strain", h.text(by_number)))
    names = {}
    for role, cs in named.items():
        for c, how in cs:
            kind = _name_kind(c, role)
            if kind is not None and how == "header name":
                names[c.number - 1] = name_check.Said(kind, c.name or "")
    wrong, lines = name_check.overruled(names, values, [c.name or "" for c in g.columns])
    if not wrong:
        return named
    for j in wrong:
        g.columns[j].overruled = True
    g.overruled = ["names overruled by the values: " + line for line in lines]
    return {role: [(c, how) for c, how in cs if not c.overruled] for role, cs in named.items()}


def _pick_by_relations(g: Guess, named: dict, found: list[rel.Relation]) -> None:
    """Stress, strain and S0 from the relations between the columns, when they hold."""
    label = _label(g)
    by_kind: dict[str, list[rel.Relation]] = {}
    for r in found:
        by_kind.setdefault(r.kind, []).append(r)
    r = _true_stress(found, named)
    if r is not None:
        eng, strain = r.sources
        g.engineering = g.columns[eng]
        g.picks["stress"] = Pick("stress", g.columns[r.target], "relation",
                                 relation=f"{r.text(label)}: the true stress of the engineering stress "
                                          f"{label(eng)} (eq. 4-6)")
        h = next((x for x in by_kind.get("hencky", []) if x.sources == (strain,)), None)
        if r.kind == "true-stress-hencky" or h is not None:
            hencky = r.formula(label) if h is None else h.formula(label)
            column = strain if h is None else h.target
            g.picks["strain"] = Pick("strain", g.columns[column], "relation", relation=(
                r.formula(label) if h is None else
                f"{h.text(label)}: the Hencky strain of {label(strain)} (eq. 1)"))
            g.measure = Fact("hencky", f"{hencky}: a Hencky strain")
            g.percent = Fact(False, f"{hencky} holds with {label(column)} as a fraction")
        else:
            g.picks["strain"] = Pick("strain", g.columns[strain], "relation", relation=(
                f"the nominal strain e of the true stress: {r.formula(label)}"))
            g.measure = Fact("nominal", f"the true stress is {r.formula(label)}: a nominal strain")
            g.percent = Fact(r.percent, f"{r.formula(label)} holds with the strain "
                                        f"{'in percent' if r.percent else 'as a fraction'}")
        return
    areas = by_kind.get("area", [])
    if areas:
        r = areas[0]
        force = r.sources[0]
        g.picks["force"] = Pick("force", g.columns[force], "relation",
                                relation=f"{r.text(label)}: the engineering stress {label(r.target)} "
                                         f"is the force over S0 = {r.value:.6g} mm²")
        g.engineering = g.columns[r.target]
        g.area0 = Fact(_round_to(r.value, r.deviation), f"{label(r.target)} = {label(force)} / S0 "
                                                         f"on every row (to {max(r.deviation, 1e-16):.0e})")


def _round_to(x: float, precision: float) -> float:
    """x with the significant digits its relative ``precision`` supports (at least 3)."""
    digits = max(3, min(8, 1 - int(math.floor(math.log10(max(precision, 1e-9))))))
    return float(f"{x:.{digits}g}")


def _pick_by_names(g: Guess, named: dict) -> None:
    for role in ("time", "force", "stress", "strain", "extension"):
        if role in g.picks or not named.get(role):
            continue
        if role in ("force", "stress") and ("force" in g.picks or "stress" in g.picks):
            continue
        if role in ("strain", "extension") and ("strain" in g.picks or "extension" in g.picks):
            continue
        cands = named[role]
        if role == "stress" and len(cands) > 1:        # 'True stress' before 'Stress'
            cands = sorted(cands, key=lambda ch: not TRUE_NAME.search(ch[0].name.lower()))
        (c, how), *rest = cands
        g.picks[role] = Pick(role, c, how, [o for o, _ in rest])


def _pick_by_values(g: Guess) -> None:
    p = g.picks
    used = {x.column.number for x in p.values()}
    if g.temperature is not None:
        used.add(g.temperature.column.number)
    t = _time_values(g)
    free = [c for c in g.columns if c.number not in used and _finite(c.values).size >= 3
            and not _is_index(c.values)]
    if not any(r in p for r in ("strain", "extension")):
        _strain_from_values(g, [c for c in free if rel.driven(t, c.values) and rel.rising(c.values)])
        free = [c for c in free if "strain" not in p or c is not p["strain"].column]
    if not any(r in p for r in ("force", "stress")):
        others = p["strain"].others if "strain" in p else []
        load = [c for c in free if rel.rising(c.values) and np.nanmax(c.values) > FRACTION_MAX
                and c not in others and not rel.driven(t, c.values)]
        load.sort(key=lambda c: (_r2(t, c.values) >= LINEAR_R2, np.nanmax(c.values) <= FORCE_MIN))
        if load:
            c = load[0]
            role = "force" if np.nanmax(c.values) > FORCE_MIN else "stress"
            p[role] = Pick(role, c, f"values: rises and bends, up to {np.nanmax(c.values):.4g}", load[1:])


def _rate_per_min(t: np.ndarray, v: np.ndarray) -> float:
    ok = np.isfinite(t) & np.isfinite(v)
    x, y = t[ok], v[ok]
    top = int(np.argmax(y >= y.min() + 0.99 * np.ptp(y))) + 1 if y.size else 0
    return 60.0 * float(np.polyfit(x[:top], y[:top], 1)[0]) if top >= 3 else math.nan


def _standard_speed(rate: float) -> float | None:
    return next((s for s in STANDARD_SPEEDS if abs(rate - s) <= SPEED_TOL * s), None)


def _strain_from_values(g: Guess, lin: list[Column]) -> None:
    """The strain among the deformations: a column that rises at a standard crosshead speed in
    mm/min is the extension, and a column linear in it is the strain it gives (the one nearest zero
    at the start: a second channel differs by an offset); else fractions first, then file order."""
    if not lin:
        return
    t = _time_values(g)
    speeds = {c.number: _standard_speed(_rate_per_min(t, c.values)) for c in lin}
    ext = [c for c in lin if speeds[c.number] is not None]
    pairs = {}
    for x in ext:
        for c in lin:
            r = rel.linear(c.values, x.values, 0, 1) if c is not x else None
            if r is not None and abs(r.value - 1) > 1e-3:     # another unit, not a second channel
                pairs[c.number] = (x, r)
    strains = [c for c in lin if c.number in pairs]
    if len(ext) == 1 and strains:
        strains.sort(key=lambda c: (abs(float(_finite(c.values)[0])), c.number))
        c = strains[0]
        x, r = pairs[c.number]
        speed = speeds[x.number]
        tiny = abs(r.offset) <= 1e-6 * float(np.nanmax(np.abs(x.values)))
        offset = "" if tiny else f" {'+' if r.offset >= 0 else '-'} {abs(r.offset):.4g}"
        g.picks["strain"] = Pick("strain", c, "relation", relation=(
            f"{x.label} = {r.value:.6g} × {c.label}{offset} "
            f"(to {max(r.deviation, 1e-16):.0e}): the same deformation as {x.label}, which rises at "
            f"{speed:g} mm/min, a standard crosshead speed: the extension in mm"))
        g.extension_of_strain = x.label
        _strain_by_extension(g, c, r)
        return
    lin = sorted(lin, key=lambda c: np.nanmax(c.values) > FRACTION_MAX)      # fractions first
    g.picks["strain"] = Pick("strain", lin[0], "values: grows steadily with time", lin[1:])


def _strain_by_extension(g: Guess, c: Column, r: rel.Relation) -> None:
    """What x = k·e + c says of the strain e: nominal (a Hencky strain is not linear in the
    extension), in percent when only L0 = 100 k is a plausible gauge length."""
    e = _finite(c.values)
    as_percent, as_fraction = 100.0 * r.value, r.value
    lo, hi = GAUGE_MM
    if lo <= as_percent <= hi and not lo <= as_fraction <= hi:
        g.percent = Fact(True, f"the extension is {r.value:.4g} mm per unit of the strain column: a "
                               f"gauge length of {as_percent:.4g} mm with the strain in percent "
                               f"({as_fraction:.3g} mm as a fraction)")
        top = float(np.max(e)) / 100.0
    elif lo <= as_fraction <= hi and not lo <= as_percent <= hi:
        g.percent = Fact(False, f"a gauge length of {as_fraction:.4g} mm with the strain as a fraction")
        top = float(np.max(e))
    else:
        return
    if abs(math.log1p(top) - top) > 10 * rel.TOL * top:
        g.measure = Fact("nominal", f"linear in the extension up to {top:.3g}: e = ΔL/L0 (a Hencky "
                                    "strain ln(1 + ΔL/L0) would bend)")


def _strain_facts(g: Guess) -> None:
    """The strain measure from the name when no relation fixed it."""
    if g.measure is not None or "strain" not in g.picks:
        return
    label = (g.picks["strain"].column.name or "").lower()
    if HENCKY_NAME.search(label):
        g.measure = Fact("hencky", f"the name {g.picks['strain'].column.label}")
    elif NOMINAL_NAME.search(label):
        g.measure = Fact("nominal", f"the name {g.picks['strain'].column.label}")


def _stress_facts(g: Guess) -> None:
    """An engineering stress by its name, when it is the only stress (no relation shows a true
    stress beside it): 'StressEng01', 'Eng. stress', 'nominal stress'."""
    pick = g.picks.get("stress")
    if pick is None or pick.relation or pick.others or not pick.column.name:
        return
    low = pick.column.name.lower()
    if ENG_NAME.search(low) and not TRUE_NAME.search(low):
        g.stress_measure = Fact("engineering", f"the name {pick.column.label} says an engineering stress "
                                               f"(F/S0), and no other column is a stress")


def _hold(g: Guess) -> None:
    strain = g.picks.get("strain") or g.picks.get("extension")
    load = g.picks.get("force") or g.picks.get("stress")
    if "time" in g.picks and strain is not None and load is not None:
        g.hold = find_hold(_time_values(g), strain.column.values, load.column.values)
