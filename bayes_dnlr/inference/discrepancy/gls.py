"""The analysis of a test under model error (``fit``'s discrepancy block): one estimate whatever the
kernel, and an interval whose width is set by the kernels weighed by the data (docs/model-error.md).

A discrepancy δ ~ GP(0, K) on the residual is confounded with the parameters: each kernel's
generalized least squares (GLS) estimates another θ (Brynjarsdóttir & O'Hagan 2014), so choosing a
kernel chose E (the 2-sd refusal of matern32 that this replaces flipped E by 2.1 combined sd between
two equally valid configs of a real curve). Here the estimate's *metric* is fixed and the kernel
only sets the *width*:

- ``target: generalized`` (the default): θ° = the GLS estimate under the Ornstein-Uhlenbeck (exp)
  covariance C_w, its hyperparameters by restricted likelihood (REML). Its covariance under an
  error of covariance C_k is the sandwich Σ_w Xᵀ C_w⁻¹ C_k C_w⁻¹ X Σ_w, Σ_w = (Xᵀ C_w⁻¹ X)⁻¹; the
  interval uses the mixture over the kernels k, weighed by their restricted likelihood, each with
  its own REML hyperparameters. ``sample`` samples the exp posterior and maps its draws onto the
  mixture covariance (an open-faced sandwich adjustment, Shaby 2014).
- ``target: l2``: θ* = the (quadrature-weighted) least-squares projection, the orthogonal
  discrepancy's hyperparameters, and θ* widened by the projection variance S(h)
  (inference/discrepancy/orthogonal.py).

No threshold decides anything: the weights are continuous in the data, and the estimate does not
depend on them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from bayes_dnlr.config import Config, SampledNoise
from bayes_dnlr.inference.discrepancy import gp, orthogonal
from bayes_dnlr.inference.discrepancy.axis import test_axis
from bayes_dnlr.inference.discrepancy.hyper import (
    AMPLITUDE,
    AMPLITUDE_FLOOR,
    EVIDENCE_LR,
    LENGTH,
    Hyper,
    amplitude_prior,
    hyper_fit,
    resolved_priors,
    restricted_likelihood,
    restricted_log_likelihood,
    search_priors,
    whitener,
)
from bayes_dnlr.inference.discrepancy.kernel_mix import mix_words
from bayes_dnlr.inference.lsq import optimize
from bayes_dnlr.inference.lsq.problem import LsqProblem
from bayes_dnlr.inference.lsq.sensitivity import (
    bound_side,
    correlation,
    relative_errors,
    score_test,
    standard_deviations,
)
from bayes_dnlr.inference.lsq.sigma0 import high_frequency_sd, resolve_sigma0
from bayes_dnlr.inference.lsq.stress_score import stress_score
from bayes_dnlr.inference.lsq.whiteness import residual_diagnostics
from bayes_dnlr.numbers import fmt
from bayes_dnlr.vocabulary import SPECTRUM_EXPONENT

CANDIDATES = ("exp", "matern32")
WORKING = "exp"         # the kernel of the generalized target's metric (and of the sampled posterior)


def columns_for(cfg: Config, test, estimate: dict[str, float]):
    """(the orthogonality columns at the estimate θ*, the discrepancy's axis) of a test: what
    ``sample`` conditions on with ``target: l2``, rebuilt from fit.json's estimate as ``fit`` did."""
    problem = LsqProblem.for_config(cfg, test)
    params = problem.params([float(estimate[k]) for k in problem.names])
    axis = test_axis(cfg.noise.discrepancy, test, problem.mask)
    X = axis.sort(problem.jacobian_u(params))
    return orthogonal.make_columns(problem.names, problem.is_log, X, axis.values), axis


def _inverse(B: np.ndarray) -> np.ndarray:
    d = np.sqrt(np.diag(B))
    inv = np.linalg.inv(B / d[:, None] / d[None, :]) / d[:, None] / d[None, :]
    return 0.5 * (inv + inv.T)


def _physical(cov_u: np.ndarray, values: np.ndarray, log: np.ndarray) -> np.ndarray:
    """A covariance in u coordinates (ln θ for the time constants) as one of θ (delta method)."""
    J = np.where(log, values, 1.0)
    return cov_u * J[:, None] * J[None, :]


def _priors(cfg: Config, rms: float, axis) -> dict:
    priors = search_priors(cfg.noise.discrepancy, rms, axis)
    priors[AMPLITUDE] = amplitude_prior(cfg.noise.discrepancy, rms)
    return priors


def _record(fit) -> dict[str, Any]:
    h = fit.hyper
    return {"hyperparameters": {"sigma0": h.sigma0, "amplitude": h.amplitude, "length": h.length},
            "estimated": fit.free, "log_likelihood": fit.log_likelihood, "log_posterior": fit.log_posterior,
            "hyper_log_covariance": fit.covariance_log, "evaluations": fit.evaluations}


# ------------------------------------------------------------------ the two targets

def _generalized(cfg, problem, beta_white, axis, kernels, sigma0, floor) -> dict[str, Any]:
    """θ° by GLS under the exp covariance (REML hyperparameters), its model covariance Σ_w and the
    kernels' sandwiches (module doc)."""
    x, origin = axis.values, axis.origin
    params_w = problem.params(beta_white)
    r = axis.sort(problem.raw_residuals(params_w))
    X = axis.sort(problem.jacobian_u(params_w))
    rms = float(np.sqrt(np.mean(r**2)))
    priors = _priors(cfg, rms, axis)
    fits = {}
    for k in dict.fromkeys((WORKING, *kernels)):      # each kernel warm-started from the last optimum
        warm = fits[next(reversed(fits))].hyper if fits else None
        fits[k] = hyper_fit(k, restricted_likelihood(x, r, X, k, origin), axis, r,
                            priors, sigma0, floor, warm)
    hw = fits[WORKING].hyper
    problem.whiten = whitener(axis, hw, WORKING)
    try:
        opt = optimize.run_minimiser(problem, cfg.fit.method, beta_white, cfg.fit.max_iterations)
        if opt.criterion > problem.ssr(problem.params(beta_white)):
            opt = optimize.Optimum(np.asarray(beta_white), problem.ssr(problem.params(beta_white)), 0, 0,
                                   True, "the white estimate (the generalized fit did not improve it)")
    finally:
        problem.whiten = None
    params = problem.params(opt.beta)
    Xo = axis.sort(problem.jacobian_u(params))
    Z = gp.solve(x, Xo, hw.sigma0, hw.amplitude, hw.length, WORKING, origin)       # C_w⁻¹ X
    sigma_w = _inverse(0.5 * (Xo.T @ Z + Z.T @ Xo))
    per = {}
    for k in kernels:
        h = fits[k].hyper
        per[k] = _record(fits[k]) | {"covariance_u": gp.sandwich(x, Z, sigma_w, h.sigma0, h.amplitude,
                                                                 h.length, k, origin)}
    white_sigma = sigma0 if sigma0 is not None else math.sqrt(float(r @ r) / max(r.size - X.shape[1], 1))
    white = restricted_log_likelihood(x, r, X, Hyper(white_sigma, 0.0, 1.0), WORKING, origin)
    return {"params": params, "hyper": hw, "sampled_kernel": WORKING, "per": per,
            "sampled_covariance_u": sigma_w, "evidence_ll": max(a["log_likelihood"] for a in per.values()),
            "white_ll": white, "rms": rms, "r_window": problem.raw_residuals(params),
            "how": f"generalized least squares under the {WORKING} covariance ({opt.message})",
            "working": _record(fits[WORKING])}


def projection_estimate(cfg: Config, problem: LsqProblem, beta_white: np.ndarray, axis,
                        weights: np.ndarray) -> tuple[np.ndarray, str]:
    """θ* = argmin (y - y(θ))ᵀ W (y - y(θ)): the white least-squares estimate on an even grid,
    else the weighted fit from it. Returns (θ*, how)."""
    if orthogonal.is_even(weights):
        return np.asarray(beta_white, dtype=float), "the least-squares estimate (an even grid: W = I)"
    root = np.sqrt(weights)
    if axis.order is not None:                 # weights are in axis order; the problem's in window order
        root_w = np.empty_like(root)
        root_w[axis.order] = root
        root = root_w
    problem.whiten = lambda v: (root[:, None] * v) if v.ndim == 2 else root * v
    try:
        opt = optimize.run_minimiser(problem, cfg.fit.method, beta_white, cfg.fit.max_iterations)
    finally:
        problem.whiten = None
    return opt.beta, f"weighted least squares ({opt.message})"


def _l2(cfg, problem, beta_white, axis, kernels, sigma0, floor) -> dict[str, Any]:
    """θ* (the weighted least-squares projection), the orthogonal discrepancy's hyperparameters for
    each kernel, Var(θ*) and the projection variance S(h) (inference/discrepancy/orthogonal.py)."""
    x, origin = axis.values, axis.origin
    weights = orthogonal.quadrature_weights(x)
    beta, how = projection_estimate(cfg, problem, beta_white, axis, weights)
    params = problem.params(beta)
    r_window = problem.raw_residuals(params)
    r = axis.sort(r_window)
    cols = orthogonal.make_columns(problem.names, problem.is_log, axis.sort(problem.jacobian_u(params)), x)
    rms = float(np.sqrt(np.mean(r**2)))
    priors = _priors(cfg, rms, axis)
    per = {}
    for k in kernels:
        warm = Hyper(**per[next(reversed(per))]["hyperparameters"]) if per else None
        fit = hyper_fit(k, lambda h, k=k: orthogonal.log_likelihood(cols, x, r, h.sigma0, h.amplitude,
                                                                   h.length, k, origin),
                        axis, r, priors, sigma0, floor, warm)
        h = fit.hyper
        star = orthogonal.star_covariance(cols, x, h.sigma0, h.amplitude, h.length, k, origin)
        mt = orthogonal.mtilde(cols, x, h.length, k, origin)
        S = orthogonal.projection_covariance(cols, h.amplitude, mt)
        per[k] = _record(fit) | {"covariance_star_u": star, "projection_covariance_u": S,
                                 "covariance_u": star + S}
    w = orthogonal.kernel_weights({k: a["log_posterior"] for k, a in per.items()})
    chosen = max(w, key=lambda k: w[k])
    hs = per[chosen]["hyperparameters"]
    white_sigma = sigma0 if sigma0 is not None else math.sqrt(float(r @ r) / r.size)
    white = -0.5 * float(r @ r) / white_sigma**2 - r.size * math.log(white_sigma * math.sqrt(2 * math.pi))
    return {"params": params, "hyper": Hyper(hs["sigma0"], hs["amplitude"], hs["length"]),
            "sampled_kernel": chosen, "per": per,
            "sampled_covariance_u": sum(w[k] * per[k]["covariance_star_u"] for k in per),
            "evidence_ll": max(a["log_likelihood"] for a in per.values()), "white_ll": white, "rms": rms,
            "r_window": r_window, "how": how,
            "quadrature": "even" if orthogonal.is_even(weights) else "weighted"}


# ------------------------------------------------------------------ fit.json's discrepancy block

def discrepancy_analysis(cfg: Config, test, problem: LsqProblem, beta_white: np.ndarray,
                         residuals: np.ndarray) -> dict[str, Any]:
    """The analysis under model error (module doc): fit.json's ``discrepancy`` block."""
    spec = cfg.noise.discrepancy
    names = problem.names
    axis = test_axis(spec, test, problem.mask)
    fixed_sigma0 = None
    if not isinstance(cfg.noise.sigma0, SampledNoise) and cfg.noise.sigma0 != "residuals":
        fixed_sigma0 = resolve_sigma0(cfg, test, residuals)[0]
    floor = high_frequency_sd(axis.sort(residuals))
    kernels = CANDIDATES if spec.kernel == "auto" else (spec.kernel,)
    core = (_l2 if spec.target == "l2" else _generalized)(cfg, problem, beta_white, axis, kernels,
                                                          fixed_sigma0, floor)
    per, params, h, rms = core["per"], core["params"], core["hyper"], core["rms"]
    values = problem.vector(params)
    w = orthogonal.kernel_weights({k: a["log_posterior"] for k, a in per.items()})
    zero_amplitude = h.amplitude <= 1.01 * AMPLITUDE_FLOOR * max(rms, 1e-12)
    lr = 2.0 * (core["evidence_ll"] - core["white_ll"])
    evident = bool(lr > EVIDENCE_LR and not zero_amplitude)
    priors = resolved_priors(spec, rms, axis, evident)
    sampled_u = core["sampled_covariance_u"]
    total_u = sum(w[k] * per[k]["covariance_u"] for k in per) if evident else sampled_u
    cov = _physical(total_u, values, problem.is_log)
    sd = standard_deviations(cov)
    corr = correlation(cov)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = relative_errors(cov, values)
    dt = corr.copy()
    np.fill_diagonal(dt, err)
    sampled = _physical(sampled_u, values, problem.is_log)
    warnings: list[str] = []
    for k in names:
        lo, hi = cfg.parameters[k].bounds()
        side = bound_side(float(params[k]), lo, hi)
        if side is not None:
            warnings.append(f"{k} = {lo if side == 'lower' else hi:g} (the estimate under model error) "
                            f"sits on the {side} bound of its prior [{lo:g}, {hi:g}]")
    hs = core["sampled_kernel"]
    whiten = whitener(axis, Hyper(h.sigma0, max(h.amplitude, 0.0), h.length), hs)
    whitened = residual_diagnostics(whiten(core["r_window"]), 1.0, "whitened")
    score = None
    if SPECTRUM_EXPONENT not in names and "E" in names:      # the spectrum exponent held at ½
        x_alpha = problem.column(params, SPECTRUM_EXPONENT)
        score = score_test(whiten(problem.jacobian(params)), whiten(x_alpha), whiten(core["r_window"]),
                            1.0)
    stress = (stress_score(cfg, test, params, problem.jacobian(params), core["r_window"], 1.0,
                           problem.mask, whiten) if "E" in names else None)
    gain = (per["matern32"]["log_posterior"] - per["exp"]["log_posterior"]) if len(per) == 2 else None
    record = {
        "rule": "kernels weighed by their likelihood of the hyperparameters with the amplitude's prior; "
                "the estimate does not depend on the weights",
        "weights": w, "log_likelihood_gain_matern32": gain,
        "reason": mix_words(w, core["sampled_kernel"])
                  + (f" (log-likelihood matern32 - exp: {fmt(gain, 3)})" if gain is not None else ""),
        "candidates": {k: {kk: a[kk] for kk in ("hyperparameters", "log_likelihood", "log_posterior")}
                       for k, a in per.items()},
    }
    diag_sampled = np.sqrt(np.diag(sampled))
    projection = {
        "target": spec.target, "estimate": core["how"], "sigma0_floor": floor, "u_names": names,
        "log": [bool(v) for v in problem.is_log], "sampled_kernel": hs,
        "kernels": {k: {"weight": w[k], **a} for k, a in per.items()},
        "covariance_u": total_u, "sampled_covariance_u": sampled_u, "covariance_star": sampled,
        "sd_sampled": dict(zip(names, (float(v) for v in diag_sampled), strict=True)),
        "widening": dict(zip(names, (float(a / b) if b > 0 else math.nan
                                     for a, b in zip(sd, diag_sampled, strict=True)), strict=True)),
    }
    if "working" in core:
        projection["working"] = core["working"]
    if "quadrature" in core:
        projection["quadrature"] = core["quadrature"]
    return {
        "kernel": hs, "axis": spec.axis, "axis_unit": axis.unit, "target": spec.target,
        "hyperparameters": {"sigma0": h.sigma0, "amplitude": 0.0 if zero_amplitude else h.amplitude,
                            "length": h.length},
        "estimated": (core.get("working") or per[hs])["estimated"],
        "amplitude_is_zero": bool(zero_amplitude),
        "likelihood_ratio": lr, "evidence": evident,
        "priors": {k: v.model_dump(mode="json", exclude_none=True) for k, v in priors.items()},
        "log_likelihood": (core.get("working") or per[hs])["log_likelihood"],
        "hyper_log_covariance": (core.get("working") or per[hs])["hyper_log_covariance"],
        "ml_evaluations": sum(a["evaluations"] for a in per.values()),
        "estimate": params,
        "sd": dict(zip(names, (float(x) for x in sd), strict=True)),
        "err": dict(zip(names, (float(x) for x in err), strict=True)),
        "covariance": cov, "correlation": corr, "delta_tilde": dt,
        "shift_in_sd": {k: (params[k] - float(beta_white[j])) / float(sd[j])
                        for j, k in enumerate(names) if sd[j] > 0},
        "criterion": float(core["r_window"] @ core["r_window"]), "converged": True, "message": core["how"],
        "whitened_residuals": whitened,
        "alpha_score": score,
        "stress_score": stress,
        "kernel_choice": record,
        "projection": projection,
        "warnings": warnings + _whiteness_warning(whitened, zero_amplitude, hs),
    }


def _whiteness_warning(whitened: dict[str, Any], zero: bool, kernel: str) -> list[str]:
    if whitened["white"] or zero:
        return []
    # every statistic of the test: the one that failed may be the runs test alone, with a lag-1
    # autocorrelation near 0 (the sign pattern in the small residuals)
    runs = whitened["runs_test"]
    return [f"the whitened residuals are still correlated ({runs['n_runs']} sign runs for "
            f"{runs['expected']:.0f} expected, Durbin-Watson {whitened['durbin_watson']:.2f}, lag-1 "
            f"autocorrelation {whitened['lag1_autocorrelation']:+.2f}): the {kernel} kernel describes "
            "the model error only in part (docs/model-error.md, 'Limits')"]


__all__ = ["CANDIDATES", "LENGTH", "WORKING", "columns_for", "discrepancy_analysis",
           "projection_estimate"]
