"""What ``init`` would have noticed, said by ``fit``: one warning note each, with the fix.

A config written by hand (or an init guess left unchecked) can read a file in a way its own values
contradict. Each check compares the config with the file, using the relations of data/relations.py
and the hold and peak that init looks for:

- a relaxation hold (the strain stays, the stress falls) in the window without
  ``data.relaxation_start``: the model fits the hold as a tensile test;
- ``observable: stress`` on an engineering stress when the file also holds the true stress
  (another column = this one × (1 + e)): σ* is the true stress (eq. 4-6), F/S0 biases E and G;
- a window that ends just past the load peak (yield): a bound meant for the peak that missed it;
- a force read with area0 = 1 mm² (a placeholder), or with an area0 the file's own engineering
  stress contradicts (another column = force / S0 with another S0).
"""

from __future__ import annotations

import numpy as np

from bayes_dnlr.config import DataConfig
from bayes_dnlr.data import relations as rel
from bayes_dnlr.data.cycles import Turns
from bayes_dnlr.data.ramp import find_hold
from bayes_dnlr.data.reading import Table

SAMPLE_ROWS = 2000      # rows of the file compared (evenly spread): enough for a relation, cheap
PEAK_DROP = 0.05        # the load falls this far below its peak after it: a yield peak
JUST_PAST = 0.25        # a window ending within this share of the peak's strain past it: aimed at it
AREA_TOL = 0.01         # area0 and the file's own S0 differ by more than this: one of them is wrong


def _ref(table: Table, j: int) -> str:
    """'column 10' (counted in the specimen's group, as data.columns takes it), with its name when
    the header sits over the columns."""
    first, _ = table.group
    header = table.layout.header if table.layout is not None else None
    name = (header[first + j] if header is not None and table.layout is not None
            and len(header) == table.layout.n_fields and header[first + j] else None)
    return f"column {j + 1}" + (f" ('{name}')" if name else "")


def _rows(n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, SAMPLE_ROWS)).astype(int))


def hold_without_start(d: DataConfig, time: np.ndarray, strain: np.ndarray, stress: np.ndarray,
                       window: np.ndarray, first: int, turns: Turns) -> str | None:
    """A hold inside the window while ``data.relaxation_start`` is not set (``turns``: the test's
    turning points, data/cycles.py: a test that unloads has no hold)."""
    if d.relaxation_start is not None:
        return None
    hold = find_hold(time[first:], strain[first:], stress[first:], turns)
    if hold is None or int(np.flatnonzero(window)[-1]) < first + hold.start + 5:
        return None
    return (f"warning: a relaxation hold: {hold.describe()} MPa, but data.relaxation_start is not set, "
            f"so the model fits the hold as a tensile test (G and tau_max pushed to their bounds); set "
            f"data.relaxation_start: auto (docs/data-input.md)")


def engineering_as_true(d: DataConfig, table: Table, nominal: np.ndarray) -> str | None:
    """``observable: stress`` on a column that another column of the file shows to be the
    engineering stress (that column = this one × (1 + e), or × exp(ε))."""
    if d.observable != "stress" or "stress" not in table.values or d.stress_measure == "engineering":
        return None
    rows = _rows(nominal.size)
    others = table.group_sample(rows)
    mine = table.columns["stress"] - table.group[0]
    stress, e = table.values["stress"][rows], nominal[rows]
    for j, col in enumerate(others):
        if j == mine:
            continue
        r = rel.true_stress(stress, col, e, 0, 1, 2)
        if r is None or r.percent:
            r = rel.true_stress(stress, col, np.log1p(e), 0, 1, 2, hencky=True)
        if r is not None and not r.percent:
            return (f"warning: data.columns.stress ({_ref(table, mine)}) is an engineering stress: "
                    f"{_ref(table, j)} equals it × (1 + e) on every row (the true stress, to "
                    f"{max(r.deviation, 1e-16):.0e}); observable: stress takes the column as the true "
                    f"stress, which biases E and G: set data.columns.stress: {j + 1}")
    return None


def area_check(d: DataConfig, table: Table) -> str | None:
    """A force read with area0 = 1 mm² (a placeholder), or with an area0 that the file's own
    engineering stress contradicts."""
    if "force" not in table.values or d.observable == "stress" or d.area0 is None:
        return None
    force = table.values["force"]
    rows = _rows(force.size)
    mine = table.columns["force"] - table.group[0]
    for j, col in enumerate(table.group_sample(rows)):
        r = rel.area(force[rows], col, 0, 1) if j != mine else None
        if r is not None and abs(r.value - d.area0) > AREA_TOL * r.value:
            return (f"warning: data.area0 is {d.area0:g} mm², but {_ref(table, j)} = force / "
                    f"{r.value:.6g} on every row: the file's own engineering stress was computed with "
                    f"S0 = {r.value:.6g} mm², so the stress (and E) is {r.value / d.area0:.3g} times what "
                    f"the file says; set data.area0: {r.value:.6g} (or check it)")
    if d.area0 == 1.0:
        return ("warning: data.area0 is 1 mm² with a force column: the stress is the force in N (a "
                "placeholder?), and E comes out S0 times too large; set data.area0 to the specimen's "
                "initial cross-section in mm²")
    return None


def _bound(x: float, nxt: float) -> float | None:
    """The shortest decimal d with x <= d < nxt: a strain_max that ends the window on the sample x;
    None when there is none (the strain does not rise after x)."""
    for digits in range(3, 13):
        scale = 10.0 ** (np.floor(np.log10(x)) - digits + 1)
        v = float(f"{np.ceil(x / scale) * scale:.{digits}g}")
        if x <= v < nxt:
            return v
    return None


def _time_bound(t: float, nxt: float) -> float:
    """The shortest decimal d with t <= d < nxt: a time_max that ends the window on the sample t."""
    for digits in range(3, 16):
        v = float(f"{t:.{digits}g}")
        if t <= v < nxt:
            return v
    return t


def peak_window(time: np.ndarray, strain: np.ndarray, k: int) -> dict[str, float]:
    """The window that ends on sample k: ``{strain_max: ...}`` when the strain rises past sample k
    (the bound reads the measured strain), else ``{time_max: ...}`` (the strain turns there: an
    unloading follows)."""
    nxt = float(strain[k + 1]) if k + 1 < strain.size else np.inf
    x = float(strain[k])
    v = _bound(x, nxt) if x > 0 and float(np.max(strain[:k + 1])) <= x else None
    if v is not None:
        return {"strain_max": v}
    return {"time_max": _time_bound(float(time[k]), float(time[k + 1]) if k + 1 < time.size else np.inf)}


def window_past_peak(d: DataConfig, time: np.ndarray, strain: np.ndarray, load: np.ndarray,
                     window: np.ndarray, relaxation_start: float | None, first: int,
                     turns: Turns) -> str | None:
    """A window that ends just past the load peak (yield): its upper bound was meant for the peak
    (a bound on another strain column, a rounding) and lets in samples of the load's fall, where a
    crosshead strain is not the specimen's (necking). A window that goes on well past the peak, or
    to the end of the loading, is a choice, not flagged. In a loading-unloading test the loading is
    the first one (its peak a turning point, the unloading after it the fall; ``turns``: the
    test's turning points, data/cycles.py). ``strain``: the measured Hencky strain, which the
    window's strain bounds read. Never recommends the window set."""
    w = d.window
    if w.strain_max is None and w.time_max is None:
        return None
    load_end = time.size if relaxation_start is None else int(np.searchsorted(time, relaxation_start))
    valley = turns.first_unloading_end
    if valley is not None and valley < load_end:
        load_end = valley + 1
    v = load[first:load_end]
    if v.size < 10:
        return None
    k = int(np.argmax(v))
    top = float(v[k])
    end = int(np.flatnonzero(window)[-1]) - first
    if turns.first_loading_end is not None and end + first == turns.first_loading_end:
        return None         # the first loading of cycles, to the strain's turn: init's own window
    if not top > 0 or float(v[k:].min()) > (1 - PEAK_DROP) * top or end <= k or end >= v.size - 1:
        return None
    e = strain[first:load_end]
    rise = float(e[k] - e[0])
    if not rise > 0 or float(e[end] - e[k]) > JUST_PAST * rise:
        return None
    fix = peak_window(time[first:load_end], e, k)
    if all(getattr(w, key) == value for key, value in fix.items()):
        return None
    past = float(time[first + end] - time[first + k])
    said = ", ".join(f"{key}: {value:g}" for key, value in fix.items())
    return (f"warning: data.window ends {past:.3g} s ({end - k} samples) past the load peak (yield) at "
            f"t = {time[first + k]:.6g} s, Hencky strain {e[k]:.4g}: a bound meant for the peak lets in "
            f"the load's fall, where a crosshead strain is not the specimen's (necking); end the window "
            f"at the peak, data.window: {{{said}}} (or take the whole test, {{}}, with a strain measured "
            f"on a homogeneous specimen)")
