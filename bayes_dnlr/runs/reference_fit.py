"""The references in ``fit`` (fit.json ``reference_moduli`` and ``reference_data``): with references
in the data (``use: data``) the run's analyses (white, and generalized under model error) take them
in, by the stacked least squares of the tests' problem with the references' rows
(inference/references/problem.py) from the optimum of the tests' quadratic form with them
(inference/references/condition.py), and fit.json keeps what they were without them: E's interval
before and after, how far it moved, how much it shrank; every reference gets the linearized
prediction at its time scale from the analysis ``sample`` will use (docs/fit.md)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.lsq.sensitivity import correlation, relative_errors, standard_deviations
from bayes_dnlr.inference.references import compare
from bayes_dnlr.inference.references.condition import Conditioned, condition, physical_to_u, stacked
from bayes_dnlr.inference.references.terms import Reference, data_references, predict
from bayes_dnlr.runs.reference_moduli import (
    console_lines,
    entry,
    is_log,
    name_function,
    reference_values,
    references_of,
)
from bayes_dnlr.vocabulary import Z90, base_name


def _e_of(ref: Reference, name_of) -> str:
    return name_of("E", ref.test) if ref.test is not None else "E"


def _analysis_record(names: Sequence[str], estimate: Mapping[str, float],
                     covariance: np.ndarray) -> dict[str, Any]:
    values = np.array([float(estimate[k]) for k in names])
    sd = standard_deviations(covariance)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = relative_errors(covariance, values)
    dt = correlation(covariance)
    np.fill_diagonal(dt, err)
    return {"estimate": {k: float(v) for k, v in estimate.items()},
            "sd": dict(zip(names, map(float, sd), strict=True)),
            "err": dict(zip(names, map(float, err), strict=True)),
            "covariance": covariance, "correlation": correlation(covariance), "delta_tilde": dt}


def _e_interval(block: Mapping[str, Any], e: str) -> dict[str, float] | None:
    if e not in (block.get("sd") or {}):
        return None
    m, s = float(block["estimate"][e]), float(block["sd"][e])
    return {"estimate": m, "sd": s, "interval_90": [m - Z90 * s, m + Z90 * s]}


def _moved(before: Mapping[str, Any], after: Mapping[str, Any], e: str) -> dict[str, Any] | None:
    b, a = _e_interval(before, e), _e_interval(after, e)
    if b is None or a is None:
        return None
    move = (a["estimate"] - b["estimate"]) / b["sd"] if b["sd"] else None
    return {"before": b, "after": a, "move_sd": move,
            "move_pct": 100.0 * (a["estimate"] / b["estimate"] - 1.0),
            "width_ratio": a["sd"] / b["sd"] if b["sd"] else None}


def _conditioned(refs, names, estimate, cov_u, fisher_u, cfg, name_of, fixed) -> Conditioned:
    bounds = {g: cfg.parameters[base_name(g)].bounds() for g in names}
    return condition(refs, names, is_log(names), {k: estimate[k] for k in names}, cov_u, fisher_u,
                     bounds, name_of, fixed, cfg.model.modes, cfg.model.decades)


def _exact(cfg: Config, base, weight: float, refs, start: Conditioned, name_of, fixed,
           meat_u: np.ndarray | None) -> Conditioned:
    """The tests' problem ``base`` (white, or whitened) with the references' rows, minimised from
    ``start`` (the quadratic form's optimum): the exact estimate; its covariance the stacked
    analysis' (eq. 32), or with the tests' sandwich (``meat_u`` M = A V A in u)
    A'⁻¹ (M + Jᵀ W J) A'⁻¹, A' the working model's information with the references."""
    from bayes_dnlr.inference.lsq.optimize import run_minimiser
    from bayes_dnlr.inference.references.problem import WithReferences

    problem = WithReferences(base, refs, weight, name_of, fixed, cfg.model.modes, cfg.model.decades)
    names = list(problem.names)
    beta0 = np.clip([start.estimate[k] for k in names], problem.lower, problem.upper)
    opt = run_minimiser(problem, cfg.fit.method, beta0, cfg.fit.max_iterations)
    params = problem.params(opt.beta)
    J = problem.jacobian_u(params)
    info = J.T @ J                          # A' in u: the tests' rows and the references'
    inv = np.linalg.inv(info)
    if meat_u is not None:
        rows = J[-problem.sd.size:]
        cov_u = inv @ (meat_u + rows.T @ rows) @ inv
    else:
        cov_u = inv
    cov_u = 0.5 * (cov_u + cov_u.T)
    jac = np.where(problem.is_log, problem.vector(params), 1.0)
    return Conditioned(names, {**dict(fixed), **{k: float(params[k]) for k in names}}, cov_u,
                       cov_u * jac[:, None] * jac[None, :], info, int(opt.iterations), bool(opt.converged))


def _held(cfg: Config, single) -> Config:
    return cfg.with_holds({k: float(v["value"]) for k, v in
                           ((single.identifiability or {}).get("held") or {}).items()})


def _white(cfg: Config, result, tests, data, name_of, fixed) -> Conditioned:
    """The white analysis with the data references: the stacked least squares, exact, from the
    optimum of the tests' quadratic form with them (without the tests' data: that optimum)."""
    from bayes_dnlr.inference.lsq.problem import LsqProblem
    from bayes_dnlr.inference.lsq.run_fit import joint_white_problem

    names = list(result.names)
    start = _conditioned(data, names, result.estimate, physical_to_u(
        result.covariance, [result.estimate[k] for k in names], is_log(names)), None, cfg, name_of, fixed)
    if not tests:
        return start
    if result.plain:
        (test,) = tests.values()
        base, weight = LsqProblem.for_config(_held(cfg, result.only), test), 1.0 / result.only.sigma0
    else:
        base, weight = joint_white_problem(cfg, tests, result.singles, result.identifiability)[0], 1.0
    return _exact(cfg, base, weight, data, start, name_of, fixed, None)


def _generalized(cfg: Config, result, tests, data, disc, name_of, fixed) -> Conditioned:
    """The analysis under model error with the data references. One test whose estimate is the
    generalized least squares (``target: generalized``): exact, the test whitened by the working
    (exp) covariance at its hyperparameters, the kernels' sandwich carried over; otherwise (several
    tests, ``target: l2``) the quadratic form about the tests' optimum (condition.py)."""
    names = list(result.names)
    proj = disc.get("projection") or {}
    if proj.get("covariance_u") is not None and proj.get("sampled_covariance_u") is not None:
        V = np.asarray(proj["covariance_u"], dtype=float)
        A = np.linalg.inv(np.asarray(proj["sampled_covariance_u"], dtype=float))
    else:
        V = physical_to_u(np.asarray(disc["covariance"], dtype=float),
                          [disc["estimate"][k] for k in names], is_log(names))
        A = None
    start = _conditioned(data, names, disc["estimate"], V, A, cfg, name_of, fixed)
    if not tests or not result.plain or A is None or disc.get("target", "generalized") != "generalized":
        return start
    from bayes_dnlr.inference.discrepancy.axis import test_axis
    from bayes_dnlr.inference.discrepancy.hyper import Hyper, whitener
    from bayes_dnlr.inference.lsq.problem import LsqProblem

    (test,) = tests.values()
    view = _held(cfg, result.only)
    base = LsqProblem.for_config(view, test)
    h = disc["hyperparameters"]
    base.whiten = whitener(test_axis(view.noise.discrepancy, test, base.mask),
                           Hyper(float(h["sigma0"]), float(h["amplitude"]), float(h["length"])),
                           disc.get("kernel", "exp"))
    return _exact(cfg, base, 1.0, data, start, name_of, fixed, A @ V @ A)


def _update(block: dict[str, Any] | Any, c: Conditioned, attr: bool) -> None:
    """Write a conditioned analysis into a FitResult / RunFit (``attr``) or a discrepancy block."""
    rec = _analysis_record(c.names, c.estimate, c.covariance)
    rec["estimate"] = {**(block.estimate if attr else block["estimate"]), **rec["estimate"]}
    for k, v in rec.items():
        if attr:
            setattr(block, k, v)
        else:
            block[k] = v


def fit_references(cfg: Config, result, tests: Mapping[str, Any] | None = None) -> None:
    """Put the references into a ``RunFit`` (``result``, changed in place): the data references
    into its analyses (``tests``: name -> TestData, for the exact stacked least squares; without
    them the quadratic form of the tests' analysis), every reference's linearized prediction into
    ``result.references``."""
    refs = references_of(cfg)
    if not refs:
        return
    plain = result.plain
    name_of = name_function(cfg, plain)
    single = result.only if plain else None
    names = list(result.names)
    held = dict(((single.identifiability if plain else result.identifiability) or {}).get("held") or {})
    fixed = {**cfg.fixed_values, **{k: float(v["value"]) for k, v in held.items()}}
    disc = (single.discrepancy if plain else result.discrepancy) or None
    evident = bool(disc and disc.get("estimate") and (disc.get("evidence", True))
                   and disc.get("covariance") is not None)
    data = data_references(refs)
    extra: dict[str, Any] = {}
    if data:
        without = {"white": _analysis_record(names, result.estimate, result.covariance)}
        white = _white(cfg, result, tests, data, name_of, fixed)
        for target in ((single, result) if plain else (result,)):
            _update(target, white, attr=True)
        done = {"white": white}
        if disc and disc.get("estimate") and disc.get("covariance") is not None:
            without["model_error"] = _analysis_record(names, disc["estimate"], np.asarray(disc["covariance"]))
            c = _generalized(cfg, result, tests, data, disc, name_of, fixed)
            proj = disc.get("projection") or {}
            if proj.get("covariance_u") is not None and proj.get("sampled_covariance_u") is not None:
                inv = np.linalg.inv(c.fisher_u)
                jac = np.where(is_log(names), [c.estimate[k] for k in names], 1.0)
                star = inv * jac[:, None] * jac[None, :]
                proj.update(covariance_u=c.covariance_u, sampled_covariance_u=inv, covariance_star=star,
                            sd_sampled=dict(zip(names, map(float, np.sqrt(np.diag(star))), strict=True)))
            _update(disc, c, attr=False)
            if proj.get("sd_sampled"):
                proj["widening"] = {k: disc["sd"][k] / proj["sd_sampled"][k] if proj["sd_sampled"][k] > 0
                                    else math.nan for k in names}
            if evident:
                done["model_error"] = c
        e = "E" if "E" in names else next((n for n in names if base_name(n) == "E"), None)
        after = {"white": _analysis_record(names, result.estimate, result.covariance)}
        if "model_error" in done:
            after["model_error"] = _analysis_record(names, disc["estimate"], np.asarray(disc["covariance"]))
        extra["reference_data"] = {
            "references": [r.label for r in data],
            "how": ("the tests' least squares with the references' rows (inference/references/"
                    "problem.py), from the optimum of the tests' quadratic form with them "
                    "(condition.py); under model error the test whitened by the working covariance, "
                    "the kernels' sandwich carried over (several tests, or target l2: the quadratic "
                    "form)"),
            "note": ("estimate, sd, err, covariance, correlation and delta_tilde of fit.json (and of "
                     "its discrepancy block), and modulus_at, hold the references; the residuals, "
                     "sigma0, the discrepancy's hyperparameters and spectrum_exponent are the tests' "
                     "alone"),
            "without": {k: v for k, v in without.items() if k in done},
            "E": {k: _moved(without[k], after[k], e) for k in after if e is not None},
            "iterations": {k: v.iterations for k, v in done.items()},
            "converged": {k: v.converged for k, v in done.items()},
            "sensitivities": _sensitivities(data, names, result.estimate, name_of, fixed, cfg),
        }
    final = ((disc["estimate"], np.asarray(disc["covariance"], dtype=float), "generalized")
             if evident else (result.estimate, result.covariance, "white"))
    extra["reference_moduli"] = [_linear_entry(ref, names, *final, name_of, fixed, cfg) for ref in refs]
    result.references = extra
    result.reference_lines = console_lines(extra)


def _sensitivities(refs, names, estimate, name_of, fixed, cfg) -> dict[str, Any]:
    """The normalised sensitivities X̃_j = β_j ∂g/∂β_j (eq. 37) of each data reference's shown
    element, MPa, at the estimate with the references."""
    out = {}
    for ref in refs:
        _, X, _ = stacked([ref], {**fixed, **estimate}, names, name_of, fixed, cfg.model.modes,
                          cfg.model.decades)
        row = X[ref.headline] * np.array([float(estimate[k]) for k in names])
        out[ref.label] = {"at": ref.where(), **dict(zip(names, map(float, row), strict=True))}
    return out


def _linear_entry(ref: Reference, names: list[str], estimate: Mapping[str, float], covariance: np.ndarray,
                  how: str, name_of, fixed: Mapping[str, float], cfg: Config) -> dict[str, Any]:
    e = _e_of(ref, name_of)
    e_stats = ({"mean": float(estimate[e]), "sd": float(np.sqrt(covariance[names.index(e), names.index(e)]))}
               if e in names else {"mean": float(fixed.get("E", math.nan)), "sd": 0.0})
    point = reference_values(ref, estimate, names, name_of, fixed)
    if not ref.predictable:
        return entry(ref, None, e_stats, point, cfg.model.decades)
    _, X, _ = stacked([ref], {**fixed, **estimate}, names, name_of, fixed, cfg.model.modes,
                      cfg.model.decades)
    g = predict(ref, point, cfg.model.modes, cfg.model.decades)
    return entry(ref, compare.linearized(g, X, covariance, how), e_stats, point, cfg.model.decades)


def entries_from_fit(cfg: Config, fit: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The linearized entries of the config's references from a fit.json as written (its analysis
    under model error when it found evidence of it, else the white one), without fitting again: for
    a report whose config's references are not those of its outputs."""
    refs = references_of(cfg)
    names = list(fit.get("parameters") or [])
    if not refs or not names or fit.get("covariance") is None:
        return []
    disc = fit.get("discrepancy") or {}
    evident = bool(disc.get("estimate") and disc.get("covariance") is not None and disc.get("evidence", True))
    src, how = (disc, "generalized") if evident else (fit, "white")
    held = {k: float(v["value"]) for k, v in ((fit.get("identifiability") or {}).get("held") or {}).items()}
    fixed = {**cfg.fixed_values, **held, **{k: float(v) for k, v in (fit.get("fixed") or {}).items()}}
    name_of = name_function(cfg, not fit.get("joint"))
    return [_linear_entry(ref, names, {k: float(v) for k, v in src["estimate"].items()},
                          np.asarray(src["covariance"], dtype=float), how, name_of, fixed, cfg)
            for ref in refs]
