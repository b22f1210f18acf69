"""The least-squares problem of the tests with references in their data: the tests' problem
(``LsqProblem`` of one test, or the ``RunProblem`` of several; white, or whitened by the model
discrepancy's working covariance) with the references' rows below it,

    criterion = |w (y − f(θ))|² + Σ ((v − g(θ))/s)²,

w the tests' weight (1/σ0 for one test's raw residuals, 1 where the problem is weighted or whitened
already), g the references' predictions (terms.py). The interface is the tests' problem's, so the
optimisers (inference/lsq/optimize.py: trust region, Gauss-Newton, variable projection) and the
stochastic analysis (eq. 32-35, 37) run on it unchanged; the references' predictions are linear in
E and G too, so the variable projection takes their rows.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from bayes_dnlr.inference.lsq.bounded import bounded_lstsq
from bayes_dnlr.inference.lsq.problem import LogCoordinates
from bayes_dnlr.inference.references.condition import parameter_map, stacked
from bayes_dnlr.inference.references.terms import Reference, predict


class WithReferences(LogCoordinates):
    """A tests' problem (``base``) with the data references ``refs`` (module doc). ``name_of(k,
    test)`` is the run's name of a reference's parameter (``Layout.name``); ``fixed`` the values of
    the parameters that are not free."""

    def __init__(self, base, refs: Sequence[Reference], weight: float, name_of,
                 fixed: Mapping[str, float], modes: int = 50, decades: float = 6.0) -> None:
        self.base = base
        self.refs = list(refs)
        self.weight = float(weight)
        self.name_of = name_of
        self.fixed = {k: float(v) for k, v in fixed.items()}
        self.modes, self.decades = modes, decades
        self.names = list(base.names)
        self.linear, self.nonlinear = list(base.linear), list(base.nonlinear)
        self.is_log = np.asarray(base.is_log, dtype=bool)
        self.lower, self.upper = base.lower, base.upper
        self.u_lower, self.u_upper = base.u_lower, base.u_upper
        self.sd = np.concatenate([r.sd for r in self.refs])

    @property
    def n_points(self) -> int:
        return int(self.base.n_points + self.sd.size)

    @property
    def n_free(self) -> int:
        return len(self.names)

    @property
    def evaluations(self) -> int:
        return int(self.base.evaluations)

    def params(self, beta: Sequence[float]) -> dict[str, float]:
        return self.base.params(beta)

    def vector(self, params: Mapping[str, float]) -> np.ndarray:
        return self.base.vector(params)

    def _refs(self, params: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        r, X, s = stacked(self.refs, {**self.fixed, **params}, self.names, self.name_of, self.fixed,
                          self.modes, self.decades)
        return r / s, X / s[:, None]

    def residuals(self, params: Mapping[str, float]) -> np.ndarray:
        return np.concatenate([self.weight * self.base.residuals(params), self._refs(params)[0]])

    def ssr(self, params: Mapping[str, float]) -> float:
        r = self.residuals(params)
        return float(r @ r)

    def jacobian(self, params: Mapping[str, float]) -> np.ndarray:
        """X = ∂(model)/∂β over the tests' rows and the references' (eq. 22), weighted."""
        return np.vstack([self.weight * self.base.jacobian(params), self._refs(params)[1]])

    def jacobian_u(self, params: Mapping[str, float]) -> np.ndarray:
        beta = self.vector(params)
        X = self.jacobian(params)
        return np.where(self.is_log[None, :], X * np.where(self.is_log, beta, 1.0)[None, :], X)

    def linear_system(self, params: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """The tests' (A, b) and the references' rows: g = E a + G b for the time constants and
        exponent of ``params`` (a, b the predictions at unit E and G), each row over its sd."""
        A, b = self.base.linear_system(params)
        rows_a, rows_b = [self.weight * A], [self.weight * b]
        full = {**self.fixed, **params}
        for ref in self.refs:
            pmap = parameter_map(ref, self.names, self.name_of)
            local = {k: full[g] for k, g in pmap.items() if g in full}
            local.update({k: self.fixed[k] for k in pmap if k not in local and k in self.fixed})
            unit = {"E": predict(ref, {**local, "E": 1.0, "G": 0.0}, self.modes, self.decades),
                    "G": predict(ref, {**local, "E": 0.0, "G": 1.0}, self.modes, self.decades)}
            cols = np.zeros((ref.m, len(self.linear)))
            target = ref.value.copy()
            for k in ("E", "G"):
                g = pmap[k]
                if g in self.linear:
                    cols[:, self.linear.index(g)] = unit[k]
                else:
                    target = target - local.get(k, 0.0) * unit[k]
            rows_a.append(cols / ref.sd[:, None])
            rows_b.append(target / ref.sd)
        return np.vstack(rows_a), np.concatenate(rows_b)

    def project(self, params: Mapping[str, float]) -> dict[str, float]:
        """The best free E, G (and sigma_inf) for the time constants in ``params`` over the tests and
        the references together (variable projection)."""
        if not self.linear:
            return dict(params)
        A, b = self.linear_system(params)
        idx = [self.names.index(k) for k in self.linear]
        c = bounded_lstsq(A, b, self.lower[idx], self.upper[idx])
        out = dict(params)
        out.update(zip(self.linear, (float(x) for x in c), strict=True))
        return out
