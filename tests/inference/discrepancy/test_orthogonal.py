"""The orthogonal discrepancy (inference/discrepancy/orthogonal.py and kalman.py): its O(n p²)
likelihood against a dense multivariate normal with the same conditioning, the projection
variance, and the offsets of the draws."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.likelihood import irregular_axis

from bayes_dnlr.inference.discrepancy import gp, orthogonal

KINDS = ("exp", "matern32")
LD = np.longdouble


def _kernel_ld(x: np.ndarray, a: float, length: float, kind: str, start: float | None) -> np.ndarray:
    """k(x, x) in extended precision (conditioned on the pinned start like gp.covariance)."""
    x = np.asarray(x, dtype=LD)
    a, length = LD(a), LD(length)
    lam = (LD(1) if kind == "exp" else np.sqrt(LD(3))) / length

    def k(p: np.ndarray, q: np.ndarray) -> np.ndarray:
        u = lam * np.abs(p[:, None] - q[None, :])
        return a * a * np.exp(-u) * (1 if kind == "exp" else 1 + u)

    K = k(x, x)
    if start is not None:
        c = k(x, np.array([LD(start)]))[:, 0]
        K = K - np.outer(c, c) / (a * a)
        if kind == "matern32":
            tau = x - LD(start)
            d = a * a * lam * lam * tau * np.exp(-lam * tau)      # cov(δ(x), δ'(start))
            K = K - np.outer(d, d) / (a * a * lam * lam)
    return K


def _cholesky_ld(A: np.ndarray) -> np.ndarray:
    n = A.shape[0]
    L = np.zeros_like(A)
    for j in range(n):
        L[j, j] = np.sqrt(A[j, j] - L[j, :j] @ L[j, :j])
        L[j + 1:, j] = (A[j + 1:, j] - L[j + 1:, :j] @ L[j, :j]) / L[j, j]
    return L


def _solve_lower_ld(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    z = np.zeros(b.shape, dtype=LD)
    for i in range(L.shape[0]):
        z[i] = (b[i] - L[i, :i] @ z[:i]) / L[i, i]
    return z


def dense_orthogonal_logpdf(x, r, sigma0, a, length, kind, V, start=None) -> float:
    """log N(r | 0, K - K V (Vᵀ K V)⁻¹ Vᵀ K + σ0² I), formed and factorised densely in extended
    precision (the subtraction of K V M⁻¹ Vᵀ K from K loses digits in double precision)."""
    K = _kernel_ld(x, a, length, kind, start)
    V = np.asarray(V, dtype=LD)
    U = K @ V
    LM = _cholesky_ld(V.T @ U)
    W = np.array([_solve_lower_ld(LM, u) for u in U])           # U L_M⁻ᵀ
    S = K - W @ W.T + LD(sigma0) ** 2 * np.eye(len(x), dtype=LD)
    L = _cholesky_ld(S)
    z = _solve_lower_ld(L, np.asarray(r, dtype=LD))
    return float(-z @ z / 2 - np.log(np.diag(L)).sum() - LD(len(x)) / 2 * np.log(2 * LD(math.pi)))


def _columns(x: np.ndarray) -> np.ndarray:
    t = (x - x.mean()) / x.std()
    return np.column_stack([np.ones_like(x), 2.0 * t, np.sin(2.0 * t)])


def _draw(x, a, length, kind, sigma0, V, start, rng) -> np.ndarray:
    """δ⊥ + ε: a draw of δ with its component along V removed by conditioning (kriging), plus noise."""
    K = gp.covariance(x, a, length, kind, 0.0, start)
    d = np.linalg.cholesky(K + 1e-12 * a * a * np.eye(x.size)) @ rng.standard_normal(x.size)
    U = K @ V
    return d - U @ np.linalg.solve(V.T @ U, V.T @ d) + sigma0 * rng.standard_normal(x.size)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("hyper", [(2.0, 7.0, 0.3), (0.5, 40.0, 0.05), (3.0, 0.8, 1.0), (1e-3, 10.0, 0.3),
                                   (1e-6, 10.0, 0.3), (1.0, 300.0, 0.01)])
@pytest.mark.parametrize("start", [None, 2.0])
def test_orthogonal_likelihood_equals_the_dense_conditioned_normal(kind, hyper, start) -> None:
    """On an uneven grid with a repeated point and a long gap, stationary or pinned, amplitudes from
    1e-6 to 200 times the noise: to 1e-10 (absolute; the values are O(100-1000))."""
    a, length, sigma0 = hyper
    x = irregular_axis() + 5.0
    V = _columns(x)
    rng = np.random.default_rng(3)
    r = _draw(x, a, length, kind, sigma0, V, start, rng)
    ref = dense_orthogonal_logpdf(x, r, sigma0, a, length, kind, V, start)
    assert gp.log_likelihood(x, r, sigma0, a, length, kind, start, V) == pytest.approx(ref, abs=1e-10)
    batch = gp.log_likelihood_batch(x, np.stack([r, -r]), sigma0, a, length, kind, start, V)
    np.testing.assert_allclose(batch, [ref, ref], rtol=0, atol=1e-10)


@pytest.mark.parametrize("kind", KINDS)
def test_the_conditioning_changes_the_likelihood_and_no_columns_is_the_plain_one(kind) -> None:
    x = irregular_axis()
    r = np.random.default_rng(4).normal(size=x.size)
    plain = gp.log_likelihood(x, r, 0.3, 1.0, 9.0, kind)
    assert gp.log_likelihood(x, r, 0.3, 1.0, 9.0, kind, V=np.zeros((x.size, 0))) == plain
    assert abs(gp.log_likelihood(x, r, 0.3, 1.0, 9.0, kind, V=_columns(x)) - plain) > 1.0
    # amplitude 0: no discrepancy to condition; the white likelihood
    white = gp.log_likelihood(x, r, 0.3, 0.0, 9.0, kind)
    assert gp.log_likelihood(x, r, 0.3, 0.0, 9.0, kind, V=_columns(x)) == white


@pytest.mark.parametrize("kind", KINDS)
def test_batch_with_columns_is_independent_of_threads_and_grouping(kind) -> None:
    import numba

    rng = np.random.default_rng(6)
    x = np.cumsum(0.2 * (1 + 0.3 * (rng.uniform(size=800) - 0.5)))
    V = _columns(x)
    k = 21
    R = rng.normal(size=(k, x.size))
    hyper = (np.full(k, 0.3), rng.uniform(0, 3, k), rng.uniform(0.5, 300, k))
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = gp.log_likelihood_batch(x, R, *hyper, kind, None, V)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = gp.log_likelihood_batch(x, R, *hyper, kind, None, V)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one, two)
    single = [gp.log_likelihood(x, R[w], *(h[w] for h in hyper), kind, None, V) for w in range(k)]
    np.testing.assert_allclose(one, single, rtol=1e-12)


def test_quadrature_weights() -> None:
    np.testing.assert_array_equal(orthogonal.quadrature_weights(np.linspace(0.0, 9.0, 10)), np.ones(10))
    x = np.sort(np.random.default_rng(1).uniform(0.0, 10.0, 400))
    w = orthogonal.quadrature_weights(x)
    assert w.mean() == pytest.approx(1.0)
    # ∫ x² dx over the sampled range, by the weights (scaled back to the axis)
    integral = float(np.sum(w * x**2) * (x[-1] - x[0]) / x.size)
    assert integral == pytest.approx((x[-1] ** 3 - x[0] ** 3) / 3.0, rel=0.02)
    assert not orthogonal.is_even(w) and orthogonal.is_even(np.ones(5))


@pytest.mark.parametrize("kind", KINDS)
def test_projection_and_star_covariances_against_dense(kind) -> None:
    """S = (XᵀWX)⁻¹ Xᵀ W K W X (XᵀWX)⁻¹ and Var(θ*) = (Xᵀ Σ⊥⁻¹ X)⁻¹, the latter σ0² (XᵀX)⁻¹ on an
    even grid (the orthogonal discrepancy has no variance along X)."""
    x = irregular_axis() + 5.0
    X = _columns(x)
    cols = orthogonal.make_columns(["a", "b", "c"], np.array([False, False, True]), X, x)
    w = cols.weights
    K = gp.covariance(x, 1.3, 9.0, kind)
    Binv = np.linalg.inv(X.T @ (w[:, None] * X))
    S_ref = Binv @ X.T @ (w[:, None] * K * w[None, :]) @ X @ Binv
    S = orthogonal.projection_covariance(cols, 1.3, orthogonal.mtilde(cols, x, 9.0, kind))
    np.testing.assert_allclose(S, S_ref, rtol=1e-10, atol=1e-12 * np.abs(S_ref).max())
    Sigma = gp.orthogonal_covariance(x, 1.3, 9.0, kind, cols.V, 0.3)
    star_ref = np.linalg.inv(X.T @ np.linalg.solve(Sigma, X))
    np.testing.assert_allclose(orthogonal.star_covariance(cols, x, 0.3, 1.3, 9.0, kind), star_ref,
                               rtol=1e-8, atol=1e-10 * np.abs(star_ref).max())
    xe = np.linspace(0.0, 100.0, 300)
    Xe = _columns(xe)
    even = orthogonal.make_columns(["a", "b", "c"], np.zeros(3, bool), Xe, xe)
    Sigma = gp.orthogonal_covariance(xe, 1.0, 10.0, kind, even.V, 0.3)
    ref = 0.09 * np.linalg.inv(Xe.T @ Xe)
    np.testing.assert_allclose(np.linalg.inv(Xe.T @ np.linalg.solve(Sigma, Xe)), ref, rtol=1e-8,
                               atol=1e-10 * np.abs(ref).max())
    np.testing.assert_allclose(orthogonal.star_covariance(even, xe, 0.3, 1.0, 10.0, kind), ref,
                               rtol=1e-12, atol=1e-14 * np.abs(ref).max())


@pytest.mark.parametrize("kind", KINDS)
def test_mtilde_table_reproduces_the_exact_values(kind) -> None:
    x = irregular_axis()
    cols = orthogonal.make_columns(["a", "b", "c"], np.zeros(3, bool), _columns(x), x)
    table = orthogonal.MtildeTable(cols, x, kind, None, 2.0, 200.0)
    lengths = np.array([2.0, 3.3, 17.0, 150.0, 200.0, 900.0])      # the last one outside: exact
    exact = np.array([orthogonal.mtilde(cols, x, v, kind) for v in lengths])
    np.testing.assert_allclose(table(lengths), exact, rtol=0, atol=1e-8 * np.abs(exact).max())


def test_offsets_have_the_projection_covariance_and_respect_the_prior_box() -> None:
    rng = np.random.default_rng(2)
    S = np.array([[4.0, 1.0], [1.0, 0.5]])
    u = np.zeros((20000, 2))
    c, tries = orthogonal.draw_offsets(np.broadcast_to(S, (20000, 2, 2)).copy(), u,
                                       np.full(2, -np.inf), np.full(2, np.inf), rng)
    assert np.all(tries == 1)
    np.testing.assert_allclose(np.cov(c, rowvar=False), S, rtol=0.05, atol=0.02)
    # a box: θ_true = u* - c ≥ 0 in the first coordinate, so c ≤ 0 there
    c, tries = orthogonal.draw_offsets(np.broadcast_to(S, (5000, 2, 2)).copy(), u[:5000],
                                       np.array([0.0, -np.inf]), np.full(2, np.inf), rng)
    assert np.all(c[:, 0] <= 0) and 0.3 < np.mean(tries > 1) < 0.7


def test_the_sandwich_adjustment_gives_the_target_covariance_and_counts_the_bounds() -> None:
    rng = np.random.default_rng(8)
    model = np.array([[1.0, 0.3], [0.3, 0.5]])
    target = np.array([[4.0, -0.2], [-0.2, 0.8]])
    u = rng.multivariate_normal([2.0, 0.5], model, size=40000)
    draws = np.column_stack([u[:, 0], np.exp(u[:, 1]), rng.normal(size=u.shape[0])])  # 2nd: a time constant
    bounds = {"E": (-np.inf, np.inf), "tau_max": (0.0, np.inf)}
    out, info = orthogonal.adjust_draws(draws, ["E", "tau_max", "disc_length"], ["E", "tau_max"],
                                        np.array([False, True]), model, target, bounds)
    adj = np.column_stack([out[:, 0], np.log(out[:, 1])])
    np.testing.assert_allclose(np.cov(adj, rowvar=False), target, rtol=0.04, atol=0.02)
    np.testing.assert_allclose(adj.mean(axis=0), u.mean(axis=0), atol=1e-9)
    np.testing.assert_array_equal(out[:, 2], draws[:, 2])                 # other columns untouched
    assert info["sd_factor"]["E"] == pytest.approx(2.0)
    assert info["draws_on_a_prior_bound"] == {"E": 0.0, "tau_max": 0.0}
    bounds["E"] = (0.0, np.inf)                                          # E ≥ 0: some draws stopped
    out, info = orthogonal.adjust_draws(draws, ["E", "tau_max", "disc_length"], ["E", "tau_max"],
                                        np.array([False, True]), model, target, bounds)
    assert out[:, 0].min() == 0.0 and 0.1 < info["draws_on_a_prior_bound"]["E"] < 0.2


def test_a_parameter_the_estimate_does_not_identify_keeps_its_sampled_draws() -> None:
    """sigma_s of a stress shift the test never reaches: its target sd in ln sigma_s (30) exceeds
    its prior box's (ln 1e4 / sqrt 12 = 2.7); scaled by it, the draws piled on both edges."""
    rng = np.random.default_rng(9)
    model = np.array([[1.0, 0.0], [0.0, 0.5]])
    target = np.array([[4.0, 0.0], [0.0, 900.0]])
    u = rng.multivariate_normal([2.0, np.log(30.0)], model, size=20000)
    draws = np.column_stack([u[:, 0], np.exp(u[:, 1])])
    bounds = {"E": (-np.inf, np.inf), "sigma_s": (0.1, 1000.0)}
    out, info = orthogonal.adjust_draws(draws, ["E", "sigma_s"], ["E", "sigma_s"],
                                        np.array([False, True]), model, target, bounds)
    np.testing.assert_array_equal(out[:, 1], draws[:, 1])
    assert info["not_identified"] == ["sigma_s"] and info["draws_on_a_prior_bound"]["sigma_s"] == 0.0
    assert np.std(out[:, 0]) == pytest.approx(2.0, rel=0.03)          # E adjusted as before
    # the same target within the box's sd: adjusted, and then piled at both edges
    identified = np.array([[4.0, 0.0], [0.0, 4.0]])
    out, info = orthogonal.adjust_draws(draws, ["E", "sigma_s"], ["E", "sigma_s"],
                                        np.array([False, True]), model, identified, bounds)
    assert info["not_identified"] == [] and np.std(np.log(out[:, 1])) > 1.5
