"""The O(n) discrepancy likelihood against a dense multivariate normal and against celerite2."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal
from support.likelihood import irregular_axis

from bayes_dnlr.inference.discrepancy import gp

KINDS = ("exp", "matern32")


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("hyper", [(2.0, 7.0, 0.3), (0.5, 40.0, 0.05), (3.0, 0.8, 1.0)])
def test_log_likelihood_equals_the_dense_multivariate_normal(kind, hyper) -> None:
    amplitude, length, sigma0 = hyper
    x = irregular_axis()
    K = gp.covariance(x, amplitude, length, kind, sigma0)
    r = np.random.default_rng(2).multivariate_normal(np.zeros(x.size), K)
    ref = multivariate_normal(np.zeros(x.size), K).logpdf(r)
    # the log-likelihood is a sum of n terms of either sign: compare to 1e-12 of n, not of the sum
    tol = 1e-12 * x.size
    assert gp.log_likelihood(x, r, sigma0, amplitude, length, kind) == pytest.approx(ref, abs=tol)
    batch = gp.log_likelihood_batch(x, np.stack([r, 2 * r, -r]), sigma0, amplitude, length, kind)
    refs = [multivariate_normal(np.zeros(x.size), K).logpdf(v) for v in (r, 2 * r, -r)]
    np.testing.assert_allclose(batch, refs, rtol=0, atol=tol)


@pytest.mark.parametrize("kind", KINDS)
def test_whitening_is_the_cholesky_solve_and_gives_log_det(kind) -> None:
    x = irregular_axis()
    K = gp.covariance(x, 1.5, 12.0, kind, 0.2)
    L = np.linalg.cholesky(K)
    V = np.random.default_rng(3).normal(size=(x.size, 3))
    W, logdet = gp.whiten(x, V, 0.2, 1.5, 12.0, kind)
    np.testing.assert_allclose(W, np.linalg.solve(L, V), rtol=1e-10, atol=1e-10)
    assert logdet == pytest.approx(2.0 * np.log(np.diag(L)).sum(), rel=1e-12)
    w1, _ = gp.whiten(x, V[:, 0], 0.2, 1.5, 12.0, kind)
    np.testing.assert_array_equal(w1, W[:, 0])


@pytest.mark.parametrize("kind", KINDS)
def test_posterior_mean_of_the_discrepancy(kind) -> None:
    x = irregular_axis()
    K = gp.covariance(x, 2.0, 9.0, kind, 0.3)
    r = np.random.default_rng(4).multivariate_normal(np.zeros(x.size), K)
    ref = gp.covariance(x, 2.0, 9.0, kind) @ np.linalg.solve(K, r)
    np.testing.assert_allclose(gp.posterior_mean(x, r, 0.3, 2.0, 9.0, kind), ref, rtol=1e-9,
                               atol=1e-10 * np.abs(ref).max())


def test_zero_amplitude_is_the_white_likelihood() -> None:
    x = irregular_axis()
    r = np.random.default_rng(5).normal(0.0, 0.4, x.size)
    white = multivariate_normal(np.zeros(x.size), 0.16 * np.eye(x.size)).logpdf(r)
    for kind in KINDS:
        assert gp.log_likelihood(x, r, 0.4, 0.0, 10.0, kind) == pytest.approx(white, rel=1e-13)


def test_invalid_hyperparameters_give_minus_infinity_never_nan() -> None:
    x = np.linspace(0, 10, 50)
    R = np.ones((5, 50))
    out = gp.log_likelihood_batch(x, R, [0.3, -0.3, 0.3, 0.3, 0.0], [1.0, 1.0, -1.0, 1.0, 1.0],
                                  [1.0, 1.0, 1.0, np.nan, 1.0])
    assert np.isfinite(out[0]) and np.all(out[1:] == -np.inf)
    with pytest.raises(ValueError, match="invalid hyperparameters"):
        gp.whiten(x, R[0], 0.3, 1.0, -2.0)
    with pytest.raises(ValueError, match="sorted"):
        gp.log_likelihood(x[::-1], R[0], 0.3, 1.0, 1.0)
    with pytest.raises(ValueError, match="unknown discrepancy kernel 'rbf'"):
        gp.log_likelihood(x, R[0], 0.3, 1.0, 1.0, "rbf")


def test_batch_does_not_depend_on_threads_or_grouping() -> None:
    import numba

    rng = np.random.default_rng(6)
    x = np.cumsum(0.2 * (1 + 0.3 * (rng.uniform(size=1000) - 0.5)))
    k = 21                                   # not a multiple of the lane group
    R = rng.normal(size=(k, x.size))
    hyper = (np.full(k, 0.3), rng.uniform(0, 3, k), rng.uniform(0.5, 300, k))
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = gp.log_likelihood_batch(x, R, *hyper)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = gp.log_likelihood_batch(x, R, *hyper)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one, two)
    alone = [gp.log_likelihood_batch(x, R[w:w + 1], *(h[w:w + 1] for h in hyper))[0] for w in range(k)]
    np.testing.assert_array_equal(one, alone)          # a lane's value is its walker's alone
    single = [gp.log_likelihood(x, R[w], *(h[w] for h in hyper)) for w in range(k)]
    np.testing.assert_allclose(one, single, rtol=1e-12)


def test_against_celerite2() -> None:
    """celerite2's RealTerm is the exp kernel exactly; its Matern32Term approximates Matérn-3/2 by
    two exponentials (parameter eps) and converges to this module's value as eps -> 0."""
    celerite2 = pytest.importorskip("celerite2")
    from celerite2 import terms

    rng = np.random.default_rng(7)
    x = np.sort(rng.uniform(0.0, 400.0, 2000))
    r = rng.normal(size=x.size)
    g = celerite2.GaussianProcess(terms.RealTerm(a=4.0, c=1.0 / 7.0))
    g.compute(x, diag=0.09)
    assert gp.log_likelihood(x, r, 0.3, 2.0, 7.0, "exp") == pytest.approx(g.log_likelihood(r), rel=1e-10)
    ours = gp.log_likelihood(x, r, 0.3, 2.0, 7.0, "matern32")
    errors = []
    for eps in (1e-2, 1e-3, 1e-5):
        g = celerite2.GaussianProcess(terms.Matern32Term(sigma=2.0, rho=7.0, eps=eps))
        g.compute(x, diag=0.09)
        errors.append(abs(g.log_likelihood(r) - ours) / abs(ours))
    assert errors[0] > 1e-6                       # the default eps = 0.01 is visibly approximate
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-10


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("start", [0.0, 4.0, 5.0])
def test_pinned_start_equals_the_conditioned_dense_normal(kind, start) -> None:
    """start: δ = 0 (and δ' = 0 for matern32) at ``start``: the Kalman filter's first state is
    P∞ - Φ P∞ Φᵀ; the reference conditions the dense covariance on the pinned state."""
    x = irregular_axis() + 5.0
    K = gp.covariance(x, 2.0, 12.0, kind, 0.3, start=start)
    r = np.random.default_rng(8).multivariate_normal(np.zeros(x.size), K)
    ref = multivariate_normal(np.zeros(x.size), K).logpdf(r)
    assert gp.log_likelihood(x, r, 0.3, 2.0, 12.0, kind, start=start) == pytest.approx(ref, abs=1e-9)
    assert gp.log_likelihood_batch(x, r[None], 0.3, 2.0, 12.0, kind, start=start)[0] == pytest.approx(
        ref, abs=1e-9)
    W, _ = gp.whiten(x, r, 0.3, 2.0, 12.0, kind, start=start)
    np.testing.assert_allclose(W, np.linalg.solve(np.linalg.cholesky(K), r), atol=1e-10)
    mref = (K - 0.09 * np.eye(x.size)) @ np.linalg.solve(K, r)
    np.testing.assert_allclose(gp.posterior_mean(x, r, 0.3, 2.0, 12.0, kind, start=start), mref,
                               atol=1e-9)
    with pytest.raises(ValueError, match="after the first point"):
        gp.log_likelihood(x, r, 0.3, 2.0, 12.0, kind, start=x[0] + 1.0)


@pytest.mark.parametrize("kind", ["exp", "matern32"])
def test_batch_stays_finite_when_the_innovations_are_tiny(kind) -> None:
    """A smooth discrepancy far above the white noise (the real rHDPE curve: σ0 8e-5 MPa, matern32
    amplitude 1 MPa, length 4.5 s, step 0.02 s) makes the innovation variances ~1e-8: a product of
    64 of them underflows. The batch must still equal the scalar filter and the whitening."""
    x = np.arange(422) * 0.02
    rng = np.random.default_rng(5)
    r = np.linalg.cholesky(gp.covariance(x, 1.0, 4.5, kind, 8e-5)) @ rng.standard_normal(x.size)
    args = (8e-5, 1.0, 4.5)
    single = gp.log_likelihood(x, r, *args, kind)
    w, logdet = gp.whiten(x, r[:, None], *args, kind)
    dense = -0.5 * float(w[:, 0] @ w[:, 0]) - 0.5 * logdet - 0.5 * x.size * np.log(2 * np.pi)
    batch = gp.log_likelihood_batch(x, np.vstack([r, r, 0.5 * r]), *args, kind)
    assert np.all(np.isfinite(batch))
    assert batch[0] == batch[1]
    assert batch[0] == pytest.approx(single, rel=1e-10) and single == pytest.approx(dense, rel=1e-10)
