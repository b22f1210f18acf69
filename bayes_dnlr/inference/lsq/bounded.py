"""Linear least squares within bounds for the few linear parameters of variable projection (E, G,
sigma_inf; a joint fit's shared and per-test ones): argmin |A c - b| with lo <= c <= hi.

The optimum is the unconstrained least squares of its free columns with the other columns held on
their bounds, and it is feasible; every other such choice is worse or infeasible. So among the 3^p
choices (free, at its low bound, at its high bound) for p columns, the feasible one of least residual
is the optimum, exactly: no iteration and no tolerance. Each choice is solved on the p × p triangle
R of A = QR (|A c - b|² = |R c - Qᵀb|² + a constant), so a choice costs microseconds whatever the
number of samples. Beyond ``MAX_ENUMERATED`` columns scipy's ``lsq_linear`` (bounded-variable least
squares, iterative) takes over.
"""

from __future__ import annotations

import itertools

import numpy as np

MAX_ENUMERATED = 6      # 3^6 = 729 choices of p × p systems


def bounded_lstsq(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """argmin |A c - b| within lo <= c <= hi (columns scaled for conditioning)."""
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    c = np.linalg.lstsq(A / scale, b, rcond=None)[0] / scale
    if np.any(c < lo) or np.any(c > hi):
        As, ls, hs = A / scale, np.asarray(lo) * scale, np.asarray(hi) * scale
        if As.shape[1] <= MAX_ENUMERATED:
            c = enumerated_lstsq(As, b, ls, hs) / scale
        else:
            from scipy.optimize import lsq_linear

            c = lsq_linear(As, b, bounds=(ls, hs)).x / scale
    return c


def enumerated_lstsq(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The bounded optimum by every choice of free and bound columns (module docstring)."""
    p = A.shape[1]
    q, r = np.linalg.qr(A)
    d = q.T @ b
    best, best_value = None, np.inf
    for states in itertools.product((0, 1, 2), repeat=p):      # free, on lo, on hi
        c = np.zeros(p)
        held = [j for j, s in enumerate(states) if s]
        edge = [lo[j] if states[j] == 1 else hi[j] for j in held]
        if not np.all(np.isfinite(edge)):
            continue
        c[held] = edge
        free = [j for j, s in enumerate(states) if not s]
        if free:
            c[free] = np.linalg.lstsq(r[:, free], d - r[:, held] @ c[held], rcond=None)[0]
            if np.any(c[free] < lo[free]) or np.any(c[free] > hi[free]):
                continue
        value = float(np.sum((r @ c - d) ** 2))
        if value < best_value:
            best, best_value = c, value
    if best is None:            # no finite bound where one is needed: the nearest point of the box
        best = np.clip(np.linalg.lstsq(r, d, rcond=None)[0], lo, hi)
    return best
