"""Loading-unloading cycles: where the strain turns.

A cyclic test loads the specimen, unloads it, loads it again. Its turning points (the peaks and
valleys of the strain) are the test's history, not corrupt samples, and a window for it is either
the whole history or the first loading. A turn is a fall (or a rise) of the strain by more than
TURN of its range from the extreme before it: the noise of an extensometer or of DIC (about 1 % of
the range in a hold) never makes one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TURN = 0.1          # the strain turns when it moves back by this share of its range


@dataclass(frozen=True)
class Turns:
    """The strain's turning points (indices): ``peaks`` where an unloading starts, ``valleys`` where
    a reloading starts, in time order."""

    peaks: tuple[int, ...]
    valleys: tuple[int, ...]

    @property
    def cyclic(self) -> bool:
        """Loaded again after an unloading: a loading-unloading test (one unloading at the end, e.g.
        after a hold, is not)."""
        return len(self.peaks) >= 2

    @property
    def first_loading_end(self) -> int | None:
        """The index of the first peak: the end of the first loading (None: the strain never turns)."""
        return self.peaks[0] if self.peaks else None

    @property
    def first_unloading_end(self) -> int | None:
        """The index of the first valley after the first peak (None: no reloading)."""
        return self.valleys[0] if self.valleys else None


def _next_turn(x: np.ndarray, start: int, h: float, up: bool) -> tuple[int, int] | None:
    """(the extreme, the index where x has moved back by more than h from it) after ``start``, for a
    rise (``up``: a peak) or a fall (a valley); None when x never moves back that far."""
    seg = x[start:] if up else -x[start:]
    top = np.maximum.accumulate(seg)
    back = np.flatnonzero(top - seg > h)
    if not back.size:
        return None
    j = int(back[0])
    return start + int(np.argmax(seg[:j + 1])), start + j


def turning_points(strain: np.ndarray) -> Turns:
    """The peaks and valleys of ``strain`` (module doc); NaN-free input."""
    x = np.asarray(strain, dtype=float)
    if x.size < 3 or not np.ptp(x) > 0:
        return Turns((), ())
    h = TURN * float(np.ptp(x))
    peaks: list[int] = []
    valleys: list[int] = []
    i, up = 0, True
    while True:         # each turn lies past the one before it: x moved back by more than h between
        found = _next_turn(x, i, h, up)
        if found is None or (found[0] <= i and (peaks or valleys)):
            break
        i = found[0]
        (peaks if up else valleys).append(i)
        up = not up
    return Turns(tuple(peaks), tuple(valleys))
