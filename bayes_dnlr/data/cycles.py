"""Loading-unloading cycles: where the test turns.

A cyclic test loads the specimen, unloads it, loads it again. Its turning points (the peaks and
valleys of the strain) are the test's history, not corrupt samples, and a window for it is either
the whole history or the first loading. An unloading is told by the stress, which falls by more
than UNLOAD of its value at the peak (and FLOOR of the test's largest stress) while the strain goes
back by more than BACK of its range: a
machine that unloads to a force may reverse the strain by a small share of its range (a stiff
polymer: 0.25 % of strain takes 6 MPa off), a relaxation hold drops the stress by far less at a
constant strain, the wander of a DIC strain in a hold moves the stress by nothing like it, and a
force that falls after its peak in a tensile test (necking, a break) does so while the strain
still rises.

The rule is applied once, when a test is loaded (``TestData.turns``); everything that asks where a
test turns (init's window, the reader's hints, the strain rate of the first loading, the start
check, the branches of the predictive check) reads that one answer. Its thresholds are measured on
real and synthetic tests in docs/thresholds.md ("Turning points").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UNLOAD = 0.5        # the stress falls by this share of its value at the peak: an unloading
FLOOR = 0.1         # ... and by this share of the test's largest stress (a reload rises by as much)
BACK = 0.02         # ... while the strain goes back by this share of its range


@dataclass(frozen=True)
class Turns:
    """The strain's turning points (indices): ``peaks`` where an unloading starts, ``valleys`` where
    a reloading starts, in time order."""

    peaks: tuple[int, ...]
    valleys: tuple[int, ...]

    @property
    def cyclic(self) -> bool:
        """Loaded again after an unloading: a loading-unloading test (one unloading at the end, e.g.
        after a hold or at a break, is not)."""
        return len(self.peaks) >= 2

    @property
    def first_loading_end(self) -> int | None:
        """The index of the first peak: the end of the first loading (None: no unloading)."""
        return self.peaks[0] if self.peaks else None

    @property
    def first_unloading_end(self) -> int | None:
        """The index of the first valley after the first peak (None: no reloading)."""
        return self.valleys[0] if self.valleys else None

    def shifted(self, offset: int) -> Turns:
        """The same turns with ``offset`` added to every index (negative: counted from a later
        sample)."""
        return Turns(tuple(p + offset for p in self.peaks), tuple(v + offset for v in self.valleys))

    def first_peak_within(self, rows: np.ndarray) -> int | None:
        """The first peak that a window of samples (``rows``: their indices, increasing) runs
        past: the end of its first loading; None when the window does not run past a peak."""
        rows = np.asarray(rows)
        if rows.size < 2:
            return None
        return next((p for p in self.peaks if rows[0] <= p < rows[-1]), None)

    def within(self, rows: np.ndarray) -> Turns:
        """The turns among a window's samples (``rows``: their indices, increasing): the positions
        in ``rows`` of the peaks and valleys that lie inside it, before its last sample."""
        rows = np.asarray(rows)

        def inside(ks: tuple[int, ...]) -> tuple[int, ...]:
            if rows.size < 2:
                return ()
            return tuple(int(np.searchsorted(rows, k)) for k in ks if rows[0] <= k < rows[-1])

        return Turns(inside(self.peaks), inside(self.valleys))


NO_TURNS = Turns((), ())


def _next_turn(x: np.ndarray, start: int, floor: float, up: bool) -> tuple[int, int] | None:
    """(the extreme, the index where x has moved back from it) from ``start`` on: for a peak
    (``up``) a fall by more than UNLOAD of the peak's value and than ``floor``, for a valley a rise
    by more than ``floor``; None when x never moves back that far."""
    seg = x[start:] if up else -x[start:]
    top = np.maximum.accumulate(seg)
    need = np.maximum(UNLOAD * top, floor) if up else floor
    back = np.flatnonzero(top - seg > need)
    if not back.size:
        return None
    j = int(back[0])
    return start + int(np.argmax(seg[:j + 1])), start + j


def _stress_turns(stress: np.ndarray, floor: float) -> list[int]:
    """Alternating peaks and valleys of the stress (``_next_turn``)."""
    turns: list[int] = []
    i, up = 0, True
    while True:
        found = _next_turn(stress, i, floor, up)
        if found is None or (turns and found[0] <= i):
            break
        i = found[0]
        turns.append(i)
        up = not up
    return turns


def turning_points(strain: np.ndarray, stress: np.ndarray) -> Turns:
    """The peaks and valleys of the strain where the test unloads and reloads (module doc): the
    stress's turns, each placed on the strain's extreme between its neighbours, kept while the strain
    goes back with the stress. Samples where either is NaN (padding) are left out; the indices
    count every sample."""
    e = np.asarray(strain, dtype=float)
    s = np.asarray(stress, dtype=float)
    ok = np.isfinite(e) & np.isfinite(s)
    if not ok.all():
        keep = np.flatnonzero(ok)
        found = _turning_points(e[keep], s[keep])
        return Turns(tuple(int(keep[p]) for p in found.peaks), tuple(int(keep[v]) for v in found.valleys))
    return _turning_points(e, s)


def _turning_points(e: np.ndarray, s: np.ndarray) -> Turns:
    top = float(np.max(s)) if s.size else 0.0
    if e.size < 3 or not top > 0:
        return NO_TURNS
    turns = _stress_turns(s, FLOOR * top)
    stress_peaks, stress_valleys = turns[0::2], turns[1::2]
    span = float(np.ptp(e))
    peaks: list[int] = []
    valleys: list[int] = []
    for n in range(len(stress_peaks)):
        # the strain's peak between the last valley and the stress's next valley, then its valley
        # before the stress's next peak: the strain must go back there, not only the stress (a
        # force that falls while the strain rises is necking or a break, not an unloading)
        lo = valleys[-1] if valleys else 0
        sv = stress_valleys[n] if n < len(stress_valleys) else e.size - 1
        p = lo + int(np.argmax(e[lo:sv + 1]))
        nxt = stress_peaks[n + 1] if n + 1 < len(stress_peaks) else e.size - 1
        v = p + int(np.argmin(e[p:nxt + 1]))
        if not p < sv or not e[p] - e[v] > BACK * span:
            break
        peaks.append(p)
        if n + 1 < len(stress_peaks):
            valleys.append(v)
    return Turns(tuple(peaks), tuple(valleys))
