"""The least-squares problem of a run with several tests: the tests' problems stacked.

The run's criterion is the sum of the tests' criteria, each weighted by its noise (1/σ0², or
whitened by its discrepancy covariance K): Σ_t |W_t (y_t - f_t(θ_t))|², with θ_t the test's own
parameters taken from the run's vector by the ``Layout``. A run with one test is its test's own
``LsqProblem``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np

from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.lsq.bounded import bounded_lstsq
from bayes_dnlr.inference.lsq.problem import LogCoordinates, LsqProblem
from bayes_dnlr.vocabulary import (
    LINEAR_COLUMN,
    LOG_COORDINATES,
    NONLINEAR,
    TIME_CONSTANTS,
    base_name,
)


class RunProblem(LogCoordinates):
    """The least-squares problem of several tests, with the interface of ``LsqProblem``
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
        if any(b.shifted for b in self.blocks.values()):
            # the shifted model (LsqProblem): no variable projection, sigma_s in log coordinates
            self.linear: list[str] = []
            self.nonlinear = list(self.names)
            self.is_log = np.array([base_name(k) in LOG_COORDINATES for k in self.names])
        else:
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

    def linear_system(self, params: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """(A, b) of the stacked tests, weighted as their residuals: the stress is A @ (the free E,
        G, sigma_inf in ``linear`` order) + the fixed part, b the data minus that part."""
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
        return np.vstack(A_rows), np.concatenate(b_rows)

    def project(self, params: Mapping[str, float]) -> dict[str, float]:
        """All free E, G, sigma_inf (shared or per test) by one bounded linear least squares over
        the stacked tests, for the time constants in ``params`` (variable projection)."""
        if not self.linear:
            return dict(params)
        A, b = self.linear_system(params)
        idx = [self.names.index(k) for k in self.linear]
        c = bounded_lstsq(A, b, self.lower[idx], self.upper[idx])
        out = dict(params)
        out.update(zip(self.linear, (float(x) for x in c), strict=True))
        return out
