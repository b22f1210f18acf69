"""The numpy ESS, R-hat and HDI (inference/mcmc/ess.py) equal ArviZ's on chains with ties and trends."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.mcmc import ess


def _chains(seed: int, chains: int = 8, draws: int = 301, phi: float = 0.8) -> np.ndarray:
    """AR(1) chains with repeated values (rejected proposals) and one shifted chain."""
    rng = np.random.default_rng(seed)
    x = np.empty((chains, draws))
    x[:, 0] = rng.standard_normal(chains)
    for t in range(1, draws):
        step = phi * x[:, t - 1] + np.sqrt(1 - phi**2) * rng.standard_normal(chains)
        stay = rng.uniform(size=chains) < 0.4
        x[:, t] = np.where(stay, x[:, t - 1], step)
    x[0] += 0.3
    return x


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_equal_to_arviz(seed) -> None:
    az = pytest.importorskip("arviz")
    x = _chains(seed, draws=301 + seed)
    assert ess.ess_bulk(x) == pytest.approx(float(az.ess(x, method="bulk")), rel=1e-10)
    assert ess.ess_tail(x, 0.05) == pytest.approx(float(az.ess(x, method="tail", prob=0.05)),
                                                  rel=1e-10)
    assert ess.rhat(x) == pytest.approx(float(az.rhat(x)), rel=1e-12)
    lo, hi = ess.hdi(x.ravel(), 0.9)
    ref = np.asarray(az.hdi(x.ravel(), prob=0.9))
    assert (lo, hi) == (ref[0], ref[1])


def test_constant_and_short_chains() -> None:
    assert ess.ess_bulk(np.ones((4, 50))) == 200.0
    assert np.isnan(ess.ess_bulk(np.ones((4, 3))))
    assert np.isnan(ess.rhat(np.zeros((1, 100)) + np.arange(100)))     # one chain: no R-hat
    x = _chains(3)
    x[2, 7] = np.nan
    assert np.isnan(ess.ess_bulk(x)) and np.isnan(ess.rhat(x))


def test_fast_fft_length() -> None:
    for n in (1, 2, 7, 11, 97, 600, 1001, 4097):
        m = ess.next_fast_len(n)
        assert m >= n
        k = m
        for p in (2, 3, 5):
            while k % p == 0:
                k //= p
        assert k == 1
        assert all(not _smooth(j) for j in range(n, m))


def _smooth(j: int) -> bool:
    for p in (2, 3, 5):
        while j % p == 0:
            j //= p
    return j == 1


def test_normal_quantile_equals_scipy() -> None:
    special = pytest.importorskip("scipy.special")
    p = np.concatenate([np.linspace(1e-12, 1 - 1e-12, 20001), 10.0 ** -np.arange(1, 300),
                        1 - 10.0 ** -np.arange(1, 16)])
    np.testing.assert_allclose(ess.ndtri(p), special.ndtri(p), rtol=1e-14, atol=1e-15)
