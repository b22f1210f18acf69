"""Bounded linear least squares of variable projection (inference/lsq/bounded.py): the exact
optimum by every choice of free and bound columns, against scipy's iterative lsq_linear."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from bayes_dnlr.inference.lsq.bounded import MAX_ENUMERATED, bounded_lstsq, enumerated_lstsq


def _problem(rng: np.random.Generator, p: int):
    n = int(rng.integers(p + 2, 200))
    A = rng.normal(size=(n, p)) @ np.diag(10.0 ** rng.uniform(-3, 3, p))
    if p > 1 and rng.random() < 0.3:
        A[:, 1] = 0.999 * A[:, 0] + 0.001 * A[:, 1]        # nearly collinear columns
    b = 5.0 * rng.normal(size=n)
    lo = np.where(rng.random(p) < 0.3, -np.inf, rng.normal(size=p))
    base = np.where(np.isfinite(lo), lo, rng.normal(size=p) - 1.0)
    hi = np.where(rng.random(p) < 0.3, np.inf, base + np.abs(rng.normal(size=p)) + 0.01)
    return A, b, lo, hi


@pytest.mark.parametrize("p", [1, 2, 3, 4])
def test_the_bounded_optimum_is_scipys_or_better(p: int) -> None:
    rng = np.random.default_rng(p)
    bound = 0
    for _ in range(60):
        A, b, lo, hi = _problem(rng, p)
        c = bounded_lstsq(A, b, lo, hi)
        scale = np.linalg.norm(A, axis=0)
        ref = lsq_linear(A / scale, b, bounds=(lo * scale, hi * scale), tol=1e-14).x / scale
        # inside the box, to the rounding of the column scaling
        assert np.all(c >= lo - 1e-15 * np.abs(lo)) and np.all(c <= hi + 1e-15 * np.abs(hi))
        ours, theirs = np.sum((A @ c - b) ** 2), np.sum((A @ ref - b) ** 2)
        assert ours <= theirs * (1 + 1e-10)
        bound += bool(np.any(c <= lo) or np.any(c >= hi))
    assert bound > 10                     # the bounds do bind in many of the problems


def test_a_known_optimum_on_a_bound() -> None:
    """y = 2 x1 - x2 with x2's coefficient bounded at 0: the fit holds it there and refits x1."""
    rng = np.random.default_rng(0)
    A = rng.normal(size=(50, 2))
    b = A @ np.array([2.0, -1.0])
    c = enumerated_lstsq(A, b, np.array([-np.inf, 0.0]), np.array([np.inf, np.inf]))
    assert c[1] == 0.0
    assert c[0] == pytest.approx(float(A[:, 0] @ b / (A[:, 0] @ A[:, 0])), rel=1e-12)


def test_inside_the_box_it_is_plain_least_squares() -> None:
    rng = np.random.default_rng(1)
    A, b = rng.normal(size=(40, 3)), rng.normal(size=40)
    scale = np.linalg.norm(A, axis=0)
    free = np.linalg.lstsq(A / scale, b, rcond=None)[0] / scale
    c = bounded_lstsq(A, b, np.full(3, -1e9), np.full(3, 1e9))
    assert np.array_equal(c, free)


def test_many_columns_go_to_scipy() -> None:
    rng = np.random.default_rng(2)
    p = MAX_ENUMERATED + 1
    A, b = rng.normal(size=(60, p)), rng.normal(size=60)
    lo, hi = np.zeros(p), np.full(p, np.inf)
    c = bounded_lstsq(A, b, lo, hi)
    assert np.all(c >= 0) and np.any(c < 1e-12)         # lsq_linear: on the bound to its tolerance
