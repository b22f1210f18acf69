"""The discrepancy's axis (time or strain) on the compared samples of a test: sorted values, the
order that sorts them, where δ is pinned. Plain numpy, no compiled code: the report places a cached
discrepancy on it without loading numba.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayes_dnlr.config import DiscrepancyConfig


@dataclass(frozen=True)
class Axis:
    """The discrepancy's axis on the compared samples: sorted values, and the order that sorts the
    window's samples (None when they are sorted already)."""

    name: str                   # time | strain
    values: np.ndarray          # sorted
    order: np.ndarray | None
    unit: str                   # s | - (strain)
    origin: float | None = None  # where δ is pinned to 0 (the test's first sample); None: stationary

    @property
    def median_step(self) -> float:
        d = np.diff(self.values)
        d = d[d > 0]
        return float(np.median(d)) if d.size else 1.0

    @property
    def span(self) -> float:
        return float(self.values[-1] - self.values[0]) if self.values.size > 1 else 1.0

    def sort(self, v: np.ndarray) -> np.ndarray:
        """Window-ordered values (n,) or (n, m), or (k, n) with ``rows=True``, in axis order."""
        return v if self.order is None else v[self.order]


def make_axis(kind: str, time: np.ndarray, strain: np.ndarray, origin: float | None = None) -> Axis:
    """The axis of the compared samples (``time`` and ``strain`` already restricted to them);
    ``origin``: the test's first sample on this axis, where δ is pinned (None: stationary δ)."""
    x = np.asarray(time if kind == "time" else strain, dtype=float)
    unit = "s" if kind == "time" else "-"
    if np.all(np.diff(x) >= 0):
        xs, order = np.ascontiguousarray(x), None
    else:
        order = np.argsort(x, kind="stable")
        xs = np.ascontiguousarray(x[order])
    if origin is not None:
        origin = min(float(origin), float(xs[0]))
    return Axis(kind, xs, order, unit, origin)


def test_axis(spec: DiscrepancyConfig, test, rows) -> Axis:
    """The discrepancy's axis on the compared samples ``rows`` of a TestData (a mask or indices
    into its first ``len`` samples), pinned at the test's first sample unless ``start: stationary``."""
    t = np.asarray(test.time)
    e = np.asarray(test.strain_input)
    n = len(rows) if isinstance(rows, np.ndarray) and rows.dtype == bool else test.model_end
    origin = None
    if spec.start == "pinned":
        origin = float(t[0] if spec.axis == "time" else e[0])
    return make_axis(spec.axis, t[:n][rows], e[:n][rows], origin)
