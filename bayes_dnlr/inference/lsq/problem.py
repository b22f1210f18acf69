"""The least-squares problem of one test: data on the window, the model, the parameter layout.

The model runs from the first sample (history matters) to ``test.model_end`` and is compared with
the observable where ``test.window`` is True (paper eq. 19-20). Optimisers work in internal
coordinates u: u = β for E, G, sigma_inf and the spectrum exponent alpha, and u = ln β for the
time constants (they span decades).

With a whitening operator W = L⁻¹ (K = L Lᵀ the covariance of the residuals: noise plus model
discrepancy, inference/discrepancy/gp.py) the criterion is the generalized one, (y - f)ᵀ K⁻¹ (y - f) =
|W(y - f)|², and everything the optimisers use (residuals, Jacobian, linear projection) is whitened.
``raw_residuals`` are always y - f.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference.lsq.bounded import bounded_lstsq
from bayes_dnlr.inference.lsq.sensitivity import derivative, log_sensitivity
from bayes_dnlr.inference.test_model import shift_of, temperature_of
from bayes_dnlr.model import DNLR, Basis
from bayes_dnlr.model.shift import NO_SHIFT, Shift
from bayes_dnlr.vocabulary import (
    LINEAR_COLUMN,
    LOG_COORDINATES,
    NONLINEAR,
    PARAMETER_NAMES,
    TIME_CONSTANTS,
    UNIVERSAL_EXPONENT,
)


class LogCoordinates:
    """The optimiser's coordinates u of a problem's free parameters: ln of the time constants
    (``is_log``), the others as they are."""

    is_log: np.ndarray

    def to_u(self, beta: Sequence[float]) -> np.ndarray:
        beta = np.asarray(beta, dtype=float)
        return np.where(self.is_log, np.log(np.where(self.is_log, beta, 1.0)), beta)

    def to_beta(self, u: Sequence[float]) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        return np.where(self.is_log, np.exp(np.where(self.is_log, u, 0.0)), u)


class LsqProblem(LogCoordinates):
    """Residuals y^m - y(β) on the window (eq. 19), the criterion (eq. 20) and its Jacobian (eq. 22).

    With a shift factor (``shift``; model/shift.py) the model is not linear in E, G and
    sigma_inf: no variable projection (every free parameter is nonlinear) and the Jacobian by the
    model's central differences (``DNLR.jacobian``), sigma_s in log coordinates.
    """

    def __init__(self, time: np.ndarray, strain_input: np.ndarray, stress: np.ndarray,
                 window: np.ndarray, relaxation_start: float | None, names: Sequence[str],
                 fixed: Mapping[str, float], bounds: Mapping[str, tuple[float, float]],
                 modes: int = 50, decades: float = 6.0, shift: Shift = NO_SHIFT,
                 temperature: float | np.ndarray | None = None) -> None:
        window = np.asarray(window, dtype=bool)
        if not window.any():
            raise BayesDnlrError("the identification window holds no sample (check data.window)")
        end = int(np.flatnonzero(window)[-1]) + 1
        if temperature is not None and np.ndim(temperature) > 0:
            temperature = np.asarray(temperature)[:end]
        self.model = DNLR(np.asarray(time)[:end], np.asarray(strain_input)[:end], modes, decades,
                          relaxation_start, shift, temperature)
        self.mask = window[:end]
        self.y = np.asarray(stress, dtype=float)[:end][self.mask]
        self.names = list(names)
        self.fixed = {k: float(v) for k, v in fixed.items()}
        self.all_names = [k for k in PARAMETER_NAMES
                          if k in self.names or k in self.fixed]
        relax = [k for k in self.names if k in ("sigma_inf", "tau_max_R")]
        if relax and not self.model.has_relaxation:
            raise BayesDnlrError(
                f"parameters {relax} act only in the relaxation phase, which starts after the "
                "identification window ends: widen data.window past the hold's start, or leave them "
                "out of the run by fixing them (parameters.<name>: {value: <any value in its prior>}: "
                "no sample of the window depends on it)")
        self.shifted = self.model.is_shifted
        if self.shifted:
            self.linear: list[str] = []
            self.nonlinear = list(self.names)
            self.is_log = np.array([k in LOG_COORDINATES for k in self.names])
        else:
            self.linear = [k for k in self.names if k in LINEAR_COLUMN]
            self.nonlinear = [k for k in self.names if k in NONLINEAR]
            self.is_log = np.array([k in TIME_CONSTANTS for k in self.names])
        lo = np.array([bounds[k][0] for k in self.names], dtype=float)
        hi = np.array([bounds[k][1] for k in self.names], dtype=float)
        self.lower, self.upper = lo, hi
        with np.errstate(divide="ignore"):
            self.u_lower = np.where(self.is_log, np.log(np.maximum(lo, 0.0)), lo)
            self.u_upper = np.where(self.is_log, np.log(hi), hi)
        self._cache: tuple[tuple[float, float | None, float], Basis] | None = None
        self._stress_cache: tuple[tuple[float, ...], np.ndarray] | None = None
        self.evaluations = 0
        self.whiten: Callable[[np.ndarray], np.ndarray] | None = None   # W = L⁻¹, or None (white)

    @classmethod
    def for_config(cls, cfg: Config, test: Any) -> LsqProblem:
        """The problem of one test (a TestData) with the free parameters, fixed values and prior
        bounds of ``cfg`` (a one-test view)."""
        names = cfg.free_parameters
        return cls(test.time, test.strain_input, test.stress, test.window, test.relaxation_start,
                   names, cfg.fixed_values, {k: cfg.parameters[k].bounds() for k in names},
                   cfg.model.modes, cfg.model.decades, shift_of(cfg), temperature_of(cfg, test))

    # ---- layout
    @property
    def n_points(self) -> int:
        return int(self.y.size)

    @property
    def n_free(self) -> int:
        return len(self.names)

    def params(self, beta: Sequence[float]) -> dict[str, float]:
        """All parameters (fixed and free) as a dict, canonical order."""
        free = dict(zip(self.names, (float(b) for b in beta), strict=True))
        return {k: free[k] if k in free else self.fixed[k] for k in self.all_names}

    def vector(self, params: Mapping[str, float]) -> np.ndarray:
        return np.array([params[k] for k in self.names], dtype=float)

    # ---- model
    def basis(self, params: Mapping[str, float]) -> Basis:
        """Basis with derivatives at these time constants and spectrum exponent (memoised for the
        last call)."""
        key = (float(params["tau_max"]),
               float(params["tau_max_R"]) if "tau_max_R" in params else None,
               float(params.get("alpha", UNIVERSAL_EXPONENT)))
        if self._cache is None or self._cache[0] != key:
            tau_r = key[1] if self.model.has_relaxation else None
            self._cache = (key, self.model.basis(key[0], tau_r, grad=True, alpha=key[2]))
            self.evaluations += 1
        return self._cache[1]

    def predict(self, params: Mapping[str, float]) -> np.ndarray:
        """Model stress on the window."""
        if self.shifted:
            key = tuple(float(params[k]) for k in self.all_names)
            if self._stress_cache is None or self._stress_cache[0] != key:
                self._stress_cache = (key, self.model.stress(params)[self.mask])
                self.evaluations += 1
            return self._stress_cache[1]
        v = self.basis(params).values[self.mask]
        y = params["E"] * v[:, 0] + params["G"] * v[:, 1]
        if "sigma_inf" in params:
            y = y + params["sigma_inf"] * v[:, 2]
        return y

    def raw_residuals(self, params: Mapping[str, float]) -> np.ndarray:
        """e = y^m - y(β) on the window (eq. 19)."""
        return self.y - self.predict(params)

    def _w(self, v: np.ndarray) -> np.ndarray:
        return v if self.whiten is None else self.whiten(v)

    def residuals(self, params: Mapping[str, float]) -> np.ndarray:
        """The residuals the criterion sums: e (eq. 19), or W e with a whitening operator."""
        return self._w(self.raw_residuals(params))

    def ssr(self, params: Mapping[str, float]) -> float:
        """The least-squares criterion (eq. 20)."""
        r = self.residuals(params)
        return float(r @ r)

    def jacobian_u(self, params: Mapping[str, float]) -> np.ndarray:
        """∂y/∂u on the window: X for E, G, sigma_inf and alpha, τ ∂y/∂τ for the time constants."""
        if self.shifted:
            self.evaluations += 2 * len(self.names)
            return self._w(self.model.jacobian(params, self.names)[self.mask])
        b = self.basis(params)
        cols = []
        for k in self.names:
            if k in TIME_CONSTANTS:
                cols.append(log_sensitivity(b, params, k)[self.mask])
            else:
                cols.append(derivative(b, params, k)[self.mask])
        return self._w(np.column_stack(cols))

    def jacobian(self, params: Mapping[str, float]) -> np.ndarray:
        """X = ∂y/∂β on the window (eq. 22), columns in the order of ``names``."""
        J = self.jacobian_u(params)
        beta = self.vector(params)
        return np.where(self.is_log[None, :], J / np.where(self.is_log, beta, 1.0)[None, :], J)

    def column(self, params: Mapping[str, float], name: str) -> np.ndarray:
        """∂y/∂β of one parameter on the window (not whitened), free or not (the spectrum
        exponent's, for its dependence and score test)."""
        if self.shifted:
            if name == "alpha" and name not in params:
                params = {**params, name: UNIVERSAL_EXPONENT}     # eq. 12's ½ unless given
            c = self.model.jacobian(params, [name])[self.mask, 0]
            return c / params[name] if name in LOG_COORDINATES else c
        return derivative(self.basis(params), params, name)[self.mask]

    # ---- variable projection
    def linear_system(self, params: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """(A, b): the stress is A @ (free E, G, sigma_inf in ``linear`` order) + (fixed part), and
        b = y minus the fixed linear part; both whitened when a whitening operator is set."""
        v = self.basis(params).values[self.mask]
        target = self.y.copy()
        for k in LINEAR_COLUMN:
            if k in self.fixed and k in params:
                target -= self.fixed[k] * v[:, LINEAR_COLUMN[k]]
        A = np.column_stack([v[:, LINEAR_COLUMN[k]] for k in self.linear])
        if self.whiten is not None:
            w = self.whiten(np.column_stack([A, target]))
            A, target = w[:, :-1], w[:, -1]
        return A, target

    def project(self, params: Mapping[str, float]) -> dict[str, float]:
        """Best E, G, sigma_inf (those free) for the time constants in ``params``, by linear least
        squares within their bounds: the model is linear in them (variable projection)."""
        if not self.linear:
            return dict(params)
        A, target = self.linear_system(params)
        idx = [self.names.index(k) for k in self.linear]
        c = bounded_lstsq(A, target, self.lower[idx], self.upper[idx])
        out = dict(params)
        out.update(zip(self.linear, (float(x) for x in c), strict=True))
        return out
