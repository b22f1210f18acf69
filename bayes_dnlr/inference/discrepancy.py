"""The model discrepancy of one test: its axis, its priors scaled to the test, and the maximum-
likelihood hyperparameters with the generalized least-squares estimate they imply.

Residual = white noise (sd σ0) + δ, δ a zero-mean Gaussian process on the time (or strain) axis
with amplitude a and correlation length ℓ (inference/gp.py; docs/model-error.md). For given
hyperparameters h = (σ0, a, ℓ) the best model parameters are the generalized least-squares (GLS)
estimate, ordinary least squares on whitened residuals W(y - f(θ)), W = L⁻¹, K = L Lᵀ. The
hyperparameters maximise the profile likelihood

    log L(h) = -½ |W(y - f(θ̂(h)))|² - ½ log det K - (n/2) log 2π,

found by Nelder-Mead over (ln τ, ln a, ln ℓ, ln σ0) with E, G, σ_inf projected out (the model is
linear in them, so θ̂ over them is a whitened linear least-squares solve), from a few starting
lengths; a GLS trust-region polish then gives θ̂ and the sensitivities at the optimum.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from bayes_dnlr.config import DiscrepancyConfig, ParameterSpec
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference import gp
from bayes_dnlr.inference.problem import LsqProblem

AMPLITUDE = "disc_amplitude"
LENGTH = "disc_length"
AMPLITUDE_FLOOR = 1e-6       # × rms: below this the amplitude counts as zero (white suffices)
DEFAULT_AMPLITUDE_SCALE = 2.0   # half-normal scale, × max(ML amplitude, rms/√n)
DEFAULT_LENGTH_STEPS = 3.0      # log-uniform low, × the median sampling step
EVIDENCE_LR = 9.21              # 2 Δ log L above the 99 % point of χ²(2): evidence of model error


@dataclass(frozen=True)
class Axis:
    """The discrepancy's axis on the compared samples: sorted values, and the order that sorts the
    window's samples (None when they are sorted already)."""

    name: str                   # time | strain
    values: np.ndarray          # sorted
    order: np.ndarray | None
    unit: str                   # s | - (strain)
    origin: float | None = None  # where δ is pinned to 0 (the test's first sample); None: stationary

    @property
    def median_step(self) -> float:
        d = np.diff(self.values)
        d = d[d > 0]
        return float(np.median(d)) if d.size else 1.0

    @property
    def span(self) -> float:
        return float(self.values[-1] - self.values[0]) if self.values.size > 1 else 1.0

    def sort(self, v: np.ndarray) -> np.ndarray:
        """Window-ordered values (n,) or (n, m), or (k, n) with ``rows=True``, in axis order."""
        return v if self.order is None else v[self.order]


def make_axis(kind: str, time: np.ndarray, strain: np.ndarray, origin: float | None = None) -> Axis:
    """The axis of the compared samples (``time`` and ``strain`` already restricted to them);
    ``origin``: the test's first sample on this axis, where δ is pinned (None: stationary δ)."""
    x = np.asarray(time if kind == "time" else strain, dtype=float)
    unit = "s" if kind == "time" else "-"
    if np.all(np.diff(x) >= 0):
        xs, order = np.ascontiguousarray(x), None
    else:
        order = np.argsort(x, kind="stable")
        xs = np.ascontiguousarray(x[order])
    if origin is not None:
        origin = min(float(origin), float(xs[0]))
    return Axis(kind, xs, order, unit, origin)


def test_axis(spec: DiscrepancyConfig, test, rows) -> Axis:
    """The discrepancy's axis on the compared samples ``rows`` of a TestData (a mask or indices
    into its first ``len`` samples), pinned at the test's first sample unless ``start: stationary``."""
    t = np.asarray(test.time)
    e = np.asarray(test.strain_input)
    n = len(rows) if isinstance(rows, np.ndarray) and rows.dtype == bool else test.model_end
    origin = None
    if spec.start == "pinned":
        origin = float(t[0] if spec.axis == "time" else e[0])
    return make_axis(spec.axis, t[:n][rows], e[:n][rows], origin)


@dataclass(frozen=True)
class Hyper:
    sigma0: float
    amplitude: float
    length: float


def search_priors(spec: DiscrepancyConfig, rms: float, axis: Axis) -> dict[str, ParameterSpec]:
    """What the maximum-likelihood search may range over: the configured priors, or, left out,
    amplitude on [0, ∞) and length log-uniform from 3 median sampling steps to the window's span."""
    amp = spec.amplitude or ParameterSpec(prior="half-normal", scale=max(rms, 1e-12))
    length = spec.length
    if length is None:
        span = axis.span
        low = min(DEFAULT_LENGTH_STEPS * axis.median_step, span / 10.0)
        length = ParameterSpec(prior="log-uniform", low=float(low), high=float(span))
    return {AMPLITUDE: amp, LENGTH: length}


def likelihood_ratio(log_likelihood: float, ssr_white: float, n: int,
                     sigma0: float | None) -> float:
    """2 (log L with the discrepancy - log L white), both at their maximum: the evidence of model
    error. The white one at the white optimum, with σ0² = SSR/n when σ0 is estimated."""
    s2 = ssr_white / n if sigma0 is None else sigma0**2
    white = -0.5 * ssr_white / s2 - 0.5 * n * math.log(2.0 * math.pi * s2)
    return 2.0 * (log_likelihood - white)


def resolved_priors(spec: DiscrepancyConfig, rms: float, axis: Axis, amplitude_ml: float,
                    evident: bool) -> dict[str, ParameterSpec]:
    """The priors (or fixed values) the posterior uses. Left out in the config, they follow the
    evidence of model error in the test (docs/model-error.md):

    - with evidence (``evident``: the likelihood ratio against the white model above EVIDENCE_LR):
      amplitude half-normal with scale 2 × max(amplitude_ml, rms/√n), length log-uniform from
      3 median sampling steps to the span of the window;
    - without: the amplitude fixed at 0, i.e. exactly the white likelihood. The data cannot tell a
      smooth discrepancy of a few hundredths of σ0 from a change of the parameters, so without
      evidence only the prior would decide how much of it to admit (measured on the shipped white
      examples: an amplitude prior of scale 2 × rms widened sd(G) 2.5×, one of 2 × rms/√n still
      1.4×).

    An amplitude or length given in the config is always used as given.
    """
    out = search_priors(spec, rms, axis)
    if spec.amplitude is None:
        if evident:
            floor = rms / math.sqrt(max(axis.values.size, 1))
            scale = DEFAULT_AMPLITUDE_SCALE * max(amplitude_ml, floor, 1e-12)
            out[AMPLITUDE] = ParameterSpec(prior="half-normal", scale=float(scale))
        else:
            out[AMPLITUDE] = ParameterSpec(value=0.0)
            if spec.length is None:
                out[LENGTH] = ParameterSpec(value=float(axis.span))
    return out


def discrepancy_priors(fit: dict[str, Any]) -> dict[str, ParameterSpec] | None:
    """The resolved priors of the discrepancy hyperparameters that fit.json records (None when the
    fit had no discrepancy)."""
    block = fit.get("discrepancy")
    if not block:
        return None
    try:
        return {k: ParameterSpec.model_validate(v) for k, v in block["priors"].items()}
    except (KeyError, TypeError, ValueError) as err:
        raise BayesDnlrError(f"fit.json: unreadable discrepancy priors ({err}); run `fit --force`") from None


def is_white(priors: dict[str, ParameterSpec]) -> bool:
    """True when the resolved priors fix the amplitude at 0: the likelihood is the white one."""
    amp = priors[AMPLITUDE]
    return bool(amp.fixed and amp.value == 0.0)


def whitener(axis: Axis, h: Hyper, kind: str) -> Callable[[np.ndarray], np.ndarray]:
    """v (window order, (n,) or (n, m)) -> L⁻¹ v in axis order; ``.logdet`` holds log det K."""

    def w(v: np.ndarray) -> np.ndarray:
        out, w.logdet = gp.whiten(axis.values, axis.sort(v), h.sigma0, h.amplitude, h.length, kind,
                                  axis.origin)
        return out

    w.logdet = float("nan")
    return w


@dataclass
class MaximumLikelihood:
    """The ML hyperparameters and what came with them."""

    hyper: Hyper
    beta: np.ndarray                 # the model parameters at the optimum (free, problem order)
    log_likelihood: float
    free: list[str]                  # the hyperparameters that were estimated (sigma0, ...)
    covariance_log: np.ndarray       # of ln(free hyperparameters), from the curvature (for starts)
    evaluations: int
    message: str


def _bounds(spec: ParameterSpec, floor: float, cap: float) -> tuple[float, float]:
    lo, hi = spec.bounds()
    return math.log(max(lo, floor)), math.log(min(hi, cap))


def maximum_likelihood(problem: LsqProblem, beta0: np.ndarray, axis: Axis, kind: str,
                       priors: dict[str, ParameterSpec], sigma0: float | None,
                       residuals: np.ndarray) -> MaximumLikelihood:
    """Maximise the profile likelihood over the time constants and the free hyperparameters.

    ``sigma0``: fixed white-noise sd, or None to estimate it; ``residuals``: those of the white fit
    (for starting values); ``beta0``: the white estimate (time constants start there).
    """
    rms = float(np.sqrt(np.mean(residuals**2)))
    scale = max(rms, 1e-12)
    fixed = {k: s.value for k, s in priors.items() if s.fixed}
    names = [k for k in ("sigma0", AMPLITUDE, LENGTH)
             if (k == "sigma0" and sigma0 is None) or (k != "sigma0" and k not in fixed)]
    nl = [problem.names.index(k) for k in problem.nonlinear]

    # starting values from the white residuals
    d = np.diff(axis.sort(residuals))
    s0_start = float(np.std(d) / math.sqrt(2.0)) if d.size else scale / 2
    s0_start = min(max(s0_start, 1e-3 * scale), scale)
    a_start = math.sqrt(max(rms**2 - s0_start**2, (0.1 * scale) ** 2))
    bounds = {"sigma0": (math.log(1e-6 * scale), math.log(10.0 * scale))}
    if AMPLITUDE in names:
        bounds[AMPLITUDE] = _bounds(priors[AMPLITUDE], AMPLITUDE_FLOOR * scale, 100.0 * scale)
        if not bounds[AMPLITUDE][0] < bounds[AMPLITUDE][1]:
            bounds[AMPLITUDE] = (bounds[AMPLITUDE][0], bounds[AMPLITUDE][0] + 1.0)
    if LENGTH in names:
        bounds[LENGTH] = _bounds(priors[LENGTH], 1e-12, math.inf)
    support = {k: (math.exp(lo), math.exp(hi)) for k, (lo, hi) in bounds.items()}
    for k in (AMPLITUDE, LENGTH):
        if k in names:
            lo, hi = priors[k].bounds()
            support[k] = (max(support[k][0], lo), min(support[k][1], hi))
    lengths = [_acf_length(axis, residuals)] if LENGTH in names else [fixed[LENGTH]]
    if LENGTH in names:
        lo, hi = bounds[LENGTH]
        lengths += [math.exp(lo + 0.25 * (hi - lo)), math.exp(lo + 0.75 * (hi - lo))]

    def hyper(v: np.ndarray) -> Hyper:
        # exp(ln bound) can land a rounding step outside the bound: clip into the support
        val = {k: float(np.clip(np.exp(x), *support[k])) for k, x in zip(names, v[len(nl):], strict=True)}
        return Hyper(sigma0=val.get("sigma0", sigma0 if sigma0 is not None else s0_start),
                     amplitude=val.get(AMPLITUDE, fixed.get(AMPLITUDE, a_start)),
                     length=val.get(LENGTH, fixed.get(LENGTH, lengths[0])))

    base = np.asarray(beta0, dtype=float).copy()
    u_base = problem.to_u(base)      # ln of the time constants, alpha as it is
    evals = 0

    def model_beta(v: np.ndarray) -> np.ndarray:
        u = u_base.copy()
        u[nl] = v[: len(nl)]
        return problem.to_beta(u)

    def objective(v: np.ndarray) -> float:
        nonlocal evals
        evals += 1
        h = hyper(v)
        beta = model_beta(v)
        problem.whiten = w = whitener(axis, h, kind)
        params = problem.project(problem.params(beta))
        rw = problem.residuals(params)
        value = 0.5 * float(rw @ rw) + 0.5 * w.logdet
        return value if math.isfinite(value) else math.inf

    from scipy.optimize import minimize  # here: `sample` reads fit.json, never optimises

    lo = np.concatenate([problem.u_lower[nl], [bounds[k][0] for k in names]])
    hi = np.concatenate([problem.u_upper[nl], [bounds[k][1] for k in names]])
    best = None
    for length0 in lengths:
        start = {"sigma0": s0_start, AMPLITUDE: a_start, LENGTH: length0}
        v0 = np.concatenate([u_base[nl], [math.log(start[k]) for k in names]])
        v0 = np.clip(v0, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
        res = minimize(objective, v0, method="Nelder-Mead", bounds=list(zip(lo, hi, strict=True)),
                       options={"xatol": 1e-5, "fatol": 1e-7, "maxfev": 400 * (len(v0) + 1),
                                "adaptive": True})
        if best is None or res.fun < best.fun:
            best = res
    h = hyper(best.x)
    beta = model_beta(best.x)
    problem.whiten = whitener(axis, h, kind)
    beta = problem.vector(problem.project(problem.params(beta)))
    cov = _log_covariance(objective, best.x, len(nl), len(names))
    problem.whiten = None
    n = axis.values.size
    return MaximumLikelihood(
        hyper=h, beta=beta, log_likelihood=-float(best.fun) - 0.5 * n * math.log(2.0 * math.pi), free=names,
        covariance_log=cov, evaluations=evals,
        message=f"Nelder-Mead from {len(lengths)} starting lengths: {best.message}")


def _acf_length(axis: Axis, residuals: np.ndarray) -> float:
    """The lag (axis units) where the residuals' autocorrelation first drops below 1/e."""
    r = axis.sort(residuals) - np.mean(residuals)
    n = r.size
    f = np.fft.rfft(r, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[:n]
    acf = acf / acf[0] if acf[0] > 0 else acf
    below = np.flatnonzero(acf < math.exp(-1.0))
    lag = int(below[0]) if below.size else n // 2
    return max(lag, 1) * axis.median_step


def _log_covariance(objective: Callable[[np.ndarray], float], v: np.ndarray, n_model: int,
                    n_hyper: int) -> np.ndarray:
    """Inverse curvature of the objective over ln(hyperparameters), the time constants held at
    their optimum: a starting spread for the sampler, not a reported uncertainty."""
    k = n_hyper
    if k == 0:
        return np.zeros((0, 0))
    step = 1e-3
    H = np.zeros((k, k))
    f0 = objective(v)
    for i in range(k):
        for j in range(i, k):
            def f(di: float, dj: float, i=i, j=j) -> float:
                u = v.copy()
                u[n_model + i] += di
                u[n_model + j] += dj
                return objective(u)
            if i == j:
                H[i, i] = (f(step, 0) - 2 * f0 + f(-step, 0)) / step**2
            else:
                H[i, j] = H[j, i] = (f(step, step) - f(step, -step) - f(-step, step)
                                     + f(-step, -step)) / (4 * step**2)
    vals, vecs = np.linalg.eigh(H)
    vals = np.where(vals > 1e-6, vals, 1.0)      # flat directions: a unit spread in ln h
    return (vecs / vals) @ vecs.T
