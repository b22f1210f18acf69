"""Long files: consecutive samples averaged in bins of k rows (``data.reduce``; docs/data-input.md).

Where samples lie much closer than anything the model or the model discrepancy resolves (the
relaxation times that the window identifies, the discrepancy's correlation length), the mean of k
consecutive samples carries their information: the least-squares normal equations (eq. 20-24) of
the bin means, each with noise sd σ0/√k, equal those of the samples up to the curvature of the
model within one bin, O((Δt)² σ''), Δt the bin's span. A fit of 1e6 rows then costs what one of
REDUCE_POINTS rows costs. benchmarks/large_files.py measures the change of E against the full data.
"""

from __future__ import annotations

import math

import numpy as np

REDUCE_POINTS = 20_000    # ``auto``: more rows than this to the window's end are averaged down to this


def rows_per_point(spec: str | int, n: int, strain_input: str = "smoothed") -> int:
    """The bin size k of ``data.reduce`` for n rows up to the window's end: ``none`` 1; ``auto`` the
    smallest k that leaves at most REDUCE_POINTS points (1 for shorter windows, and with
    ``strain_input: measured``, where averaging the strain would change the errors-in-variables
    bias of the estimate); an integer as given."""
    if spec == "none" or (spec == "auto" and strain_input != "smoothed"):
        return 1
    if spec == "auto":
        return max(1, math.ceil(n / REDUCE_POINTS))
    return max(1, int(spec))


def bins(n: int, k: int, keep: int, breaks: list[int]) -> np.ndarray:
    """The start of each bin and n at the end: the first ``keep`` samples alone (the model starts from
    the state there, which a bin's mean, already under load, is not), then bins of k samples that
    never straddle a break (the relaxation start); a segment's last bin holds its rest."""
    edges = sorted({keep, n, *(b for b in breaks if keep < b < n)})
    starts = [np.arange(keep)]
    for a, b in zip(edges[:-1], edges[1:], strict=False):
        starts.append(np.arange(a, b, k))
    return np.concatenate([*starts, [n]]).astype(np.int64)


def bin_means(v: np.ndarray, cuts: np.ndarray) -> np.ndarray:
    """The mean of v over each bin [cuts[i], cuts[i + 1])."""
    v = np.asarray(v, dtype=float)
    sums = np.add.reduceat(v, cuts[:-1])
    return sums / np.diff(cuts)


def reduction_note(n: int, used: int, k: int, spec: str | int) -> str:
    """What ``data.reduce`` did, for the test's notes (printed by fit, kept in fit.json)."""
    where = "" if used >= n else f" ({used} to the window's end)"
    return (f"data.reduce ({spec}): {n} rows{where} averaged in bins of {k} consecutive rows (the first "
            f"row alone; no bin across the relaxation start), after the strain smoothing; σ0 given as "
            f"a number is one row's, σ0/√{k} per point (data.reduce: none keeps every row)")
