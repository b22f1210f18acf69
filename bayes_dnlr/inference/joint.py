"""Several tests, one answer: the joint parameter layout, least-squares problem and log-posterior.

A run with ``tests:`` has one parameter vector for all tests. A parameter is *shared* (one value,
named ``E``) unless its config entry says ``per: test`` (one value per test, named ``tau_max[r5e-3]``);
the noise of each test (a sampled σ0, the discrepancy's amplitude and length) always belongs to
that test (``disc_amplitude[r5e-3]``). ``Layout`` maps the joint vector to each test's own
parameters; the joint least-squares criterion is the sum of the tests' criteria, each weighted by
its noise (1/σ0², or whitened by its discrepancy covariance K), and the joint log-posterior is the
prior plus the sum of the tests' log-likelihoods (the tests are independent given the parameters).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.config import PARAMETER_NAMES
from bayes_dnlr.inference.problem import LsqProblem, bounded_lstsq
from bayes_dnlr.inference.sensitivity import LINEAR_COLUMN, NONLINEAR, TIME_CONSTANTS

NOISE_NAMES = ("sigma0", "disc_amplitude", "disc_length")


def joint_name(name: str, test: str) -> str:
    return f"{name}[{test}]"


def base_name(name: str) -> str:
    """``tau_max[r5e-3]`` -> ``tau_max``."""
    return name.split("[", 1)[0]


def test_of(name: str) -> str | None:
    """``tau_max[r5e-3]`` -> ``r5e-3``; None for a shared name."""
    return name[name.index("[") + 1:-1] if "[" in name else None


@dataclass(frozen=True)
class Layout:
    """The joint vector's names, and for each test the joint column of each of its local names."""

    names: list[str]
    tests: list[str]
    local: dict[str, list[str]]          # test -> its own parameter names, its own order
    columns: dict[str, list[int]]        # test -> joint column of each local name

    @classmethod
    def build(cls, local: Mapping[str, Sequence[str]], per_test: Sequence[str]) -> Layout:
        """``local``: each test's own free (or sampled) names; ``per_test``: the model parameters
        that are one per test. Joint order: the canonical model order (shared, then each test's
        own), then each test's noise parameters."""
        tests = list(local)
        names: list[str] = []
        for k in PARAMETER_NAMES:
            users = [t for t in tests if k in local[t]]
            if not users:
                continue
            if k in per_test:
                names += [joint_name(k, t) for t in users]
            else:
                names.append(k)
        for t in tests:
            names += [joint_name(k, t) for k in NOISE_NAMES if k in local[t]]
        columns = {}
        for t in tests:
            cols = []
            for k in local[t]:
                g = joint_name(k, t) if (k in per_test or k in NOISE_NAMES) else k
                cols.append(names.index(g))
            columns[t] = cols
        return cls(names, tests, {t: list(v) for t, v in local.items()}, columns)

    def for_test(self, theta: np.ndarray, test: str) -> np.ndarray:
        """Columns of a (k, joint) array that are the test's own parameters, in its own order."""
        return theta[..., self.columns[test]]


class JointProblem:
    """The joint least-squares problem of several tests, with the interface of ``LsqProblem``
    (residuals, Jacobian, variable projection) so that the optimisers run on it unchanged.

    Each block is a test's ``LsqProblem`` over its own free names; ``weights`` (1/σ0 of each test)
    scale its residuals, or its ``whiten`` operator does (the discrepancy: weights 1 then).
    """

    def __init__(self, blocks: Mapping[str, LsqProblem], layout: Layout,
                 bounds: Mapping[str, tuple[float, float]], weights: Mapping[str, float]) -> None:
        self.blocks = dict(blocks)
        self.layout = layout
        self.names = list(layout.names)
        self.weights = {t: float(weights[t]) for t in self.blocks}
        self.linear = [k for k in self.names if base_name(k) in LINEAR_COLUMN]
        self.nonlinear = [k for k in self.names if base_name(k) in NONLINEAR]
        self.is_log = np.array([base_name(k) in TIME_CONSTANTS for k in self.names])
        self.lower = np.array([bounds[k][0] for k in self.names], dtype=float)
        self.upper = np.array([bounds[k][1] for k in self.names], dtype=float)
        with np.errstate(divide="ignore"):
            self.u_lower = np.where(self.is_log, np.log(np.maximum(self.lower, 0.0)), self.lower)
            self.u_upper = np.where(self.is_log, np.log(self.upper), self.upper)
        self.sizes = {t: b.n_points for t, b in self.blocks.items()}

    # ---- layout
    @property
    def n_points(self) -> int:
        return int(sum(self.sizes.values()))

    @property
    def n_free(self) -> int:
        return len(self.names)

    @property
    def evaluations(self) -> int:
        return int(sum(b.evaluations for b in self.blocks.values()))

    def params(self, beta: Sequence[float]) -> dict[str, float]:
        return dict(zip(self.names, (float(b) for b in beta), strict=True))

    def vector(self, params: Mapping[str, float]) -> np.ndarray:
        return np.array([params[k] for k in self.names], dtype=float)

    def to_u(self, beta: Sequence[float]) -> np.ndarray:
        beta = np.asarray(beta, dtype=float)
        return np.where(self.is_log, np.log(np.where(self.is_log, beta, 1.0)), beta)

    def to_beta(self, u: Sequence[float]) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        return np.where(self.is_log, np.exp(np.where(self.is_log, u, 0.0)), u)

    def local(self, params: Mapping[str, float], test: str) -> dict[str, float]:
        """The block's own parameter dict (its fixed values included) from joint ``params``."""
        b = self.blocks[test]
        free = [params[self.names[c]] for c in self.layout.columns[test]]
        return b.params(free)

    def set_whiteners(self, whiteners: Mapping[str, Callable | None]) -> None:
        for t, w in whiteners.items():
            self.blocks[t].whiten = w

    # ---- criterion
    def residuals(self, params: Mapping[str, float]) -> np.ndarray:
        return np.concatenate([self.weights[t] * b.residuals(self.local(params, t))
                               for t, b in self.blocks.items()])

    def raw_residuals(self, params: Mapping[str, float]) -> dict[str, np.ndarray]:
        """y - model of each test (unweighted, not whitened)."""
        return {t: b.raw_residuals(self.local(params, t)) for t, b in self.blocks.items()}

    def ssr(self, params: Mapping[str, float]) -> float:
        r = self.residuals(params)
        return float(r @ r)

    def jacobian_u(self, params: Mapping[str, float]) -> np.ndarray:
        J = np.zeros((self.n_points, self.n_free))
        row = 0
        for t, b in self.blocks.items():
            Jt = b.jacobian_u(self.local(params, t)) * self.weights[t]
            J[row:row + Jt.shape[0], self.layout.columns[t]] += Jt
            row += Jt.shape[0]
        return J

    def jacobian(self, params: Mapping[str, float]) -> np.ndarray:
        J = self.jacobian_u(params)
        beta = self.vector(params)
        return np.where(self.is_log[None, :], J / np.where(self.is_log, beta, 1.0)[None, :], J)

    def project(self, params: Mapping[str, float]) -> dict[str, float]:
        """All free E, G, sigma_inf (shared or per test) by one bounded linear least squares over
        the stacked tests, for the time constants in ``params`` (variable projection)."""
        if not self.linear:
            return dict(params)
        lin = {k: j for j, k in enumerate(self.linear)}
        A_rows, b_rows = [], []
        for t, b in self.blocks.items():
            A, target = b.linear_system(self.local(params, t))
            full = np.zeros((A.shape[0], len(self.linear)))
            for j, k in enumerate(b.linear):
                g = self.names[self.layout.columns[t][b.names.index(k)]]
                full[:, lin[g]] = A[:, j]
            A_rows.append(self.weights[t] * full)
            b_rows.append(self.weights[t] * target)
        idx = [self.names.index(k) for k in self.linear]
        c = bounded_lstsq(np.vstack(A_rows), np.concatenate(b_rows), self.lower[idx], self.upper[idx])
        out = dict(params)
        out.update(zip(self.linear, (float(x) for x in c), strict=True))
        return out


class JointPosterior:
    """log prior(z) + Σ_tests log L_test(θ_test(z)) over the joint vector; emcee ``vectorize``.

    ``posts``: each test's ``LogPosterior`` over its own names (its priors unused here; only its
    ``log_likelihood``), ``priors``: the joint ``PriorSet`` in ``layout.names`` order.
    """

    def __init__(self, posts: Mapping[str, object], layout: Layout, priors) -> None:
        self.posts = dict(posts)
        self.layout = layout
        self.priors = priors
        self.names = priors.names
        if self.names != layout.names:
            raise ValueError(f"prior names {self.names} and layout names {layout.names} differ")
        self.ndim = priors.ndim
        self.n = int(sum(p.n for p in self.posts.values()))
        self.sigma0 = None
        self.discrepancy = None
        self.n_evals = 0

    def log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        out = np.zeros(theta.shape[0])
        for t, post in self.posts.items():
            out += post.log_likelihood(self.layout.for_test(theta, t))
        return out

    def __call__(self, z: np.ndarray) -> np.ndarray:
        z = np.atleast_2d(np.asarray(z, dtype=float))
        lp = self.priors.log_prior(z)
        ok = np.flatnonzero(np.isfinite(lp))
        if ok.size:
            lp[ok] += self.log_likelihood(self.priors.to_physical(z[ok]))
            self.n_evals += ok.size
        lp[~np.isfinite(lp)] = -np.inf
        return lp


def pooled_start(estimates: Mapping[str, Mapping[str, float]], sds: Mapping[str, Mapping[str, float]],
                 layout: Layout) -> dict[str, float]:
    """A start for the joint fit from the single-test fits: a shared parameter at the
    inverse-variance mean of the tests' estimates (the geometric one for time constants), a
    per-test parameter at its test's own estimate."""
    out: dict[str, float] = {}
    for name in layout.names:
        t = test_of(name)
        k = base_name(name)
        if t is not None:
            out[name] = float(estimates[t][k])
            continue
        vals, wts = [], []
        for test in layout.tests:
            if k in estimates[test]:
                v, s = float(estimates[test][k]), float(sds[test].get(k, math.nan))
                vals.append(math.log(v) if k in TIME_CONSTANTS else v)
                rel = s / v if k in TIME_CONSTANTS and v > 0 else s
                wts.append(1.0 / rel**2 if math.isfinite(rel) and rel > 0 else 1.0)
        m = float(np.average(vals, weights=wts))
        out[name] = math.exp(m) if k in TIME_CONSTANTS else m
    return out
