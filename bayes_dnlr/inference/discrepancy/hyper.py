"""The model discrepancy of one test: its axis, its priors scaled to the test, and its
hyperparameters by a likelihood of h alone (``hyper_fit``): the restricted likelihood
(``restricted_log_likelihood``) or the orthogonal discrepancy's (inference/discrepancy/orthogonal.py), for the
analysis of inference/discrepancy/gls.py.

Residual = white noise (sd σ0) + δ, δ a zero-mean Gaussian process on the time (or strain) axis
with amplitude a and correlation length ℓ (inference/discrepancy/gp.py; docs/model-error.md). A likelihood of
h = (σ0, a, ℓ) alone keeps the hyperparameters from being confounded with θ; ``hyper_fit`` finds
its maximum (with the amplitude's prior) over ln σ0, ln a, ln ℓ by a bounded quasi-Newton descent
from the best of a few starts (the residuals' autocorrelation length, two more lengths, the other
kernel's optimum): 90-430 likelihood evaluations per test where Nelder-Mead from every start took
260-1900, the same E and sd to 1e-4 sd on the shipped examples and the real curves
(benchmarks/hyper_speed.py; tests/inference/discrepancy/test_hyper.py holds it to Nelder-Mead).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from bayes_dnlr.config import DiscrepancyConfig, ParameterSpec
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference.discrepancy import gp
from bayes_dnlr.inference.discrepancy.axis import Axis

AMPLITUDE = "disc_amplitude"
LENGTH = "disc_length"
AMPLITUDE_FLOOR = 1e-6       # × rms: below this the amplitude counts as zero (white suffices)
DEFAULT_AMPLITUDE_SCALE = 2.0   # half-normal scale, × the rms residual of the projection θ*
DEFAULT_LENGTH_STEPS = 3.0      # log-uniform low, × the median sampling step
EVIDENCE_LR = 9.21              # 2 Δ log L above the 99 % point of χ²(2): evidence of model error


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


def amplitude_prior(spec: DiscrepancyConfig, rms: float) -> ParameterSpec:
    """The amplitude's prior: the configured one, or half-normal with scale 2 × the rms residual of
    the projection θ*: a priori the discrepancy is about as large as the misfit the data show. (A
    smooth kernel fitted without it reached 135 MPa on a 42 MPa curve, its length at the window's
    span: the kernel extrapolating to what no data constrain, not a measurement.)"""
    if spec.amplitude is not None:
        return spec.amplitude
    return ParameterSpec(prior="half-normal", scale=float(DEFAULT_AMPLITUDE_SCALE * max(rms, 1e-12)))


def resolved_priors(spec: DiscrepancyConfig, rms: float, axis: Axis,
                    evident: bool) -> dict[str, ParameterSpec]:
    """The priors (or fixed values) the posterior uses. Left out in the config, they follow the
    evidence of model error in the test (docs/model-error.md):

    - with evidence (``evident``: the likelihood ratio against the white model above EVIDENCE_LR):
      ``amplitude_prior``, length log-uniform from 3 median sampling steps to the span of the window;
    - without: the amplitude fixed at 0, i.e. exactly the white likelihood. The data cannot tell a
      smooth discrepancy of a few hundredths of σ0 from a change of the parameters, so without
      evidence only the prior would decide how much of it to admit.

    An amplitude or length given in the config is always used as given.
    """
    out = search_priors(spec, rms, axis)
    out[AMPLITUDE] = amplitude_prior(spec, rms)
    if spec.amplitude is None and not evident:
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


def _bounds(spec: ParameterSpec, floor: float, cap: float) -> tuple[float, float]:
    lo, hi = spec.bounds()
    return math.log(max(lo, floor)), math.log(min(hi, cap))


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


_FIELD = {"sigma0": "sigma0", AMPLITUDE: "amplitude", LENGTH: "length"}
GRADIENT_STEP = 1e-5      # central differences in ln h: error ~ step² × the third derivative
FLAT = 1e-7              # a change of -log posterior below this is no change (Nelder-Mead's fatol)
STARTS_DESCENDED = 1      # the best starts (by their value) that are descended from


def _gradient_search(objective: Callable[[np.ndarray], float], starts: list[np.ndarray],
                     lo: np.ndarray, hi: np.ndarray):
    """The lowest minimum of ``objective`` over the box [lo, hi] by L-BFGS-B with central-difference
    gradients, from the STARTS_DESCENDED starts of lowest value: a few dozen evaluations where
    Nelder-Mead from every start took hundreds. A step that leaves the box is taken one-sided."""
    from scipy.optimize import minimize

    def value_and_gradient(v: np.ndarray) -> tuple[float, np.ndarray]:
        f0 = objective(v)
        g = np.zeros_like(v)
        for j in range(v.size):
            up, down = v.copy(), v.copy()
            up[j] = min(v[j] + GRADIENT_STEP, hi[j])
            down[j] = max(v[j] - GRADIENT_STEP, lo[j])
            if up[j] - down[j] <= 0:
                continue
            fu = objective(up) if up[j] > v[j] else f0
            fd = objective(down) if down[j] < v[j] else f0
            g[j] = (fu - fd) / (up[j] - down[j])
        if not (math.isfinite(f0) and np.all(np.isfinite(g))):
            return (f0 if math.isfinite(f0) else 1e300), np.zeros_like(v)
        return f0, g

    ranked = sorted(starts, key=objective)[:STARTS_DESCENDED]
    best = None
    for v0 in ranked:
        res = minimize(value_and_gradient, v0, jac=True, method="L-BFGS-B",
                       bounds=list(zip(lo, hi, strict=True)),
                       options={"ftol": 1e-10, "gtol": 1e-5, "maxiter": 200})
        if best is None or res.fun < best.fun:
            best = res
    return best


@dataclass
class HyperFit:
    """The maximum a-posteriori hyperparameters of one kernel under one likelihood of h."""

    kernel: str
    hyper: Hyper
    log_likelihood: float            # the likelihood of h at ``hyper``
    log_posterior: float             # ... plus the amplitude's log prior (what the kernels compare)
    free: list[str]
    covariance_log: np.ndarray       # of ln(free hyperparameters), from the curvature (for starts)
    evaluations: int


def restricted_log_likelihood(x: np.ndarray, r: np.ndarray, X: np.ndarray, h: Hyper, kind: str,
                              start: float | None = None) -> float:
    """The restricted (REML) log-likelihood of h: of the residual r (axis order) with the parameters
    of the linearized model y ≈ y(θ) + X Δθ integrated out under a flat prior,

        -½ [rᵀC⁻¹r - bᵀ(XᵀC⁻¹X)⁻¹b + log det C + log det XᵀC⁻¹X + (n - p) ln 2π],  b = XᵀC⁻¹r,

    (up to ½ log det XᵀX, the same for every h). It does not depend on where along X the residual
    is taken, so the hyperparameters are not confounded with θ (Patterson & Thompson 1971); it is
    also the evidence of a kernel against another up to that constant."""
    return restricted_likelihood(x, r, X, kind, start)(h)


def restricted_likelihood(x: np.ndarray, r: np.ndarray, X: np.ndarray, kind: str,
                          start: float | None = None) -> Callable[[Hyper], float]:
    """h -> ``restricted_log_likelihood(x, r, X, h, kind, start)``: the axis, columns and buffers
    checked and laid out once, for a search that evaluates it hundreds of times."""
    n, p = X.shape
    whiten = gp.whitening(x, np.column_stack([r, X]), kind, start)
    constant = (n - p) * math.log(2.0 * math.pi)

    def value(h: Hyper) -> float:
        if not (h.sigma0 > 0 and h.amplitude >= 0 and h.length > 0):
            return -math.inf
        out, logdet = whiten(float(h.sigma0), float(h.amplitude), float(h.length))
        zr, zX = out[:, 0], out[:, 1:]
        G = zX.T @ zX
        d = np.sqrt(np.diag(G))
        try:
            L = np.linalg.cholesky(G / d[:, None] / d[None, :])
        except np.linalg.LinAlgError:
            return -math.inf
        b = np.linalg.solve(L, (zX.T @ zr) / d)
        logdet_g = 2.0 * float(np.log(np.diag(L)).sum() + np.log(d).sum())
        v = -0.5 * (float(zr @ zr) - float(b @ b) + logdet + logdet_g + constant)
        return v if math.isfinite(v) else -math.inf

    return value


def hyper_fit(kind: str, loglik: Callable[[Hyper], float], axis: Axis, r: np.ndarray,
              priors: dict[str, ParameterSpec], sigma0: float | None, floor: float,
              warm: Hyper | None = None, search: str = "gradient") -> HyperFit:
    """Maximise ``loglik(h)`` plus the amplitude's log prior over ln σ0 (when ``sigma0`` is None;
    never below the noise ``floor``), ln a and ln ℓ within their priors' supports; r: the residual
    in axis order (for starting values). The starts: a few lengths (the residuals' autocorrelation
    length among them) and ``warm`` (e.g. another kernel's optimum). ``search``: ``gradient``, a
    bounded quasi-Newton descent (``_gradient_search``), or ``nelder-mead`` from every start (the
    slower reference it is tested against)."""
    from scipy.optimize import minimize  # here: `sample` reads fit.json, never optimises

    from bayes_dnlr.inference.posterior.priors import Prior

    rms = float(np.sqrt(np.mean(r**2)))
    scale = max(rms, 1e-12)
    fixed = {k: s.value for k, s in priors.items() if s.fixed}
    names = [k for k in ("sigma0", AMPLITUDE, LENGTH)
             if (k == "sigma0" and sigma0 is None) or (k != "sigma0" and k not in fixed)]
    amp_prior = (Prior.from_spec(AMPLITUDE, priors[AMPLITUDE], key="noise.discrepancy.amplitude")
                 if AMPLITUDE in names else None)
    d = np.diff(r)
    s0_start = max(float(np.std(d) / math.sqrt(2.0)) if d.size else scale / 2, floor, 1e-3 * scale)
    s0_start = min(s0_start, max(scale, floor))
    a_start = math.sqrt(max(rms**2 - s0_start**2, (0.1 * scale) ** 2))
    bounds = {"sigma0": (math.log(max(floor, 1e-6 * scale)), math.log(max(10.0 * scale, 2 * floor)))}
    if AMPLITUDE in names:
        bounds[AMPLITUDE] = _bounds(priors[AMPLITUDE], AMPLITUDE_FLOOR * scale, 100.0 * scale)
        if not bounds[AMPLITUDE][0] < bounds[AMPLITUDE][1]:
            bounds[AMPLITUDE] = (bounds[AMPLITUDE][0], bounds[AMPLITUDE][0] + 1.0)
    if LENGTH in names:
        bounds[LENGTH] = _bounds(priors[LENGTH], 1e-12, math.inf)
    lo = np.array([bounds[k][0] for k in names])
    hi = np.array([bounds[k][1] for k in names])
    evals = 0

    def hyper(v: np.ndarray) -> Hyper:
        val = {k: float(np.exp(np.clip(z, lo[j], hi[j])))
               for j, (k, z) in enumerate(zip(names, v, strict=True))}
        if "sigma0" in val:           # exp(ln floor) may land an ulp below the floor
            val["sigma0"] = max(val["sigma0"], floor)
        return Hyper(sigma0=val.get("sigma0", sigma0 if sigma0 is not None else s0_start),
                     amplitude=val.get(AMPLITUDE, fixed.get(AMPLITUDE, a_start)),
                     length=val.get(LENGTH, fixed.get(LENGTH, 1.0)))

    def log_post(v: np.ndarray) -> tuple[float, float]:
        nonlocal evals
        evals += 1
        h = hyper(v)
        ll = loglik(h)
        lp = float(amp_prior.logpdf(np.array([h.amplitude]))[0]) if amp_prior is not None else 0.0
        return ll, ll + lp

    def objective(v: np.ndarray) -> float:
        value = -log_post(v)[1]
        return value if math.isfinite(value) else math.inf

    lengths = [_acf_length(axis, r)] if LENGTH in names else [fixed[LENGTH]]
    if LENGTH in names:
        a, b = bounds[LENGTH]
        lengths += [math.exp(a + 0.25 * (b - a)), math.exp(a + 0.75 * (b - a))]
    inner = lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo)
    starts = [np.clip([math.log({"sigma0": s0_start, AMPLITUDE: a_start, LENGTH: length0}[k]) for k in names],
                      *inner) for length0 in lengths] if names else []
    if warm is not None and names and search != "nelder-mead":
        starts.append(np.clip([math.log(getattr(warm, _FIELD[k])) for k in names], *inner))
    best = None
    if search == "nelder-mead":
        for v0 in starts:
            res = minimize(objective, v0, method="Nelder-Mead", bounds=list(zip(lo, hi, strict=True)),
                           options={"xatol": 1e-5, "fatol": 1e-7, "maxfev": 300 * (len(v0) + 1),
                                    "adaptive": True})
            if best is None or res.fun < best.fun:
                best = res
    elif starts:
        best = _gradient_search(objective, starts, lo, hi)
        if AMPLITUDE in names:          # no model error: the amplitude's floor, where Nelder-Mead ends
            j = names.index(AMPLITUDE)
            v = best.x.copy()
            v[j] = lo[j]
            f = objective(v)
            if f <= best.fun + FLAT:
                best.x, best.fun = v, f
    v = best.x if best is not None else np.zeros(0)
    ll, lp = log_post(v)
    cov = _log_covariance(objective, v, 0, len(names))
    return HyperFit(kind, hyper(v), ll, lp, names, cov, evals)
