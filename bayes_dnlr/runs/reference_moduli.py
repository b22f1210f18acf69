"""The run's references (``reference_moduli:``, paper Table 4) in its outputs.

- ``fit``: with references in the data (``use: data``) the run's analyses (white, and generalized
  under model error) take them in (inference/references/condition.py) and fit.json keeps what they
  were without them (``reference_data``: E's interval before and after, how far it moved, how much
  it shrank); every reference gets the linearized prediction at its time scale (fit.json
  ``reference_moduli``).
- ``sample``: every reference gets the posterior's prediction from every kept draw (summary.json
  ``reference_moduli``), and the references to check (``use: check``) a line of the verdict when
  they disagree (summary.json ``checks.reference_moduli``, runs/verdict.py).

Each entry of ``reference_moduli`` (fit.json and summary.json): the config's keys (method, value,
sd, frequency or time, temperature, use, note, ...), ``label``, ``at`` (the quantity, e.g.
"E'(5 MHz)"), ``regime``, ``prediction`` {mean, sd, median, hdi_90, how}, ``z`` (the reference
against the prediction, their sd combined), ``discrepancy_pct`` (against the prediction),
``discrepancy_to_E_pct`` (against E, the paper's Table 4), ``E`` {mean, sd}, ``check`` and, for a
sweep, ``points`` (every element) with ``chi2``, ``dof``, ``p_value``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference.layout import joint_name
from bayes_dnlr.inference.lsq.sensitivity import correlation, relative_errors, standard_deviations
from bayes_dnlr.inference.references import compare
from bayes_dnlr.inference.references.condition import (
    Conditioned,
    condition,
    parameter_map,
    physical_to_u,
    stacked,
)
from bayes_dnlr.inference.references.terms import (
    PREDICTED_BY,
    Reference,
    build_references,
    data_references,
    frequency_text,
    gradient,
    predict,
    regime,
)
from bayes_dnlr.numbers import fmt, fmt_at, fmt_sd, pm
from bayes_dnlr.vocabulary import TIME_CONSTANTS, Z90, base_name

MAX_DRAWS = 20000          # the posterior's prediction from at most this many kept draws (evenly spread)
CURVE_DRAWS = 400          # the report's E'(ω), E''(ω) curve: draws and frequencies
CURVE_POINTS = 100
SPEC_KEYS = ("method", "value", "sd", "frequency", "time", "temperature", "use", "note")   # always
OPTIONAL_KEYS = ("relative_sd", "test", "file")                                          # when given


def references_of(cfg: Config) -> list[Reference]:
    """The run's references, or an error naming the entry."""
    try:
        return build_references(cfg)
    except BayesDnlrError:
        raise
    except (OSError, ValueError) as err:
        raise BayesDnlrError(f"reference_moduli: {err}") from None


def name_function(cfg: Config, plain: bool):
    """``Layout.name`` of the run without its layout: a per-test parameter's name carries its test."""
    per = set(cfg.per_test_parameters)
    return lambda k, t: k if plain or k not in per or t is None else joint_name(k, t)


def _values(ref: Reference, estimate: Mapping[str, float], names: Sequence[str], name_of,
            fixed: Mapping[str, float]) -> dict[str, float]:
    out = {}
    for k, g in parameter_map(ref, names, name_of).items():
        if g in estimate:
            out[k] = float(estimate[g])
        elif k in fixed:
            out[k] = float(fixed[k])
    return out


def _is_log(names: Sequence[str]) -> list[bool]:
    return [base_name(k) in TIME_CONSTANTS for k in names]


# ---------------------------------------------------------------- records

def _spec(ref: Reference) -> dict[str, Any]:
    s = ref.spec
    out = {k: getattr(s, k) for k in SPEC_KEYS}
    out.update({k: getattr(s, k) for k in OPTIONAL_KEYS if getattr(s, k, None) is not None})
    out["use"] = ref.use
    if out["sd"] is None and ref.m and math.isfinite(float(ref.sd[0])):
        out["sd"] = float(ref.sd[0])          # from relative_sd
    return {"index": ref.index, "label": ref.label, **out}


def _e_of(ref: Reference, name_of) -> str:
    return name_of("E", ref.test) if ref.test is not None else "E"


def entry(ref: Reference, pred: compare.Prediction | None, e_stats: Mapping[str, float] | None,
          point: Mapping[str, float] | None, decades: float) -> dict[str, Any]:
    """One entry of ``reference_moduli`` (module doc) from the prediction of its elements."""
    out = _spec(ref)
    if ref.sweep:          # a sweep's value and sd: those of the element Table 4 shows
        out["value"] = float(ref.value[ref.headline])
        out["sd"] = float(ref.sd[ref.headline])
    kind, words = regime(ref, point or {"tau_max": math.nan}, decades) if point else ("none", "")
    out.update(at=ref.where() if ref.predictable else "E (no time scale)", regime=kind,
               regime_words=words, notes=list(ref.notes), held_out=ref.use == "check")
    if ref.reading:
        out["reading"] = list(ref.reading)
    e_mean = (e_stats or {}).get("mean")
    i = ref.headline
    value = float(ref.value[i])
    out["E"] = dict(e_stats) if e_stats else None
    out["discrepancy_to_E_pct"] = (100.0 * (value - e_mean) / e_mean) if e_mean else None
    if pred is None or not ref.predictable:
        out.update(prediction=None, z=None, discrepancy_pct=None, check=None)
        return out
    ag = compare.agreement(ref.value, ref.sd, pred, ref.sweep)
    out["prediction"] = {"mean": float(pred.mean[i]), "sd": float(pred.sd[i]),
                         "median": float(pred.median[i]), "hdi_90": [float(x) for x in pred.hdi[i]],
                         "how": pred.how}
    out["z"] = None if not math.isfinite(ag.z[i]) else float(ag.z[i])
    out["discrepancy_pct"] = float(ag.discrepancy_pct[i])
    given_sd = float(ref.sd[i]) if math.isfinite(ref.sd[i]) else None
    combined = math.hypot(given_sd or 0.0, float(pred.sd[i]))
    out["check"] = {
        "held_out": ref.use == "check", "p_value": ag.p_value, "threshold_p": compare.CHECK_P,
        "fired": ag.fired, "ok": None if ag.fired is None else not ag.fired,
        "combined_sd": combined, "chi2": ag.chi2, "dof": ag.dof,
        "words": check_words(ref, out, ag, given_sd),
    }
    if ref.sweep:
        out["points"] = {
            "quantity": [str(q) for q in ref.quantity], "frequency": [float(x) for x in ref.at],
            "value": [float(x) for x in ref.value], "sd": [float(x) for x in ref.sd],
            "mean": [float(x) for x in pred.mean], "pred_sd": [float(x) for x in pred.sd],
            "hdi_90": [[float(a), float(b)] for a, b in pred.hdi],
            "z": [None if not math.isfinite(x) else float(x) for x in ag.z]}
        out.update(chi2=ag.chi2, dof=ag.dof, p_value=ag.p_value)
    return out


def check_words(ref: Reference, rec: Mapping[str, Any], ag: compare.Agreement,
                given_sd: float | None) -> str:
    """The check's sentence: how the reference compares with the model's prediction."""
    p = rec["prediction"]
    who = f"{ref.label} ({ref.method}"
    who += f", {ref.spec.note}" if ref.spec.note else ""
    who += ")"
    role = "held out" if ref.use == "check" else "in the data"
    if ref.sweep:
        n = ref.m
        text = (f"{who}, {role}: the sweep's {n} values against the model's E'(ω), E''(ω): χ² = "
                f"{ag.chi2:.1f} on {ag.dof} (p = {ag.p_value:.2g}); at its highest frequency {ref.where()} "
                f"= {fmt(float(ref.value[ref.headline]))} MPa, the model {pm(p['mean'], p['sd'])} MPa")
    else:
        sd_text = f" ± {fmt_sd(given_sd)}" if given_sd else " (no sd given)"
        text = (f"{who}, {role}: {ref.where()} = {fmt(float(ref.value[0]))}{sd_text} MPa, the model "
                f"{pm(p['mean'], p['sd'])} MPa ({rec['discrepancy_pct']:+.1f} %, z = "
                f"{ag.z[0]:+.1f})")
    if ag.fired and ref.use == "data":
        text += (f": the model does not describe it beside the tensile data (beyond the "
                 f"{100 * (1 - compare.CHECK_P):.0f} % level): E is a compromise between the two, "
                 "not a measurement. The model's spectrum cannot follow both (its shape, a second "
                 "process), or the reference is not of this material or its conditions. Sample the "
                 "spectrum's exponent (parameters.alpha), or hold the reference out (use: check)")
    elif ag.fired:
        text += (f": they disagree beyond the {100 * (1 - compare.CHECK_P):.0f} % interval of their "
                 "combined uncertainty. The model's spectrum does not reach this time scale as the "
                 "material does (another spectrum shape, a second process), or the reference is not "
                 "of this material or its conditions; E's interval does not carry it. Sample the "
                 "spectrum's exponent (parameters.alpha), or give the reference as data (use: data) "
                 "if it is to be trusted")
    elif ag.fired is False:
        text += ": they agree"
    return text


# ---------------------------------------------------------------- fit

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
    return condition(refs, names, _is_log(names), {k: estimate[k] for k in names}, cov_u, fisher_u,
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
        result.covariance, [result.estimate[k] for k in names], _is_log(names)), None, cfg, name_of, fixed)
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
                          [disc["estimate"][k] for k in names], _is_log(names))
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
                jac = np.where(_is_log(names), [c.estimate[k] for k in names], 1.0)
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
    point = _values(ref, estimate, names, name_of, fixed)
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


# ---------------------------------------------------------------- sample

def summary_references(cfg: Config, names: list[str], draws: np.ndarray, plain: bool,
                       fit: Mapping[str, Any] | None = None
                       ) -> tuple[list[dict[str, Any]] | None, dict[str, Any] | None]:
    """summary.json ``reference_moduli``: every reference's prediction from the kept draws
    (steps, walkers, ndim), at most MAX_DRAWS of them; and ``reference_curve``, E'(ω) and E''(ω)
    quantiles for the report's figure. (None, None) without references."""
    refs = references_of(cfg)
    if not refs:
        return None, None
    name_of = name_function(cfg, plain)
    flat = draws.reshape(-1, draws.shape[-1])
    if flat.shape[0] > MAX_DRAWS:
        flat = flat[np.linspace(0, flat.shape[0] - 1, MAX_DRAWS).astype(int)]
    held = {k: float(v["value"]) for k, v in (((fit or {}).get("identifiability") or {}).get("held")
                                               or {}).items()}
    fixed = {**cfg.fixed_values, **held}
    out = []
    first_cols = None
    for ref in refs:
        cols: dict[str, Any] = {}
        for k, g in parameter_map(ref, names, name_of).items():
            if g in names:
                cols[k] = flat[:, names.index(g)]
            elif k in fixed:
                cols[k] = float(fixed[k])
        e = cols.get("E")
        e_stats = (None if e is None else {"mean": float(np.mean(e)), "sd": float(np.std(e, ddof=1))}
                   if np.ndim(e) else {"mean": float(e), "sd": 0.0})
        point = {k: float(np.median(v)) if np.ndim(v) else float(v) for k, v in cols.items()}
        pred = None
        if ref.predictable and {"E", "tau_max"} <= set(cols):
            pred = compare.from_draws(predict(ref, cols, cfg.model.modes, cfg.model.decades))
            first_cols = first_cols or cols
        out.append(entry(ref, pred, e_stats, point, cfg.model.decades))
    curve = None if first_cols is None else _curve(refs, first_cols, cfg)
    return out, curve


def _curve(refs: Sequence[Reference], cols: Mapping[str, Any], cfg: Config) -> dict[str, Any]:
    """E'(ω), E''(ω) quantiles (5, 50, 95 %) over CURVE_DRAWS draws on CURVE_POINTS frequencies from
    well below the references' and the spectrum's to where every mode is frozen; E's median and
    90 % HDI: what the report draws (it computes no model)."""
    from bayes_dnlr.model.modulus import FROZEN, complex_modulus

    n = max(np.size(v) for v in cols.values())
    pick = np.linspace(0, n - 1, min(CURVE_DRAWS, n)).astype(int)
    sub = {k: (np.asarray(v)[pick] if np.ndim(v) else v) for k, v in cols.items()}
    tau = float(np.median(sub["tau_max"]))
    freq = [float(f) for r in refs for q, f in zip(r.quantity, r.at, strict=True)
            if q in ("storage", "loss")]
    freq += [1.0 / (2 * np.pi * float(t)) for r in refs for q, t in zip(r.quantity, r.at, strict=True)
             if q == "relaxation"]
    low = min([0.1 / (2 * np.pi * tau), *(0.3 * f for f in freq)])
    frozen = FROZEN / (2 * np.pi * tau * 10.0 ** (-cfg.model.decades))
    high = max([3.0 * frozen, *(3.0 * f for f in freq)])
    grid = np.geomspace(low, high, CURVE_POINTS)
    storage, loss = complex_modulus(grid, sub["E"], sub.get("G", 0.0), sub["tau_max"],
                                    sub.get("alpha", 0.5), cfg.model.modes, cfg.model.decades)
    qs = np.quantile(np.atleast_2d(storage), [0.05, 0.5, 0.95], axis=0)
    ql = np.quantile(np.atleast_2d(loss), [0.05, 0.5, 0.95], axis=0)
    e = np.asarray(cols["E"], dtype=float).ravel()
    lo, hi = compare.from_draws(e[:, None]).hdi[0]
    return {"frequency": grid.tolist(), "storage": qs.tolist(), "loss": ql.tolist(),
            "E_median": float(np.median(e)), "E_hdi_90": [float(lo), float(hi)],
            "frozen_above": float(frozen)}


def reference_check(entries: Sequence[Mapping[str, Any]] | None) -> dict[str, Any] | None:
    """summary.json ``checks.reference_moduli``: each reference against the posterior's prediction,
    held out (``use: check``) or in the data (``use: data``: does the model describe it beside the
    tests?); ``ok`` false when one fires (it withdraws trust in E's interval, runs/verdict.py)."""
    checked = [e for e in entries or [] if e.get("check") and e["check"].get("fired") is not None]
    if not checked:
        return None
    return {"ok": not any(e["check"]["fired"] for e in checked),
            "entries": [{"label": e["label"], "method": e["method"], "use": e["use"], "at": e["at"],
                         "z": e.get("z"), "p_value": e["check"]["p_value"], "fired": e["check"]["fired"],
                         "words": e["check"]["words"]} for e in checked]}


# ---------------------------------------------------------------- words

def console_lines(block: Mapping[str, Any]) -> list[str]:
    """The ``fit`` console's lines of the references."""
    entries = block.get("reference_moduli") or []
    if not entries:
        return []
    lines = ["", "reference moduli (Table 4; linearized predictions at each time scale):"]
    for e in entries:
        p = e.get("prediction")
        value = e.get("value")
        head = f"  {e['label']} ({e['use']}): {e['at']}"
        if e.get("file"):
            head += f" of the sweep {e['file']}"
        if p is None:
            lines.append(f"{head} = {fmt(value)} MPa; no time scale: {e['discrepancy_to_E_pct']:+.1f} % "
                         "against E" if e.get("discrepancy_to_E_pct") is not None else head)
            continue
        lines.append(f"{head}: reference {fmt(value)} MPa, model {fmt_at(p['mean'], p['sd'])} ± "
                     f"{fmt_sd(p['sd'])} MPa ({p['how']}); z {e['z']:+.2f}, {e['discrepancy_pct']:+.1f} %"
                     + (f"; χ² {e['chi2']:.1f} on {e['dof']}" if e.get("chi2") is not None else ""))
        if e.get("regime") == "frozen":
            lines.append(f"    {e['regime_words']}")
    data = block.get("reference_data")
    if data:
        lines.append(f"  the estimates, sd and Δ̃ above hold the data references "
                     f"({', '.join(data['references'])}); fit.json reference_data.without keeps the "
                     "tests' alone")
        for k, m in (data.get("E") or {}).items():
            if not m:
                continue
            b, a = m["before"], m["after"]
            lines.append(f"  E with the data references ({k}): {pm(b['estimate'], b['sd'])} -> "
                         f"{pm(a['estimate'], a['sd'])} MPa (moved {m['move_sd']:+.2f} sd, "
                         f"{m['move_pct']:+.2f} %; interval ×{m['width_ratio']:.2f})")
    return lines


def summary_lines(entries: Sequence[Mapping[str, Any]] | None) -> list[str]:
    """The ``sample`` console's line of each reference: the posterior's prediction beside it."""
    out = []
    for e in entries or []:
        p = e.get("prediction")
        value = f"{fmt(e['value'])}" + (f" ± {fmt_sd(e['sd'])}" if e.get("sd") else "")
        if p is None:
            against = e.get("discrepancy_to_E_pct")
            out.append(f"reference {e['label']}: {value} MPa, no time scale"
                       + (f" ({against:+.1f} % against E)" if against is not None else ""))
            continue
        check = e.get("check") or {}
        state = ("DISAGREES" if check.get("fired") else "agrees") if check.get("fired") is not None else ""
        out.append(f"reference {e['label']} ({e['use']}): {e['at']} = {value} MPa, posterior "
                   f"{pm(p['mean'], p['sd'])} MPa (z {e['z']:+.2f}, {e['discrepancy_pct']:+.1f} %)"
                   + (f": {state}" if state else ""))
    return out


def short_at(ref: Reference) -> str:
    """The time scale of a reference in a few characters, for tables."""
    i = ref.headline
    if str(ref.quantity[i]) == "relaxation":
        return f"t = {float(ref.at[i]):.3g} s"
    return frequency_text(float(ref.at[i])) if ref.predictable else "—"


__all__ = ["PREDICTED_BY", "console_lines", "entry", "fit_references", "gradient", "reference_check",
           "references_of", "summary_references"]
