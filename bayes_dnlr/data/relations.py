"""Relations between the columns of an export that say what each column is, computed from the values.

An engineer reading an export without trusting its header checks how the columns depend on each
other; each relation here holds to the precision the file writes its numbers, or not at all:

- a true stress is the engineering stress times (1 + e), e the nominal strain (isovolumic, eq. 4-6:
  σ = F/S0 · exp(ε) = F/S0 · (1 + e)), or times exp(ε) with a Hencky strain;
- a Hencky strain is ln(1 + e) (eq. 1);
- an engineering stress is the force over a constant cross-section S0 (F/S0, MPa with N and mm²);
- an extension and a strain are the same deformation in other units: x = k·e + c (k = L0, or L0/100
  for a strain in percent), and two channels of one strain differ by a constant offset.

``init`` confirms its guesses with them and writes the relation beside each; ``fit`` uses them to
notice a config that reads the wrong column (an engineering stress taken as the true stress, an
area0 that contradicts the file's own stress column).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

TOL = 2e-3          # largest deviation, relative to the column's largest value, of a relation that holds
MIN_ROWS = 10       # rows needed to call a relation confirmed
APART_MIN = 1e-9    # two readings closer than this (relative) are one, whatever the file's precision
STRAIN_UNITS = ((1.0, False), (0.01, True))     # (factor to a fraction, percent?)


@dataclass(frozen=True)
class Relation:
    """``target`` is computed from ``sources`` (column indices); ``value``: S0 (mm²) for 'area', the
    factor k for 'linear'; ``deviation``: the largest misfit relative to the target's largest value."""

    kind: str                   # 'true-stress' | 'true-stress-hencky' | 'hencky' | 'area' | 'linear'
    target: int
    sources: tuple[int, ...]
    deviation: float
    value: float = 1.0
    offset: float = 0.0
    percent: bool = False       # the nominal strain source is in percent

    def formula(self, label: Callable[[int], str]) -> str:
        """The relation with the columns named by ``label``: 'column 10 = column 4 × (1 + column 2)'."""
        t = label(self.target)
        s = [label(i) for i in self.sources]
        e = f"{s[-1]}/100" if self.percent else s[-1]
        if self.kind == "true-stress":
            return f"{t} = {s[0]} × (1 + {e})"
        if self.kind == "true-stress-hencky":
            return f"{t} = {s[0]} × exp({s[1]})"
        if self.kind == "hencky":
            return f"{t} = ln(1 + {e})"
        if self.kind == "area":
            return f"{t} = {s[0]} / {self.value:.6g}"
        sign = "+" if self.offset >= 0 else "-"
        k = "" if abs(self.value - 1) < 1e-9 else f"{self.value:.6g} × "
        return f"{t} = {k}{s[0]} {sign} {abs(self.offset):.4g}"

    def text(self, label: Callable[[int], str]) -> str:
        """The formula and how well it holds."""
        return f"{self.formula(label)} (to {max(self.deviation, 1e-16):.0e})"


def _usable(*cols: np.ndarray) -> np.ndarray:
    ok = np.ones(cols[0].shape, bool)
    for c in cols:
        ok &= np.isfinite(c)
    return ok


def _misfit(target: np.ndarray, model: np.ndarray, ok: np.ndarray) -> float:
    scale = float(np.max(np.abs(target[ok]))) if ok.any() else 0.0
    return float(np.max(np.abs(target[ok] - model[ok]))) / scale if scale > 0 else np.inf


def _tells(apart: float, dev: float) -> bool:
    """A relation that holds to ``dev`` tells its two readings apart (a true from an engineering
    stress, ln(1 + e) from e) when they differ by ``apart``, ten times more: a file written to 9
    digits tells them apart at 0.8 % strain, one that rounds to 2e-3 only past 2 %."""
    return apart > max(10.0 * dev, APART_MIN)


def true_stress(eng: np.ndarray, true: np.ndarray, strain: np.ndarray, i: int, j: int, k: int,
                hencky: bool = False) -> Relation | None:
    """``true`` (column j) = ``eng`` (column i) × (1 + e) with ``strain`` (column k) the nominal
    strain as a fraction or in percent, or × exp(ε) with a Hencky ``strain``; None when it does not
    hold, or when the strain is too small for the relation to tell the two stresses apart."""
    ok = _usable(eng, true, strain)
    if ok.sum() < MIN_ROWS or not np.max(np.abs(true[ok])) > 0:
        return None
    best = None
    for factor, percent in ((1.0, False),) if hencky else STRAIN_UNITS:
        e = np.where(ok, factor * strain, 0.0)
        if hencky and np.max(e) > 50:           # not a Hencky strain: exp would overflow
            return None
        model = eng * (np.exp(e) if hencky else 1.0 + e)
        dev = _misfit(true, model, ok)
        apart = _misfit(true, eng, ok)           # how far the two stresses are: the relation must matter
        if dev <= TOL and _tells(apart, dev) and (best is None or dev < best.deviation):
            kind = "true-stress-hencky" if hencky else "true-stress"
            best = Relation(kind, j, (i, k), dev, percent=percent)
    return best


def hencky(h: np.ndarray, e: np.ndarray, i: int, k: int) -> Relation | None:
    """``h`` (column i) = ln(1 + e) with ``e`` (column k) the nominal strain (fraction or percent),
    where the strain is large enough that ln(1 + e) and e differ beyond the tolerance."""
    ok = _usable(h, e) & (e > -0.99)
    if ok.sum() < MIN_ROWS:
        return None
    for factor, percent in STRAIN_UNITS:
        x = factor * e
        model = np.log1p(np.where(ok, x, 0.0))
        dev = _misfit(h, model, ok)
        if dev <= TOL and _tells(_misfit(h, x, ok), dev):
            return Relation("hencky", i, (k,), dev, percent=percent)
    return None


def area(force: np.ndarray, stress: np.ndarray, i: int, j: int) -> Relation | None:
    """``stress`` (column j) = ``force`` (column i) / S0 with one S0 on every loaded row."""
    ok = _usable(force, stress)
    if ok.sum() < MIN_ROWS:
        return None
    top = float(np.max(np.abs(stress[ok])))
    loaded = ok & (np.abs(stress) > 0.1 * top) if top > 0 else ok & False
    if loaded.sum() < MIN_ROWS:
        return None
    ratio = force[loaded] / stress[loaded]
    s0 = float(np.median(ratio))
    if not s0 > 0 or abs(s0 - 1.0) < 1e-9:      # a copy of the same column is not a cross-section
        return None
    dev = _misfit(stress, force / s0, ok)
    line = linear(force, stress, i, j)
    if line is not None and dev > 10 * line.deviation + 1e-6:
        return None                             # an offset between them: not F/S0
    return Relation("area", j, (i,), dev, value=s0) if dev <= TOL else None


def linear(a: np.ndarray, b: np.ndarray, i: int, j: int) -> Relation | None:
    """``b`` (column j) = k × ``a`` (column i) + c on every row: one deformation in two units or
    with two zeros (not an identical copy)."""
    ok = _usable(a, b)
    if ok.sum() < MIN_ROWS or np.ptp(a[ok]) == 0 or np.ptp(b[ok]) == 0:
        return None
    k, c = np.polyfit(a[ok], b[ok], 1)
    if k == 0 or (abs(k - 1) < 1e-9 and abs(c) < 1e-12):
        return None
    dev = float(np.max(np.abs(b[ok] - (k * a[ok] + c)))) / float(np.ptp(b[ok]))
    return Relation("linear", j, (i,), dev, value=float(k), offset=float(c)) if dev <= TOL else None


def rising(v: np.ndarray) -> bool:
    """A column a tensile test makes grow: finite, positive at its largest, which lies well above
    its start (a load may fall after it: yield, a relaxation hold)."""
    f = v[np.isfinite(v)]
    if f.size < MIN_ROWS or np.ptp(f) == 0:
        return False
    top = float(np.max(f))
    return top > 0 and float(np.min(f)) >= -0.05 * top and top - f[0] > 0.5 * np.ptp(f)


DRIVEN_R2 = 0.98    # a deformation the machine drives grows (nearly) linearly with time while it rises


def driven(time: np.ndarray, v: np.ndarray) -> bool:
    """A deformation (strain or extension) rather than a load: on its way up (to 99 % of its rise)
    it is a straight line of time to R² >= DRIVEN_R2, as a machine at constant speed makes it; a
    load bends (yield, relaxation)."""
    ok = np.isfinite(time) & np.isfinite(v)
    t, x = time[ok], v[ok]
    if x.size < MIN_ROWS or np.ptp(x) == 0 or np.ptp(t) == 0:
        return False
    top = int(np.argmax(x >= x.min() + 0.99 * np.ptp(x)))
    t, x = t[:top + 1], x[:top + 1]
    if x.size < MIN_ROWS or np.ptp(t) == 0:
        return False
    return float(np.corrcoef(t, x)[0, 1] ** 2) >= DRIVEN_R2


def classify(values: list[np.ndarray], time: np.ndarray, skip: set[int] = frozenset()
             ) -> tuple[list[int], list[int]]:
    """(deformations, loads): the rising columns not in ``skip``, split by ``driven``."""
    cand = [i for i, v in enumerate(values) if i not in skip and rising(v)]
    deform = [i for i in cand if driven(time, values[i])]
    return deform, [i for i in cand if i not in deform]


def find(values: list[np.ndarray], time: np.ndarray, skip: set[int] = frozenset()) -> list[Relation]:
    """Every relation among the rising columns of ``values`` (indices not in ``skip``), each between
    the columns it can join: a true stress from two other columns (an engineering stress and a
    strain, whichever of them the machine drives: a stress-controlled ramp rises as straight as a
    strain); an area between two loads; a Hencky strain and a linear pair between two deformations.
    The true stress is sought among every rising column, so that no guess about which column is a
    load decides it: the relation itself does."""
    deform, loads = classify(values, time, skip)
    rising_cols = sorted({*deform, *loads})
    out: list[Relation | None] = []
    for i in loads:
        for j in loads:
            if i != j and np.nanmax(np.abs(values[i])) > np.nanmax(np.abs(values[j])):
                out.append(area(values[i], values[j], i, j))
    for i in rising_cols:
        for j in rising_cols:
            if i == j or not np.nanmax(values[j]) > np.nanmax(values[i]):   # σ = s·(1 + e) > s
                continue
            for k in rising_cols:
                if k not in (i, j):
                    out.append(true_stress(values[i], values[j], values[k], i, j, k)
                               or true_stress(values[i], values[j], values[k], i, j, k, hencky=True))
    for i in deform:
        for j in deform:
            if i != j:
                out.append(hencky(values[j], values[i], j, i))
                if i < j:
                    out.append(linear(values[i], values[j], i, j))
    return sorted((r for r in out if r is not None), key=lambda r: (r.kind, r.target, r.deviation))
