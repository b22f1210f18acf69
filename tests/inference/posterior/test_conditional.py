"""The model parameters' conditional given the discrepancy's hyperparameters: on its grid it is the
generalized least-squares mean and covariance of the linearized model, computed here densely."""

from __future__ import annotations

import numpy as np
import pytest
from support.likelihood import discrepancy_config, discrepancy_priors, white_config
from support.sampling import TRUTH, make_test

from bayes_dnlr.inference.discrepancy.gp import covariance
from bayes_dnlr.inference.posterior.density import build_log_posterior


@pytest.mark.parametrize("kernel", ["exp", "matern32"])
def test_grid_nodes_are_the_dense_gls_conditional(kernel: str) -> None:
    test = make_test(n=400, error=(kernel, 0.5, 20.0), seed=3)
    post = build_log_posterior(discrepancy_config(kernel, "time"), test, sigma0=0.3,
                               discrepancy_priors=discrepancy_priors(1e3))
    assert post.names == ["E", "G", "tau_max", "disc_amplitude", "disc_length"]
    center = post.priors.from_physical(np.array([TRUTH["E"], TRUTH["G"], TRUTH["tau_max"], 0.5, 20.0]))
    m = post.conditional_map(center)
    assert m.model == [0, 1, 2] and m.hyper == [3, 4]
    like = next(iter(post.likelihoods.values()))
    i, j = 5, 7
    h = np.array([[m.axes[0][i], m.axes[1][j]]])
    a, length = np.exp(h[0])
    # dense: J by central differences in sampling coordinates, K = k(t, t) + σ0² I
    step = 1e-5 * np.abs(center[:3])
    base = like.predict(post.priors.to_physical(center)[None])[0]
    cols = []
    for k in range(3):
        up, dn = center.copy(), center.copy()
        up[k] += step[k]
        dn[k] -= step[k]
        cols.append((like.predict(post.priors.to_physical(np.stack([up, dn])))[0]
                     - like.predict(post.priors.to_physical(np.stack([up, dn])))[1]) / (2 * step[k]))
    jac = np.column_stack(cols)
    K = covariance(test.time, a, length, kernel, sigma0=0.3)
    kinv_j = np.linalg.solve(K, jac)
    C = np.linalg.inv(jac.T @ kinv_j)
    mu = center[:3] + C @ (kinv_j.T @ (like.y - base))
    got_mu, got_a, _ = m._at(h)
    sd = np.sqrt(np.diag(C))
    assert np.allclose(got_a[0] @ got_a[0].T, C, rtol=1e-3, atol=1e-3 * np.outer(sd, sd).max())
    assert np.all(np.abs(got_mu[0] - mu) < 1e-3 * sd)


def test_no_map_without_sampled_hyperparameters() -> None:
    test = make_test(n=200)
    post = build_log_posterior(white_config(), test, sigma0=0.3)
    assert post.conditional_map(post.priors.from_physical(np.array([2854.0, 2.32, 5.79]))) is None


def test_no_map_for_the_orthogonal_discrepancy() -> None:
    test = make_test(n=200, error=("exp", 0.5, 20.0))
    cfg = discrepancy_config("exp", "time")
    center = np.log([TRUTH["E"], TRUTH["G"], TRUTH["tau_max"], 0.5, 20.0])
    plain = build_log_posterior(cfg, test, sigma0=0.3, discrepancy_priors=discrepancy_priors(1e3))
    center[:2] = [TRUTH["E"], TRUTH["G"]]
    assert plain.conditional_map(center) is not None
    ortho = build_log_posterior(cfg, test, sigma0=0.3, discrepancy_priors=discrepancy_priors(1e3),
                                columns=np.ones((200, 1)))
    assert ortho.conditional_map(center) is None
