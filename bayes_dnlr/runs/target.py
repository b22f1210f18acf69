"""What a ``sample`` run samples: the log-density of the run's parameter vector, its priors and
names, where the walkers start, and what the chain must remember (each test's resolved
discrepancy priors and kernel). One test or several: a run with one test is the case N = 1 of the
same construction (inference/layout.py, inference/posterior/density.py).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bayes_dnlr.config import Config, ParameterSpec, SampledNoise
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.discrepancy.hyper import AMPLITUDE, LENGTH, discrepancy_priors, is_white
from bayes_dnlr.inference.layout import Layout, test_of
from bayes_dnlr.inference.posterior.density import LogPosterior
from bayes_dnlr.inference.posterior.likelihood import TestLikelihood, build_likelihood
from bayes_dnlr.inference.posterior.priors import PriorSet, build_priors, sampled_names
from bayes_dnlr.runs.layout import FIT_FILE
from bayes_dnlr.runs.records import Analysis, FitRecord, TestFit
from bayes_dnlr.runs.testset import TestSet
from bayes_dnlr.vocabulary import NOISE_NAMES, base_name


@dataclass
class Target:
    """The log-density a run samples and how its walkers start."""

    post: LogPosterior             # z (k, ndim) -> (k,)
    priors: PriorSet
    x0: np.ndarray                 # start (physical units) and its covariance
    cov: np.ndarray
    sigma0: Any                    # per test (collapsed: one number for one test); None when sampled
    sigma0_source: Any
    meta: dict[str, Any] = field(default_factory=dict)   # extra chain attributes

    @property
    def names(self) -> list[str]:
        return self.priors.names

    @property
    def model_indices(self) -> list[int]:
        """The positions of the model parameters (not σ0 nor the discrepancy's) in ``names``."""
        return [j for j, k in enumerate(self.names) if base_name(k) not in NOISE_NAMES]

    @property
    def near_linear(self) -> bool:
        """Whether the posterior is expected close to its linearization (eq. 32), for the Laplace
        move (inference/mcmc/blocks.py): not when the discrepancy's amplitude or length, or the
        spectrum's exponent, is sampled; there it was accepted less often than DEMove (measured in
        docs/sampling.md)."""
        return not any(base_name(k) in (AMPLITUDE, LENGTH, "alpha") for k in self.names)


def resolve_sigma0(cfg: Config, fit: TestFit, test) -> tuple[float | None, str, float | None]:
    """(σ0 for the likelihood or None when sampled, its source, a starting value when sampled) of
    one test.

    With a discrepancy, ``residuals`` means the white part of the residuals: the maximum-likelihood
    σ0 that fit.json's discrepancy analysis found beside the amplitude and length."""
    spec = cfg.noise.sigma0
    if isinstance(spec, int | float):       # one row's: per point of a reduced test (data.reduce) σ0/√k
        from bayes_dnlr.inference.lsq.sigma0 import resolve_sigma0 as from_config

        return from_config(cfg, test)[0], "config", None
    disc = fit.discrepancy if cfg.noise.has_discrepancy else None
    priors = discrepancy_priors({"discrepancy": disc}) if disc else None
    if priors is not None and is_white(priors):
        disc = None                          # no evidence of model error: the white likelihood
    ml_sigma = ((disc or {}).get("hyperparameters") or {}).get("sigma0")
    fit_sigma = ml_sigma if disc else fit.sigma0
    if isinstance(spec, SampledNoise):
        start = float(fit_sigma) if fit_sigma else None
        if start is None:
            from bayes_dnlr.inference.lsq.sigma0 import resolve_sigma0 as from_config

            start = from_config(cfg, test)[0]
        return None, "sampled", start
    if fit_sigma and math.isfinite(fit_sigma) and fit_sigma > 0:
        source = ("white part of the residuals (maximum likelihood with the discrepancy)"
                  if disc and spec == "residuals" else str(fit.sigma0_source or spec))
        return float(fit_sigma), source, None
    from bayes_dnlr.inference.lsq.sigma0 import resolve_sigma0 as from_config

    value, source = from_config(cfg, test)
    return float(value), source, None


def _inside(x0: np.ndarray, priors: PriorSet) -> np.ndarray:
    """Strictly inside the support: exp(ln x) may overshoot a bound the estimate sits on by an ulp."""
    lo = np.array([p.low for p in priors.priors])
    hi = np.array([p.high for p in priors.priors])
    with np.errstate(invalid="ignore"):           # inf - inf on unbounded sides: left as they are
        return np.clip(x0, np.where(np.isfinite(lo), lo + 1e-9 * np.abs(lo), lo),
                       np.where(np.isfinite(hi), hi - 1e-9 * np.abs(hi), hi))


def model_start(analysis: Analysis | None, names: list[str], priors: PriorSet,
                scale: float = 1.0, covariance: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The model parameters' start (the run's least-squares estimate, eq. 32, strictly inside the
    prior support) and covariance (× ``scale``², NaN when the analysis has none; ``covariance``
    in the analysis' order instead of its own), in the order of ``names``; the noise parameters'
    entries are left 0 for ``noise_start``."""
    n = len(names)
    model = [j for j, k in enumerate(names) if base_name(k) not in NOISE_NAMES]
    est = analysis.estimate if analysis is not None else {}
    missing = [names[j] for j in model if names[j] not in est]
    if missing:
        raise RunError(f"{FIT_FILE} has no estimate for {missing}: run `fit --force`")
    x0 = np.array([est[k] if j in model else 0.0 for j, k in enumerate(names)], dtype=float)
    x0 = np.where(np.isin(np.arange(n), model), _inside(x0, priors), x0)
    cov = np.zeros((n, n))
    try:
        idx = [analysis.names.index(names[j]) for j in model]   # type: ignore[union-attr]
        full = analysis.covariance if covariance is None else covariance   # type: ignore[union-attr]
        cov[np.ix_(model, model)] = full[np.ix_(idx, idx)] * scale**2
    except (AttributeError, TypeError, ValueError, IndexError):
        cov[np.ix_(model, model)] = np.nan
    return x0, cov


def noise_start(like: TestLikelihood, priors: PriorSet, fit: TestFit, sigma0_start: float | None,
                rms: float) -> dict[str, tuple[float, float]]:
    """Each sampled noise parameter of one test: (start, variance). A sampled sigma0 starts at
    ``sigma0_start`` with the variance of a variance estimate from n points; the discrepancy's
    hyperparameters at their maximum-likelihood values with the spread of the likelihood's
    curvature (capped at 1 in log)."""
    disc = fit.discrepancy if like.discrepancy is not None else None
    hyper = dict((disc or {}).get("hyperparameters") or {})
    if disc and disc.get("amplitude_is_zero"):
        hyper["amplitude"] = 0.05 * rms          # on the bound: start just inside, spread as much
    start = {"sigma0": sigma0_start, AMPLITUDE: hyper.get("amplitude"), LENGTH: hyper.get("length")}
    names = [k for k in like.names if k in NOISE_NAMES]
    x0 = np.array([start[k] for k in like.names if k in NOISE_NAMES], dtype=float)
    noise_priors = PriorSet(tuple(p for p in priors.priors if p.name in NOISE_NAMES))
    x0 = _inside(x0, noise_priors) if names else x0
    free = list((disc or {}).get("estimated") or [])
    log_cov = np.asarray((disc or {}).get("hyper_log_covariance") or np.zeros((0, 0)), dtype=float)
    out = {}
    for k, x in zip(names, x0, strict=True):
        if k == "sigma0":
            out[k] = (float(x), sigma0_start**2 / (2.0 * like.n))
            continue
        var_log = log_cov[free.index(k), free.index(k)] if k in free and log_cov.size else 1.0
        if k == AMPLITUDE and disc.get("amplitude_is_zero"):
            var_log = 1.0
        out[k] = (float(x), min(var_log, 1.0) * float(x) ** 2)
    return out


def stored_per_test(stored, attr: str, plain: bool, tests: list[str]) -> dict[str, Any]:
    """A JSON attribute of the stored chain, per test (one test's chain holds the value itself)."""
    raw = stored.attrs.get(attr) if stored is not None else None
    if not raw:
        return {}
    value = json.loads(raw)
    return {tests[0]: value} if plain else dict(value or {})


def _dump(priors: dict[str, ParameterSpec] | None) -> dict | None:
    return None if priors is None else {k: v.model_dump(mode="json", exclude_none=True)
                                        for k, v in priors.items()}


def _run_priors(layout: Layout, local: dict[str, PriorSet]) -> PriorSet:
    """The run's priors, in ``layout.names`` order: each name's prior from the test that uses it."""
    out = []
    for g in layout.names:
        t = test_of(g) or next(t for t in layout.tests if base_name(g) in local[t].names)
        p = local[t].priors[local[t].names.index(base_name(g))]
        out.append(p.renamed(g))
    return PriorSet(tuple(out))


def model_error_target(resumed: bool, stored_target: str | None, fit: TestFit,
                       disc_priors) -> str | None:
    """``generalized`` or ``l2`` when the draws of a test's posterior become those of the
    parameters under model error (inference/discrepancy/gls.py): fit made that analysis and found
    evidence of model error, and a resumed chain was started so (a chain from an earlier version
    continues as it began). None: the draws are the answer as they are."""
    proj = (fit.discrepancy or {}).get("projection")
    if not proj or disc_priors is None or is_white(disc_priors):
        return None
    return stored_target if resumed else proj.get("target", "generalized")


def reference_terms(cfg: Config, layout: Layout) -> list:
    """The likelihood of the references in the data (``reference_moduli`` with ``use: data``): one
    term over the run's vector, or none."""
    from bayes_dnlr.inference.references.terms import ReferenceLikelihood, data_references
    from bayes_dnlr.runs.reference_moduli import references_of

    refs = data_references(references_of(cfg))
    if not refs:
        return []
    return [ReferenceLikelihood(refs, layout.names, layout.name, cfg.fixed_values, cfg.model.modes,
                                cfg.model.decades)]


def build_target(cfg: Config, tests: TestSet, fit: FitRecord, stored=None) -> Target:
    """The posterior of a run: shared and per-test model parameters, each test's own noise
    parameters. The walkers start at the run's least-squares estimate (generalized when a test has
    model error) and each test's noise parameters where its own fit put them; a resumed chain keeps
    the discrepancy priors and kernel it was started with."""
    names_of = cfg.test_names
    stored_priors = stored_per_test(stored, "discrepancy_priors", tests.plain, names_of)
    stored_kernels = stored_per_test(stored, "discrepancy_kernel", tests.plain, names_of)
    stored_targets = stored_per_test(stored, "discrepancy_projection", tests.plain, names_of)
    likes, local_priors, noise, sig, src, disc_all, kernels = {}, {}, {}, {}, {}, {}, {}
    targets: dict[str, str | None] = {}
    for t in names_of:
        view, own = cfg.for_test(t), fit.tests.get(t)
        if own is None:
            raise RunError(f"{FIT_FILE} has no fit of test {t}: run `fit --force`")
        s0, s0_src, s0_start = resolve_sigma0(view, own, tests.tests[t])
        block = stored_priors.get(t)
        disc_priors = (discrepancy_priors({"discrepancy": {"priors": block}}) if block
                       else discrepancy_priors({"discrepancy": own.discrepancy}))
        if view.noise.has_discrepancy and disc_priors is None:
            raise RunError(f"{cfg.run_dir / FIT_FILE} has no discrepancy analysis for test {t} (made "
                           "by another version?): run `fit --force`")
        priors = build_priors(view, disc_priors)
        kernels[t] = stored_kernels.get(t) or (own.discrepancy or {}).get("kernel")
        targets[t] = model_error_target(stored is not None, stored_targets.get(t), own, disc_priors)
        columns = None
        if targets[t] == "l2":
            from bayes_dnlr.inference.discrepancy.gls import columns_for

            columns = columns_for(view, tests.tests[t], own.discrepancy["estimate"])[0].V
        like = build_likelihood(view, tests.tests[t], s0, sampled_names(view, disc_priors), disc_priors,
                                kernels[t], columns)
        rms = float(own.residuals.get("rms") or 1.0)
        likes[t], local_priors[t] = like, priors
        noise[t] = noise_start(like, priors, own, s0_start, rms)
        sig[t], src[t], disc_all[t] = s0, s0_src, _dump(disc_priors)
    layout = Layout.build({t: likes[t].names for t in names_of}, cfg.per_test_parameters, tests.plain)
    priors = _run_priors(layout, local_priors)
    post = LogPosterior(likes, layout, priors, reference_terms(cfg, layout))
    uses_disc = any(like.discrepancy is not None for like in likes.values())
    own_sigma = next(iter(likes.values())).sigma0 if tests.plain else None
    scale = (own_sigma / fit.sigma0 if not uses_disc and own_sigma is not None and fit.sigma0
             and fit.sigma0 > 0 else 1.0)                  # the covariance scales with σ0²
    # the sampled model's covariance (the exp model's, or θ*'s), not that of the answer under model
    # error, which the draws are mapped onto after sampling (one test)
    star = None
    if tests.plain:
        own = fit.tests[names_of[0]]
        star = ((own.discrepancy or {}).get("projection") or {}).get("covariance_star")
    x0, cov = model_start(fit.start_analysis(uses_disc), layout.names, priors, scale,
                          None if star is None else np.asarray(star, dtype=float))
    for t in names_of:
        for k, (x, var) in noise[t].items():
            j = layout.names.index(layout.name(k, t))
            x0[j], cov[j, j] = x, var
    meta = {"discrepancy_priors": layout.collapse(disc_all), "discrepancy_kernel": layout.collapse(kernels),
            "discrepancy_projection": layout.collapse(targets) if any(targets.values()) else None}
    meta = {k: json.dumps(v) for k, v in meta.items() if v is not None}
    if not tests.plain:
        meta["layout"] = json.dumps(layout.local)
    return Target(post, priors, x0, cov, layout.collapse(sig), layout.collapse(src), meta)
