"""data/brent.py is scipy's bounded Brent step for step: the same minimum, the same GCV λ."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayes_dnlr.data import smoothing
from bayes_dnlr.data.brent import fminbound

optimize = pytest.importorskip("scipy.optimize")


@pytest.mark.parametrize("f, lo, hi", [
    (lambda x: (x - 1.3) ** 2, -3.0, 4.0),
    (lambda x: math.cos(x) + 0.1 * x, 0.0, 10.0),
    (lambda x: abs(x - 0.25) ** 0.7, -1.0, 1.0),
    (lambda x: 3.0, -2.0, 2.0),
    (lambda x: -x, 0.0, 1.0),                    # at a bound
])
def test_same_steps_as_scipy(f, lo, hi) -> None:
    for xatol in (1e-5, 1e-3):
        ref = optimize.minimize_scalar(f, bounds=(lo, hi), method="bounded",
                                       options={"xatol": xatol})
        x, fun = fminbound(f, lo, hi, xatol=xatol)
        assert x == float(ref.x) and fun == float(ref.fun)


def test_same_gcv_lambda_as_scipy() -> None:
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 380.0, 2000)
    e = 5e-3 * t + 1e-4 * rng.standard_normal(t.size)
    u, z, *_ = smoothing._scaled(t, e)
    fit = np.empty_like(z)
    ours = smoothing._search(u, z)
    grid = np.arange(smoothing.LOG_LAMBDA[0], smoothing.LOG_LAMBDA[1] + 0.5, 1.0)
    scores = np.array([smoothing._gcv(u, z, g, fit) for g in grid])
    k = int(np.argmin(scores))
    ref = optimize.minimize_scalar(lambda g: smoothing._gcv(u, z, g, fit),
                                   bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]),
                                   method="bounded", options={"xatol": 1e-3})
    assert ours == (float(ref.x) if ref.fun <= scores[k] else float(grid[k]))


def test_bad_bounds() -> None:
    with pytest.raises(ValueError, match="bounds"):
        fminbound(lambda x: x, 1.0, 0.0)
