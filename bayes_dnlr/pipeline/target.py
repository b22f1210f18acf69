"""What a ``sample`` run samples: the log-density, its priors and names, where the walkers start,
and what the chain must remember (the resolved discrepancy priors) — for one test, or for the joint
vector of a run with ``tests:`` (inference/joint.py).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from bayes_dnlr.config import DISCREPANCY_PARAMETERS, Config, ParameterSpec, SampledNoise
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.discrepancy import AMPLITUDE, LENGTH, discrepancy_priors, is_white
from bayes_dnlr.inference.joint import NOISE_NAMES, JointPosterior, Layout, base_name, test_of
from bayes_dnlr.inference.likelihood import LogPosterior, build_log_posterior
from bayes_dnlr.inference.priors import PriorSet, build_priors, sampled_names


@dataclass
class Target:
    """The log-density a run samples and how its walkers start."""

    post: Any                      # LogPosterior or JointPosterior: z (k, ndim) -> (k,)
    priors: PriorSet
    x0: np.ndarray                 # start (physical units) and its covariance
    cov: np.ndarray
    sigma0: Any                    # float (one test), {test: float} (joint), None when sampled
    sigma0_source: Any
    meta: dict[str, Any] = field(default_factory=dict)   # extra chain attributes

    @property
    def names(self) -> list[str]:
        return self.priors.names


def start_point(post: LogPosterior, fit: dict[str, Any],
                sigma0_start: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Where the walkers start: the least-squares estimate and its linearized covariance (eq. 32)
    from fit.json — the generalized (discrepancy) analysis when the likelihood has a discrepancy —,
    in the order of the sampled parameters (physical units). A sampled sigma0 starts at
    ``sigma0_start`` with the sd of a variance estimate from n points; the discrepancy
    hyperparameters at their maximum-likelihood values with the spread of the likelihood's
    curvature."""
    names = post.names
    disc = fit.get("discrepancy") if post.discrepancy is not None else None
    src = disc if disc else fit
    est = src.get("estimate") or {}
    fit_names = list(fit.get("parameters") or [])
    noise = ("sigma0", *DISCREPANCY_PARAMETERS)
    missing = [k for k in names if k not in noise and k not in est]
    if missing:
        raise RunError(f"fit.json has no estimate for {missing}: run `fit --force`")
    hyper = dict((disc or {}).get("hyperparameters") or {})
    rms = float((fit.get("residuals") or {}).get("rms") or 1.0)
    if disc and disc.get("amplitude_is_zero"):
        hyper["amplitude"] = 0.05 * rms          # on the bound: start just inside, spread as much
    start = {"sigma0": sigma0_start, AMPLITUDE: hyper.get("amplitude"), LENGTH: hyper.get("length")}
    x0 = np.array([start[k] if k in noise else est[k] for k in names], dtype=float)
    # strictly inside the support: exp(ln x) may overshoot a bound the estimate sits on by an ulp
    lo = np.array([p.low for p in post.priors.priors])
    hi = np.array([p.high for p in post.priors.priors])
    with np.errstate(invalid="ignore"):           # inf - inf on unbounded sides: left as they are
        x0 = np.clip(x0, np.where(np.isfinite(lo), lo + 1e-9 * np.abs(lo), lo),
                     np.where(np.isfinite(hi), hi - 1e-9 * np.abs(hi), hi))
    model_pos = [j for j, k in enumerate(names) if k not in noise]
    cov = np.zeros((len(names), len(names)))
    try:
        fcov = np.asarray(src.get("covariance"), dtype=float)
        idx = [fit_names.index(names[j]) for j in model_pos]
        cov[np.ix_(model_pos, model_pos)] = fcov[np.ix_(idx, idx)]
    except (TypeError, ValueError, IndexError):
        cov[np.ix_(model_pos, model_pos)] = np.nan
    fit_sigma = fit.get("sigma0")
    if not disc and post.sigma0 is not None and fit_sigma and fit_sigma > 0:
        cov *= (post.sigma0 / fit_sigma) ** 2     # the covariance scales with σ0²
    if "sigma0" in names:
        j = names.index("sigma0")
        cov[j, j] = sigma0_start ** 2 / (2.0 * post.n)
    if disc:
        free = list(disc.get("estimated") or [])
        log_cov = np.asarray(disc.get("hyper_log_covariance") or np.zeros((0, 0)), dtype=float)
        for k in (AMPLITUDE, LENGTH):
            if k not in names:
                continue
            j = names.index(k)
            var_log = log_cov[free.index(k), free.index(k)] if k in free and log_cov.size else 1.0
            if k == AMPLITUDE and disc.get("amplitude_is_zero"):
                var_log = 1.0
            cov[j, j] = min(var_log, 1.0) * x0[j] ** 2
    return x0, cov


def resolve_sigma0(cfg: Config, fit: dict[str, Any], test) -> tuple[float | None, str, float | None]:
    """(σ0 for the likelihood or None when sampled, its source, a starting value when sampled).

    With a discrepancy, ``residuals`` means the white part of the residuals: the maximum-likelihood
    σ0 that fit.json's discrepancy analysis found beside the amplitude and length."""
    spec = cfg.noise.sigma0
    if isinstance(spec, int | float):
        return float(spec), "config", None
    disc = fit.get("discrepancy") if cfg.noise.has_discrepancy else None
    priors = discrepancy_priors(fit) if disc else None
    if priors is not None and is_white(priors):
        disc = None                          # no evidence of model error: the white likelihood
    ml_sigma = ((disc or {}).get("hyperparameters") or {}).get("sigma0")
    fit_sigma = ml_sigma if disc else fit.get("sigma0")
    if isinstance(spec, SampledNoise):
        start = float(fit_sigma) if fit_sigma else None
        if start is None:
            from bayes_dnlr.inference.noise import resolve_sigma0

            start = resolve_sigma0(cfg, test)[0]
        return None, "sampled", start
    if fit_sigma and math.isfinite(fit_sigma) and fit_sigma > 0:
        source = ("white part of the residuals (maximum likelihood with the discrepancy)"
                  if disc and spec == "residuals" else str(fit.get("sigma0_source") or spec))
        return float(fit_sigma), source, None
    from bayes_dnlr.inference.noise import resolve_sigma0

    value, source = resolve_sigma0(cfg, test)
    return float(value), source, None




def _stored(stored, attr: str, key: str | None = None) -> Any:
    """A JSON attribute of the stored chain (a joint run's: its entry for test ``key``), or None."""
    raw = stored.attrs.get(attr) if stored is not None else None
    if not raw:
        return None
    value = json.loads(raw)
    return value.get(key) if key is not None else value


def _stored_priors(stored, key: str | None = None) -> dict[str, ParameterSpec] | None:
    block = _stored(stored, "discrepancy_priors", key)
    return None if block is None else discrepancy_priors({"discrepancy": {"priors": block}})


def _dump(priors: dict[str, ParameterSpec] | None) -> dict | None:
    return None if priors is None else {k: v.model_dump(mode="json", exclude_none=True)
                                        for k, v in priors.items()}


def _kernel(stored, fit: dict[str, Any], key: str | None = None) -> str | None:
    """The discrepancy kernel the chain was started with (resuming), else the one fit.json records
    (``kernel: auto`` resolves there)."""
    return _stored(stored, "discrepancy_kernel", key) or (fit.get("discrepancy") or {}).get("kernel")


def single_target(cfg: Config, test, fit: dict[str, Any], stored=None) -> Target:
    """The posterior of one test (its resolved discrepancy priors and kernel from the stored chain
    when it resumes one, else from fit.json)."""
    sigma0, source, sigma0_start = resolve_sigma0(cfg, fit, test)
    disc_priors = _stored_priors(stored) or discrepancy_priors(fit)
    if cfg.noise.has_discrepancy and disc_priors is None:
        raise RunError(f"{cfg.run_dir / 'fit.json'} has no discrepancy analysis for this config "
                       "(made by another version?): run `fit --force`")
    kernel = _kernel(stored, fit)
    priors = build_priors(cfg, disc_priors)
    post = build_log_posterior(cfg, test, sigma0, priors, disc_priors, kernel)
    x0, cov = start_point(post, fit, sigma0_start)
    meta = {} if disc_priors is None else {"discrepancy_priors": json.dumps(_dump(disc_priors)),
                                           "discrepancy_kernel": json.dumps(kernel)}
    return Target(post, priors, x0, cov, sigma0, source, meta)


def joint_target(cfg: Config, tests: dict[str, Any], fit: dict[str, Any], stored=None) -> Target:
    """The joint posterior of a run with ``tests:``: shared and per-test model parameters, each
    test's own noise parameters; walkers start at the joint least-squares estimate (generalized
    when a test has model error) and each test's noise parameters where its own fit put them."""
    singles = fit.get("single_fits") or {}
    local_posts, local_priors, local_names, starts, sig, src, disc_all = {}, {}, {}, {}, {}, {}, {}
    kernels: dict[str, str | None] = {}
    for t in cfg.test_names:
        view = cfg.for_test(t)
        single = singles.get(t)
        if single is None:
            raise RunError(f"fit.json has no fit of test {t}: run `fit --force`")
        s0, s0_src, s0_start = resolve_sigma0(view, single, tests[t])
        disc_priors = _stored_priors(stored, t) or discrepancy_priors(single)
        if view.noise.has_discrepancy and disc_priors is None:
            raise RunError(f"fit.json has no discrepancy analysis for test {t}: run `fit --force`")
        priors = build_priors(view, disc_priors)
        kernels[t] = _kernel(stored, single, t)
        post = build_log_posterior(view, tests[t], s0, priors, disc_priors, kernels[t])
        local_posts[t], local_priors[t] = post, priors
        local_names[t] = sampled_names(view, disc_priors)
        starts[t] = start_point(post, single, s0_start)
        sig[t], src[t], disc_all[t] = s0, s0_src, _dump(disc_priors)
    layout = Layout.build(local_names, cfg.per_test_parameters)
    joint_priors = []
    for g in layout.names:
        t = test_of(g) or next(t for t in layout.tests if base_name(g) in local_names[t])
        p = local_priors[t].priors[local_priors[t].names.index(base_name(g))]
        joint_priors.append(replace(p, name=g))
    priors = PriorSet(tuple(joint_priors))
    post = JointPosterior(local_posts, layout, priors)
    # start: the joint model estimate and covariance, each test's noise start
    gls = fit.get("discrepancy")
    src_fit = gls if gls and gls.get("estimate") else fit
    fit_names = list(fit.get("parameters") or [])
    n = len(layout.names)
    x0, cov = np.empty(n), np.zeros((n, n))
    model = [j for j, g in enumerate(layout.names) if base_name(g) not in NOISE_NAMES]
    for j in model:
        x0[j] = float(src_fit["estimate"][layout.names[j]])
    try:
        fcov = np.asarray(src_fit["covariance"], dtype=float)
        idx = [fit_names.index(layout.names[j]) for j in model]
        cov[np.ix_(model, model)] = fcov[np.ix_(idx, idx)]
    except (KeyError, TypeError, ValueError, IndexError):
        cov[np.ix_(model, model)] = np.nan
    for t in layout.tests:
        lx0, lcov = starts[t]
        for i, k in enumerate(local_names[t]):
            if k in NOISE_NAMES:
                j = layout.columns[t][i]
                x0[j], cov[j, j] = lx0[i], lcov[i, i]
    meta = {"discrepancy_priors": json.dumps(disc_all), "discrepancy_kernel": json.dumps(kernels),
            "layout": json.dumps(layout.local)}
    return Target(post, priors, x0, cov, sig, src, meta)
