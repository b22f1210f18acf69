"""The log-posterior of a run, vectorised over emcee walkers:

    log p(z | y) = log prior(z) + Σ_tests log L_t(θ_t(z)) + Σ_terms log L_r(θ(z)),

the tests independent given the parameters; θ_t is the test's own parameters in the run's vector
(inference/layout.py), log L_t its likelihood (likelihood.py). A run with one test is the case
N = 1 (the sum has one term). The other terms are observations beside the tests that share their
parameters: the references in the data (``reference_moduli`` with ``use: data``,
inference/references/terms.py), each a callable of the run's vector.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np

from bayes_dnlr.config import Config, ParameterSpec
from bayes_dnlr.data import TestData
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.posterior.likelihood import TestLikelihood, build_likelihood
from bayes_dnlr.inference.posterior.priors import PriorSet, build_priors


class LogPosterior:
    """Callable ``z (k, ndim) -> (k,)``: the log-posterior in sampling coordinates (emcee
    ``vectorize=True``) over the run's vector ``layout.names``.

    ``likelihoods``: each test's likelihood over its own names; ``priors``: the run's ``PriorSet``
    in ``layout.names`` order. Outside the prior support no model is run and the result is -inf.
    """

    def __init__(self, likelihoods: Mapping[str, TestLikelihood], layout: Layout,
                 priors: PriorSet, terms: Sequence[Callable[[np.ndarray], np.ndarray]] = ()) -> None:
        self.likelihoods = dict(likelihoods)
        self.terms = list(terms)
        self.layout = layout
        self.priors = priors
        self.names = priors.names
        if self.names != layout.names:
            raise ValueError(f"prior names {self.names} and layout names {layout.names} differ")
        self.ndim = priors.ndim
        self.n = int(sum(like.n for like in self.likelihoods.values()))
        self.n_evals = 0      # likelihood evaluations (points inside the prior support)

    def log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        """Σ_tests log L_t (k,) at physical parameters theta (k, ndim); -inf on failure."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        out = np.zeros(theta.shape[0])
        for t, like in self.likelihoods.items():
            out += like.log_likelihood(self.layout.for_test(theta, t))
        for term in self.terms:
            out += term(theta)
        return out

    def log_likelihood_reference(self, theta: np.ndarray) -> np.ndarray:
        """``log_likelihood`` through each test's reference path (walker by walker in Python)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        out = np.zeros(theta.shape[0])
        for t, like in self.likelihoods.items():
            out += like.log_likelihood_reference(self.layout.for_test(theta, t))
        for term in self.terms:
            out += term(theta)
        return out

    def conditional_map(self, center: np.ndarray):
        """The model parameters' conditional given the discrepancy's hyperparameters around
        ``center`` (sampling coordinates; inference/posterior/conditional.py), for the conditional
        move; None for several tests, other terms or without sampled hyperparameters."""
        if len(self.likelihoods) != 1 or self.terms:
            return None
        from bayes_dnlr.inference.posterior.conditional import conditional_map

        return conditional_map(next(iter(self.likelihoods.values())), self.priors, center)

    def __call__(self, z: np.ndarray) -> np.ndarray:
        z = np.atleast_2d(np.asarray(z, dtype=float))
        lp = self.priors.log_prior(z)
        ok = np.flatnonzero(np.isfinite(lp))
        if ok.size:
            lp[ok] += self.log_likelihood(self.priors.to_physical(z[ok]))
            self.n_evals += ok.size
        lp[~np.isfinite(lp)] = -np.inf
        return lp


def one_test(likelihood: TestLikelihood, priors: PriorSet) -> LogPosterior:
    """The log-posterior of a run with one test: its likelihood under plain names."""
    layout = Layout.build({"test": likelihood.names}, (), plain=True)
    return LogPosterior({"test": likelihood}, layout, priors)


def build_log_posterior(cfg: Config, test: TestData, sigma0: float | None,
                        priors: PriorSet | None = None,
                        discrepancy_priors: Mapping[str, ParameterSpec] | None = None,
                        kernel: str | None = None, columns: np.ndarray | None = None) -> LogPosterior:
    """The log-posterior of a one-test config and its data (sigma0 None when it is sampled): the
    config's priors (or ``priors``) and the test's likelihood (likelihood.build_likelihood; with
    ``columns`` the orthogonal discrepancy)."""
    priors = priors or build_priors(cfg, discrepancy_priors)
    like = build_likelihood(cfg, test, sigma0, priors.names, discrepancy_priors, kernel, columns)
    return one_test(like, priors)
