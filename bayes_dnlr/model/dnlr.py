"""The reduced DNLR model of a tensile (then relaxation) test, driven by a measured strain history.

``DNLR(time, strain)`` precomputes what does not depend on the parameters; ``basis`` gives the
stress responses to unit E, G and σ_inf for given time constants (the model is linear in those),
``stress`` and ``stress_batch`` give the true stress (eq. 18; relaxation phase of section 4.1).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.model import kernel
from bayes_dnlr.model.spectrum import tau_scale, weights

LINEAR_PARAMETERS = ("E", "G", "sigma_inf")


def haward_thackray(strain: np.ndarray) -> np.ndarray:
    """ε_HT = λ² - 1/λ = exp(2ε) - exp(-ε), λ = exp(ε) (eq. 7-8)."""
    strain = np.asarray(strain, dtype=float)
    return np.exp(2.0 * strain) - np.exp(-strain)


@dataclass(frozen=True)
class Basis:
    """Unit responses: stress = E·values[:, 0] + G·values[:, 1] + sigma_inf·values[:, 2].

    grad_tau_max / grad_tau_max_R hold d(values)/d ln(tau_max) and d/d ln(tau_max_R) when asked.
    """

    values: np.ndarray
    grad_tau_max: np.ndarray | None = None
    grad_tau_max_R: np.ndarray | None = None


def _as_grid(time: np.ndarray, strain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.ascontiguousarray(time, dtype=float)
    e = np.ascontiguousarray(strain, dtype=float)
    if t.ndim != 1 or e.ndim != 1:
        raise ValueError(f"time and strain must be 1-D arrays, got shapes {t.shape} and {e.shape}")
    if t.shape != e.shape:
        raise ValueError(f"time and strain differ in length: {t.size} and {e.size}")
    if t.size < 2:
        raise ValueError("need at least two samples")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(e))):
        raise ValueError("time and strain must be finite (no NaN or inf)")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"time must increase strictly: t[{i}] = {t[i]} then t[{i + 1}] = {t[i + 1]}")
    return t, e


class DNLR:
    """The DNLR model on one strain history (time and strain in s and Hencky strain).

    relaxation_start: a time in s; every step that ends after it follows the relaxation law.
    """

    def __init__(self, time: np.ndarray, strain: np.ndarray, modes: int = 50,
                 decades: float = 6.0, relaxation_start: float | None = None) -> None:
        self.time, self.strain = _as_grid(time, strain)
        self.modes = int(modes)
        self.decades = float(decades)
        if self.modes < 1:
            raise ValueError(f"modes must be >= 1, got {modes}")
        if not self.decades > 0:
            raise ValueError(f"decades must be > 0, got {decades}")
        self.relaxation_start = None if relaxation_start is None else float(relaxation_start)
        self.h = haward_thackray(self.strain)
        self.dt = np.diff(self.time)
        self.p = weights(self.modes, self.decades)
        self.shape = tau_scale(self.modes, self.decades)
        if self.relaxation_start is None:
            self.n_tensile = self.dt.size
        else:
            # a step i (t_i -> t_{i+1}) is a relaxation step when it ends after the switch
            self.n_tensile = int(np.searchsorted(self.time[1:], self.relaxation_start, "right"))
        self._phase_t = np.unique(self.dt[: self.n_tensile], return_inverse=True)
        self._phase_r = np.unique(self.dt[self.n_tensile:], return_inverse=True)

    @property
    def has_relaxation(self) -> bool:
        return self.n_tensile < self.dt.size

    @property
    def n_points(self) -> int:
        return self.time.size

    def _phase(self, tau_max: float, steps: tuple[np.ndarray, np.ndarray]):
        dtu, row = steps
        tau = tau_max * self.shape
        if dtu.size == 0:
            return tau, 0, np.ones(1), np.zeros(1, dtype=np.int64), np.ones((1, 1))
        # modes with dt/tau > X_RELAXED in every step: quasi-static, handled in O(1) per step
        j0 = int(np.searchsorted(tau, dtu[0] / kernel.X_RELAXED, "left"))
        x = np.multiply.outer(dtu, -1.0 / tau[j0:])
        np.maximum(x, -kernel.X_RELAXED, out=x)
        np.exp(x, out=x)
        return tau, j0, dtu, row.astype(np.int64, copy=False), x

    def basis(self, tau_max: float, tau_max_R: float | None = None, grad: bool = False) -> Basis:
        """Unit responses to E, G and σ_inf for these time constants (and their derivatives)."""
        if not (np.isfinite(tau_max) and tau_max > 0):
            raise ValueError(f"tau_max must be a positive number, got {tau_max}")
        if self.has_relaxation:
            if tau_max_R is None or not (np.isfinite(tau_max_R) and tau_max_R > 0):
                raise ValueError(f"tau_max_R must be a positive number, got {tau_max_R}")
        else:
            tau_max_R = tau_max
        q = self.n_points
        out = np.empty((q, 3))
        gt = np.empty((q, 3)) if grad else np.empty((1, 3))
        gr = np.empty((q, 3)) if grad else np.empty((1, 3))
        tt, j0t, dtut, rowt, dect = self._phase(float(tau_max), self._phase_t)
        tr, j0r, dtur, rowr, decr = self._phase(float(tau_max_R), self._phase_r)
        kernel.integrate(self.dt, self.strain, self.h, self.n_tensile, self.p,
                         tt, j0t, dtut, rowt, dect, tr, j0r, dtur, rowr, decr,
                         grad, out, gt, gr)
        if not grad:
            return Basis(out)
        return Basis(out, gt, gr if self.has_relaxation else None)

    def parameter_names(self) -> list[str]:
        names = ["E", "G", "tau_max"]
        return names + (["sigma_inf", "tau_max_R"] if self.has_relaxation else [])

    def _check_params(self, params: Mapping[str, float]) -> None:
        missing = [k for k in self.parameter_names() if k not in params]
        if missing:
            raise ValueError(f"missing parameter(s) {missing}; the model needs "
                             f"{self.parameter_names()}")

    def stress(self, params: Mapping[str, float]) -> np.ndarray:
        """True stress (MPa) at every sample for a parameter mapping."""
        self._check_params(params)
        b = self.basis(params["tau_max"], params.get("tau_max_R")).values
        s = params["E"] * b[:, 0] + params["G"] * b[:, 1]
        if self.has_relaxation:
            s = s + params["sigma_inf"] * b[:, 2]
        return s

    def stress_batch(self, theta: np.ndarray, names: Sequence[str]) -> np.ndarray:
        """Stress for many parameter sets: theta (k, p) in the order ``names`` -> (k, q)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        names = list(names)
        if theta.shape[1] != len(names):
            raise ValueError(f"theta has {theta.shape[1]} columns for {len(names)} names")
        self._check_params(dict.fromkeys(names, 0.0))
        col = {k: names.index(k) for k in names}
        out = np.empty((theta.shape[0], self.n_points))
        for k, row in enumerate(theta):
            tau_r = row[col["tau_max_R"]] if self.has_relaxation else None
            b = self.basis(row[col["tau_max"]], tau_r).values
            s = row[col["E"]] * b[:, 0] + row[col["G"]] * b[:, 1]
            if self.has_relaxation:
                s += row[col["sigma_inf"]] * b[:, 2]
            out[k] = s
        return out


def simulate(time: np.ndarray, strain: np.ndarray, params: Mapping[str, float],
             modes: int = 50, decades: float = 6.0,
             relaxation_start: float | None = None) -> np.ndarray:
    """True stress (MPa) of the DNLR model driven by ``strain`` (Hencky) on the grid ``time`` (s).

    params: E, G, tau_max; with ``relaxation_start`` (s) also sigma_inf and tau_max_R.
    The strain is used exactly as given (linear between samples); no smoothing happens here.
    """
    return DNLR(time, strain, modes, decades, relaxation_start).stress(params)
