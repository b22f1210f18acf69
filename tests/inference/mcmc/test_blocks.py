"""The independence moves keep the target distribution, whatever they propose from (a deliberately
wrong map or linearization here): the conditional move on a correlated Gaussian and a funnel (the
spread of the model block grows with a hyperparameter), the Laplace move on a correlated Gaussian
and a skewed density, the complement move on a correlated Gaussian and a density cut by a bound,
sampled to their moments; and all stay inside emcee's contract."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.mcmc.blocks import ComplementMove, ConditionalMove, LaplaceMove
from bayes_dnlr.inference.mcmc.emcee_import import load_emcee
from bayes_dnlr.inference.mcmc.ensemble import complement_fits, make_moves
from bayes_dnlr.inference.mcmc.stopping import _tau
from bayes_dnlr.inference.posterior.conditional import ConditionalMap


def _wrong_map() -> ConditionalMap:
    """A map of the model block (0, 1) on the hyperparameters (2, 3) that is not the target's
    conditional: a shifted mean, a scale that grows with h1, a shear."""
    axes = [np.linspace(-3, 3, 7), np.linspace(-3, 3, 5)]
    g1, g2 = np.meshgrid(*axes, indexing="ij")
    mu = np.stack([0.3 * g1 + 0.5, -0.2 * g2], axis=-1)
    chol = np.zeros((7, 5, 2, 2))
    chol[..., 0, 0] = np.exp(0.3 * g1)
    chol[..., 1, 1] = 0.8
    chol[..., 1, 0] = 0.2 * g2
    return ConditionalMap(axes, mu, chol, model=[0, 1], hyper=[2, 3])


def _wrong_laplace(d: int) -> tuple[np.ndarray, np.ndarray]:
    """A linearization that is not the target's: a shifted centre, a rotated, too narrow root."""
    rng = np.random.default_rng(7)
    q, _ = np.linalg.qr(rng.standard_normal((d, d)))
    return np.full(d, 0.4), q * np.linspace(0.5, 0.9, d)


def _run(log_prob, start: np.ndarray, steps: int, seed: int = 3, moves=None) -> np.ndarray:
    emcee = load_emcee()
    sampler = emcee.EnsembleSampler(start.shape[0], start.shape[1], log_prob, vectorize=True,
                                    moves=moves or make_moves("de", _wrong_map()))
    sampler._random.seed(seed)
    sampler.run_mcmc(start, steps, progress=False)
    return sampler.get_chain()


def _kept(chain: np.ndarray, burn: int = 200) -> tuple[np.ndarray, np.ndarray]:
    kept = chain[burn:]
    return kept.reshape(-1, kept.shape[-1]), kept.shape[0] * kept.shape[1] / _tau(kept)


def _gaussian_case():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((4, 4))
    cov = a @ a.T + 0.5 * np.eye(4)            # correlated within and across the two blocks
    mean = np.array([1.0, -2.0, 0.5, 1.5])
    prec = np.linalg.inv(cov)

    def log_prob(x):
        d = x - mean
        return -0.5 * np.einsum("ij,jk,ik->i", d, prec, d)

    start = mean + rng.standard_normal((32, 4)) @ np.linalg.cholesky(cov).T
    return log_prob, start, mean, cov


def _check_gaussian(chain: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> None:
    flat, ess = _kept(chain)
    sd = np.sqrt(np.diag(cov))
    assert np.all(np.abs(flat.mean(axis=0) - mean) < 4.5 * sd / np.sqrt(ess)), flat.mean(axis=0)
    assert np.all(np.abs(flat.std(axis=0) / sd - 1) < 6 / np.sqrt(2 * ess)), flat.std(axis=0) / sd
    assert np.all(np.abs(np.corrcoef(flat.T) - cov / np.outer(sd, sd)) < 0.08)


@pytest.mark.slow      # a statistical check of a long chain: 3000 steps of 32 walkers, 4 s of CPU
def test_the_conditional_move_keeps_a_correlated_gaussian() -> None:
    log_prob, start, mean, cov = _gaussian_case()
    _check_gaussian(_run(log_prob, start, 3000), mean, cov)


@pytest.mark.slow      # a statistical check of a long chain: 3000 steps of 32 walkers, 3 s of CPU
def test_the_laplace_move_keeps_a_correlated_gaussian() -> None:
    log_prob, start, mean, cov = _gaussian_case()
    _check_gaussian(_run(log_prob, start, 3000, moves=make_moves("de", laplace=_wrong_laplace(4))),
                    mean, cov)


@pytest.mark.slow      # a statistical check of a long chain: 4000 steps of 32 walkers, 4 s of CPU
def test_the_laplace_move_keeps_a_skewed_density() -> None:
    """x = ln y, y ~ Gamma(2, 1) (a skewed density, heavier on the left than a Gaussian), and
    z | x ~ N(x, 0.3²): E x = ψ(2) = 1 - γ, Var x = ψ'(2) = π²/6 - 1; E z = E x, Var z = Var x +
    0.09. The linearization proposes a Gaussian that is neither centred nor shaped like it."""
    def log_prob(p):
        x, z = p[:, 0], p[:, 1]
        return 2.0 * x - np.exp(x) - 0.5 * ((z - x) / 0.3) ** 2

    rng = np.random.default_rng(3)
    x = np.log(rng.gamma(2.0, size=32))
    start = np.column_stack([x, x + 0.3 * rng.standard_normal(32)])
    moves = make_moves("de", laplace=(np.array([0.8, 0.6]), np.array([[0.6, 0.0], [0.55, 0.2]])))
    flat, ess = _kept(_run(log_prob, start, 4000, moves=moves))
    mean_x, var_x = 1.0 - np.euler_gamma, np.pi**2 / 6 - 1.0
    mean, var = np.array([mean_x, mean_x]), np.array([var_x, var_x + 0.09])
    assert np.all(np.abs(flat.mean(axis=0) - mean) < 4.5 * np.sqrt(var / ess)), flat.mean(axis=0)
    assert np.all(np.abs(flat.var(axis=0) / var - 1) < 0.12), flat.var(axis=0) / var


@pytest.mark.slow      # a statistical check of a long chain: 3000 steps of 32 walkers, 3 s of CPU
def test_the_complement_move_keeps_a_correlated_gaussian() -> None:
    log_prob, start, mean, cov = _gaussian_case()
    _check_gaussian(_run(log_prob, start, 3000, moves=make_moves("de", complement=True)), mean, cov)


@pytest.mark.slow      # a statistical check of a long chain: 4000 steps of 32 walkers, 3 s of CPU
def test_the_complement_move_keeps_a_density_cut_by_a_bound() -> None:
    """As G held at 0 by its prior: x ~ N(0, 1) cut to x > 0 (E x = √(2/π), Var x = 1 - 2/π) and
    z | x ~ N(x, 0.5²) (E z = E x, Var z = Var x + 0.25). The walkers' own Student t proposes
    across the bound half the time; those proposals are rejected, the others keep the density."""
    def log_prob(p):
        x, z = p[:, 0], p[:, 1]
        return np.where(x > 0, -0.5 * x**2 - 0.5 * ((z - x) / 0.5) ** 2, -np.inf)

    rng = np.random.default_rng(6)
    x = np.abs(rng.standard_normal(32))
    start = np.column_stack([x, x + 0.5 * rng.standard_normal(32)])
    flat, ess = _kept(_run(log_prob, start, 4000, moves=make_moves("de", complement=True)))
    mean_x, var_x = np.sqrt(2 / np.pi), 1 - 2 / np.pi
    mean, var = np.array([mean_x, mean_x]), np.array([var_x, var_x + 0.25])
    assert np.all(np.abs(flat.mean(axis=0) - mean) < 4.5 * np.sqrt(var / ess)), flat.mean(axis=0)
    assert np.all(np.abs(flat.var(axis=0) / var - 1) < 0.12), flat.var(axis=0) / var


@pytest.mark.slow      # a statistical check of a long chain: 4000 steps of 32 walkers, 6 s of CPU
def test_the_conditional_move_keeps_a_funnel() -> None:
    """h = (h1, h2) ~ N(0, I); the model block θ | h ~ N(0, exp(h1) I): E θ = 0,
    Var θ = E exp(h1) = exp(1/2)."""
    def log_prob(x):
        h1 = x[:, 2]
        return (-0.5 * np.sum(x[:, 2:] ** 2, axis=1) - 0.5 * np.sum(x[:, :2] ** 2, axis=1)
                * np.exp(-h1) - h1)

    rng = np.random.default_rng(1)
    h = rng.standard_normal((32, 2))
    start = np.column_stack([np.exp(h[:, :1] / 2) * rng.standard_normal((32, 2)), h])
    flat, ess = _kept(_run(log_prob, start, 4000))
    var = np.array([np.exp(0.5), np.exp(0.5), 1.0, 1.0])
    assert np.all(np.abs(flat.mean(axis=0)) < 4.5 * np.sqrt(var / ess)), flat.mean(axis=0)
    assert np.all(np.abs(flat.var(axis=0) / var - 1) < 0.12), flat.var(axis=0) / var


def test_the_map_is_invertible_and_its_jacobian_is_the_determinant() -> None:
    m = _wrong_map()
    rng = np.random.default_rng(2)
    h = rng.uniform(-4, 4, (6, 2))             # also outside the grid: clamped
    theta = rng.standard_normal((6, 2))
    u, ld = m.standardize(h, theta)
    back, ld2 = m.place(h, u)
    assert np.allclose(back, theta) and np.allclose(ld, ld2)
    h_new = rng.uniform(-3, 3, (6, 2))
    out, log_jac = m.carry(h, h_new, theta)
    eps = 1e-6
    for k in range(6):
        jac = np.column_stack([(m.carry(h[k:k + 1], h_new[k:k + 1], theta[k:k + 1] + eps * e)[0][0]
                                - out[k]) / eps for e in np.eye(2)])
        assert np.isclose(np.log(abs(np.linalg.det(jac))), log_jac[k], atol=1e-5)


def test_one_interpolation_for_both_ends_of_the_move_gives_the_same_bits() -> None:
    """The move interpolates the map once over its old and new rows: the same values, bit for bit,
    as standardize and place called apart (the chain does not change)."""
    m = _wrong_map()
    rng = np.random.default_rng(5)
    h, h_new = rng.uniform(-4, 4, (16, 2)), rng.uniform(-4, 4, (16, 2))
    theta, u_new = rng.standard_normal((16, 2)), rng.standard_normal((16, 2))
    u, ld, placed, ld_new = m.standardize_and_place(h, theta, h_new, u_new)
    u_ref, ld_ref = m.standardize(h, theta)
    placed_ref, ld_new_ref = m.place(h_new, u_new)
    for got, ref in ((u, u_ref), (ld, ld_ref), (placed, placed_ref), (ld_new, ld_new_ref)):
        assert np.array_equal(got, ref)


def test_the_move_changes_both_blocks_and_rejects_what_it_cannot_place() -> None:
    rng = np.random.RandomState(4)
    s = rng.randn(16, 4)
    c = [rng.randn(16, 4)]
    q, f = ConditionalMove(_wrong_map()).get_proposal(s, c, rng)
    assert not np.any(np.isclose(q, s))
    assert np.all(np.isfinite(f))
    s[0, 0] = np.inf
    q, f = ConditionalMove(_wrong_map()).get_proposal(s, c, rng)
    assert f[0] == -np.inf and np.all(np.isfinite(f[1:]))


def test_the_laplace_moves_ratio_is_that_of_its_student_t() -> None:
    """The Metropolis-Hastings factor is ln q(s) - ln q(proposal) of the multivariate Student t
    (scipy's density), whatever the root (not triangular here)."""
    from scipy.stats import multivariate_t

    center, root = _wrong_laplace(3)
    move = LaplaceMove(center, root, dof=6.0, scale=1.3)
    rng = np.random.RandomState(8)
    s = rng.randn(16, 3)
    q, f = move.get_proposal(s, [rng.randn(16, 3)], rng)
    t = multivariate_t(loc=center, shape=1.3**2 * root @ root.T, df=6.0)
    np.testing.assert_allclose(f, t.logpdf(s) - t.logpdf(q), rtol=1e-10, atol=1e-10)
    s[2, 1] = np.nan
    q, f = move.get_proposal(s, [rng.randn(16, 3)], rng)
    assert f[2] == -np.inf and np.all(np.isfinite(np.delete(f, 2)))


def test_which_moves_de_makes() -> None:
    """The conditional move with a map, else the Laplace move with a linearization, else the
    complement move when asked, else DEMove; ``de-plain`` is DEMove whatever is given."""
    laplace = _wrong_laplace(4)
    assert type(make_moves("de")).__name__ == "DEMove"
    assert type(make_moves("de-plain", _wrong_map(), laplace, True)).__name__ == "DEMove"
    kinds = [type(m).__name__ for m, _ in make_moves("de", _wrong_map(), laplace, True)]
    assert kinds == ["DEMove", "ConditionalMove"]
    kinds = [type(m).__name__ for m, _ in make_moves("de", laplace=laplace, complement=True)]
    assert kinds == ["DEMove", "LaplaceMove"]
    kinds = [type(m).__name__ for m, _ in make_moves("de", complement=True)]
    assert kinds == ["DEMove", "ComplementMove"]


def test_the_complement_move_needs_a_half_of_2d_plus_2_walkers() -> None:
    assert complement_fits(32, 7) and not complement_fits(32, 8)
    assert complement_fits(16, 3) and not complement_fits(15, 3)


def test_the_complement_moves_ratio_is_that_of_the_other_walkers_student_t() -> None:
    """The proposal comes from the other half only (the same draws whatever the walkers moved),
    and the Metropolis-Hastings factor is ln q(s) - ln q(proposal) of the multivariate Student t
    with the other half's mean and covariance × scale² (scipy's density); a walker at a
    non-finite point is rejected."""
    from scipy.stats import multivariate_t

    move = ComplementMove(dof=5.0, scale=1.3)
    rng = np.random.RandomState(9)
    s, c = rng.randn(16, 3), [rng.randn(10, 3), rng.randn(6, 3) + 1.0]
    q, f = move.get_proposal(s, c, np.random.RandomState(1))
    q2, _ = move.get_proposal(s + 5.0, c, np.random.RandomState(1))
    assert np.array_equal(q, q2)
    comp = np.concatenate(c)
    t = multivariate_t(loc=comp.mean(axis=0), shape=1.3**2 * np.cov(comp.T), df=5.0)
    np.testing.assert_allclose(f, t.logpdf(s) - t.logpdf(q), rtol=1e-8, atol=1e-8)
    s[3, 2] = np.nan
    q, f = move.get_proposal(s, c, rng)
    assert f[3] == -np.inf and np.array_equal(q[3], s[3], equal_nan=True)
    assert np.all(np.isfinite(np.delete(f, 3)))
