"""The rank plot's statistics (report/rank.py) equal ArviZ's: ranks, Δ-ECDF and the multi-chain
uniformity test with its marked points."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.report import rank

array_stats = pytest.importorskip("arviz_stats.base").array_stats


def _groups(seed: int, shift: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((8, 300))
    x[0] += shift                    # one group off: the test should notice a large shift
    return x


@pytest.mark.parametrize("seed, shift", [(0, 0.0), (1, 0.0), (2, 0.6), (3, 1.5)])
def test_equal_to_arviz(seed, shift) -> None:
    x = _groups(seed, shift)
    ranks = rank.fractional_ranks(x)
    np.testing.assert_array_equal(ranks, array_stats.compute_ranks(x, axis=(-2, -1), relative=True))
    p, b, w = rank.mchain_uniformity_test(ranks)
    p_ref, b_ref, w_ref = array_stats.mchain_uniformity_test(ranks)
    # hypergeometric tails summed here, by scipy's own routine there: they differ in the last digits,
    # which the Cauchy transform tan((1/2 - γ) π) magnifies where γ is small
    assert p == pytest.approx(float(p_ref), rel=1e-4, abs=1e-12)
    np.testing.assert_allclose(b, b_ref, rtol=1e-4, atol=1e-5 * np.abs(b_ref).max())
    np.testing.assert_allclose(w, w_ref, rtol=1e-4, atol=1e-5 * np.abs(w_ref).max())
    mask = rank.suspicious(p, b, w)
    ref_mask = (b_ref > 0) & (w_ref[:, None] > 0) & (p_ref < 0.01)
    np.testing.assert_array_equal(mask, ref_mask)
    points, d = rank.delta_ecdf(ranks, x.shape[1])
    ref_x, ref_y = array_stats.ecdf(ranks, npoints=x.shape[1], pit=True, axis=-1)
    np.testing.assert_allclose(points, ref_x[0])
    np.testing.assert_allclose(d, ref_y, atol=1e-15)
    if shift >= 1.5:
        assert p < 0.01 and mask[:, 0].any()
