"""The ``modulus_at`` blocks of fit.json and summary.json: each test's E(t) from the one estimator
(inference/modulus_estimate.py), with the draws of its source, its predictive band and its checks
gathered here from the run, and its trust decided by the verdict's words (runs/verdict.py).

- ``fit_rows``: a test's fit (fit.json, or one of a joint run's ``single_fits``): its Laplace draws,
  their band and start check, the bounds it sits on, whether its likelihood matches its residuals,
  its optimiser's convergence. The runs' `consistency` reads the same rows at the times every test
  resolves.
- ``posterior_block``: the chain's kept draws, the run's posterior bands, the bound check's
  refits, E(t)'s prior sensitivity, the noise-model check and the stopping rule.

A cyclic test gets one analysis, on its configured window: its E(t), its E and its verdict come
from the same fit or posterior (docs/model-form.md, "Loading-unloading cycles").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.checks import bounds as bound_rules
from bayes_dnlr.inference.checks.band import Band
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.modulus_estimate import (
    MODULUS_PARAMETERS,
    AtTemperature,
    BoundRefit,
    LocalEstimate,
    ModulusEstimate,
    Source,
    estimate,
    exponent_spread,
    fit_source,
    modulus_draws,
    posterior_source,
    stress_pull,
)
from bayes_dnlr.inference.modulus_window import X_LINEAR, ResolvedWindow, linear_range, times_for
from bayes_dnlr.inference.posterior.priors import LOG_SPACE_KINDS
from bayes_dnlr.runs.bands import N_CURVES, fit_noise, test_band
from bayes_dnlr.runs.testset import TestSet
from bayes_dnlr.runs.verdict import modulus_reasons
from bayes_dnlr.vocabulary import SHIFT_LAW_PARAMETERS

LOCAL_FACTOR = 10.0      # E(t) at t is measured by the slope over about a decade of time after t
LOCAL_MIN_SAMPLES = 12   # a local fit needs this many samples ...
LOCAL_MAX_SHARE = 0.5    # ... and leaves out at least half of the window (else it is the window)
LOCAL_STARTS = 2         # a small problem near the whole window's optimum
LOCAL_FREE = ("E", "tau_max")   # the start of a test identifies these; the rest held at the fit's


def has_modulus(view: Config) -> bool:
    """Whether a test's model has an E(t): E and tau_max among its parameters."""
    return {"E", "tau_max"} <= set(view.parameters)


def judged(result: ModulusEstimate, who: str) -> ModulusEstimate:
    """The rows with their trust: the verdict's reasons, trusted when there are none."""
    for row in result.rows:
        row["trust_reasons"] = modulus_reasons(row, who)
        row["trust"] = not row["trust_reasons"]
    return result


def at_temperature(view: Config, data) -> AtTemperature:
    """The test's temperature for its E(t) (a column's mean where it is read per row), with the
    model's temperature law; the reference state's when the model has none."""
    s = view.model.shift
    t = getattr(data, "temperature", None)
    if s.temperature == "none" or t is None:
        return AtTemperature()
    return AtTemperature(s.temperature, s.reference_temperature, float(np.mean(t)))


def resolved(view: Config, data, source: Source, fit: Mapping[str, Any]
             ) -> tuple[list[float], str, ResolvedWindow, dict[str, float] | None]:
    """A test's E(t) times, why, and the window it resolves, ended where the test leaves its linear
    range (inference/modulus_window.py ``linear_range``): at the model's sigma_s with a stress
    shift, else at the one the stress score points to where the data ask for a stress shift;
    with that range's end for the words (None when the window was not ended there)."""
    times, why, w = times_for(view, data)
    sigma_s, whose = None, ""
    if view.model.shift.stress != "none":
        sigma_s, whose = source.point().get("sigma_s"), "the model's"
    else:
        pull = stress_pull(fit, source.under_model_error)
        if pull is not None and pull.asked and pull.sigma_s:
            sigma_s = pull.sigma_s
            whose = (f"the one the stress score points to (z = {pull.z:.1f}); the model has no "
                     "stress shift")
    if sigma_s is None:
        return times, why, w, None
    ended = linear_range(w, data.time, data.stress, np.asarray(data.window)[: data.model_end],
                         float(sigma_s), whose)
    if ended.longest == w.longest:
        return times, why, w, None
    return times, why, ended, {"time": ended.longest, "stress": X_LINEAR * float(sigma_s),
                               "sigma_s": float(sigma_s), "model_shift": view.model.shift.stress != "none"}


def _rows(view: Config, data, source: Source, band: Band | None, fit: Mapping[str, Any],
          refits: Sequence[BoundRefit], noise_ok: bool, who: str,
          times: Sequence[float] | None = None) -> ModulusEstimate:
    chosen, why, window, linear = resolved(view, data, source, fit)
    if times is not None:
        chosen, why = list(times), "times every test of the run resolves"
    spread = exponent_spread(fit, source.under_model_error)
    local = _stored_local(fit, chosen) if source.kind == "posterior" else None
    if local is None:
        local = local_estimates(view, data, fit, chosen, window.origin)
    found = estimate(source, chosen, why, window, band, spread, refits, noise_ok, view.model.modes,
                     view.model.decades, local, at_temperature(view, data),
                     stress_pull(fit, source.under_model_error))
    if linear is not None:
        for row in found.rows:
            row["linear_range"] = linear
    return judged(found, who)


def _first_turn(data) -> float:
    """The time of the first peak the window runs past (the one rule, data/cycles.py; inf: the
    test never turns there)."""
    k = data.first_peak
    return math.inf if k is None else float(np.asarray(data.time, dtype=float)[k])


def stress_refit(view: Config, data, fit: Mapping[str, Any]) -> dict[str, Any] | None:
    """Where the data ask a stress-blind fit for a stress shift (its score test), the same test
    fitted with it (``model.shift.stress: eyring``, the parameters the fit held held): {estimate
    (of the generalized analysis under model error), sigma_s, converged}, or {error} when that fit
    fails. None where the data do not ask for it."""
    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.inference.lsq.run_fit import fit_run

    pull = stress_pull(fit, under_model_error(fit))
    if pull is None or not pull.asked or not has_modulus(view):
        return None
    shifted = fit_view(view, fit).with_shift(stress="eyring")
    try:
        again = fit_run(shifted, {view.name: data}, plain=True).to_dict()
    except BayesDnlrError as err:
        return {"error": str(err)}
    estimate_ = analysis(again)[0]
    return {"estimate": estimate_, "sigma_s": estimate_.get("sigma_s"),
            "converged": bool(again.get("converged"))}


def _stored_local(fit: Mapping[str, Any], times: Sequence[float]) -> dict[float, LocalEstimate] | None:
    """The local fits that fit.json's E(t) made at these times (None unless it made them at every
    one): a posterior reads them rather than fit again."""
    rows = {float(r["t"]): r for r in fit.get("modulus_at") or [] if isinstance(r, Mapping)}
    if not all(float(t) in rows for t in times):
        return None
    out = {}
    for t in times:
        c = (rows[float(t)].get("checks") or {}).get("local")
        if c:
            out[float(t)] = LocalEstimate(c["local_mean"], c["local_sd"], c["window_end"], c["time_max"])
    return out


def local_estimates(view: Config, data, fit: Mapping[str, Any], times: Sequence[float],
                    origin: float) -> dict[float, LocalEstimate]:
    """E(t) of a fit on the start of the test alone, up to LOCAL_FACTOR × t after the loading
    began, for each time whose local window holds at least LOCAL_MIN_SAMPLES samples and at most
    LOCAL_MAX_SHARE of the window: E and tau_max free, the other parameters held at the fit's
    estimate, the same noise model (the generalized analysis under model error)."""
    from dataclasses import replace

    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.inference.lsq.run_fit import fit_run

    if not fit.get("estimate"):
        return {}
    estimate_ = analysis(fit)[0]
    held = {k: float(v) for k, v in estimate_.items() if k in view.free_parameters and k not in LOCAL_FREE}
    local_view = fit_view(view, fit).with_holds(held)
    local_view = local_view.model_copy(update={"fit": local_view.fit.model_copy(
        update={"multistart": min(local_view.fit.multistart, LOCAL_STARTS)})})
    window = np.asarray(data.window, dtype=bool)
    time = np.asarray(data.time, dtype=float)
    n = int(window[: data.model_end].sum())
    first_turn = _first_turn(data)
    out: dict[float, LocalEstimate] = {}
    sources: dict[int, Source | None] = {}
    for t in times:
        # the start of the test: a decade of time after t, within the first loading of cycles
        end = min(origin + LOCAL_FACTOR * float(t), first_turn)
        mask = window & (time <= end)
        k = int(mask[: data.model_end].sum())
        if k < LOCAL_MIN_SAMPLES or k > LOCAL_MAX_SHARE * n:
            continue
        if k not in sources:
            try:
                again = fit_run(local_view, {view.name: replace(data, window=mask)}, plain=True)
                sources[k] = _source_of_fit(local_view, again.to_dict())
            except BayesDnlrError:
                sources[k] = None
        if sources[k] is not None:
            values = modulus_draws(sources[k].columns(at_temperature(view, data)), [t],
                                   view.model.modes, view.model.decades)
            out[float(t)] = LocalEstimate(float(values.mean()), float(values.std(ddof=1)),
                                          end - origin, end)
    return out


# ---------------------------------------------------------------- a fit

def under_model_error(fit: Mapping[str, Any]) -> bool:
    """Whether a test's fit reports its generalized analysis (model error found, and its estimate
    and covariance there)."""
    d = fit.get("discrepancy") or {}
    return bool(d.get("evidence") and d.get("estimate") and d.get("covariance") is not None)


def fit_view(view: Config, fit: Mapping[str, Any]) -> Config:
    """The test's config with the parameters its fit held fixed there: those its window cannot
    identify (identifiability), and those a test alone holds (its temperature law's,
    inference/lsq/temperature_start.py)."""
    held = {k: v["value"] for k, v in ((fit.get("identifiability") or {}).get("held") or {}).items()}
    held.update({k: v for k, v in (fit.get("fixed") or {}).items()
                 if k in view.free_parameters and k not in held})
    return view.with_holds(held) if held else view


def fit_rows(view: Config, data, fit: Mapping[str, Any], who: str = "",
             times: Sequence[float] | None = None) -> ModulusEstimate | None:
    """E(t) of a test's fit (fit.json's layout of one test), at its times or ``times``."""
    if not has_modulus(view) or not fit.get("estimate"):
        return None
    view = fit_view(view, fit)
    source = _source_of_fit(view, fit)
    band = test_band(view, data, {k: v[:N_CURVES] for k, v in source.draws.items()},
                     fit_noise(view, data, fit, source.under_model_error))
    white = bool((fit.get("residuals") or {}).get("white", True))
    return _rows(view, data, source, band, fit, _fit_refits(view, data, fit, analysis(fit)[0]),
                 source.under_model_error or white, who, times)


def analysis(fit: Mapping[str, Any]) -> tuple[dict[str, float], np.ndarray | None, list[str], bool]:
    """A fit's estimate, covariance and their names: of its generalized analysis under model
    error, else of the white one; and whether it is the generalized one."""
    under = under_model_error(fit)
    d = fit.get("discrepancy") or {}
    estimate_ = {**fit["estimate"], **(d.get("estimate") or {})} if under else dict(fit["estimate"])
    cov = d.get("covariance") if under else fit.get("covariance")
    return (estimate_, None if cov is None else np.asarray(cov, dtype=float),
            list(fit.get("parameters") or fit["estimate"]), under)


def _source_of_fit(view: Config, fit: Mapping[str, Any]) -> Source:
    """A fit's Laplace draws (``view``: the test's config with the fit's holds)."""
    estimate_, cov, names, under = analysis(fit)
    return fit_source(estimate_, cov, names, view.fixed_values, bool(fit.get("converged", True)),
                      under)


def _fit_refits(view: Config, data, fit: Mapping[str, Any],
                estimate_: Mapping[str, float]) -> list[BoundRefit]:
    """The parameters of E(t) whose fit sits on a bound of its prior box (not a physical limit),
    each refitted with that bound widened ×10 (the bound check's rule, runs/checks.py)."""
    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.inference.lsq.run_fit import fit_run
    from bayes_dnlr.inference.lsq.sensitivity import bound_side

    out = []
    for k in MODULUS_PARAMETERS:
        if k not in view.free_parameters or k not in estimate_:
            continue
        spec = view.parameters[k]
        low, high = spec.bounds()
        # bound_side says "lower"/"upper"; the bound check's rules (physical_limit, widened) "low"/"high"
        side = {"lower": "low", "upper": "high"}.get(bound_side(float(estimate_[k]), low, high))
        if side is None or bound_rules.physical_limit(side, low if side == "low" else high):
            continue
        lo, hi = bound_rules.widened(low, high, side, spec.prior in LOG_SPACE_KINDS)
        wide = view.model_copy(update={"parameters": {
            **view.parameters, k: spec.model_copy(update={"low": lo, "high": hi})}})
        try:
            again = fit_run(wide, {view.name: data}, plain=True).to_dict()
        except BayesDnlrError:
            continue
        after = again.get("estimate") or {}
        if under_model_error(again):
            after = {**after, **again["discrepancy"]["estimate"]}
        out.append(BoundRefit(k, {**view.fixed_values, **estimate_},
                              {**view.fixed_values, **after}))
    return out


# ---------------------------------------------------------------- a posterior

def uses_discrepancy(checks: Mapping[str, Any], test: str) -> bool:
    """Whether a test's posterior used the model discrepancy (its noise-model check says)."""
    return ((checks.get("noise_model") or {}).get(test) or {}).get("likelihood") == "discrepancy"


def posterior_refits(bound_limited: Sequence[Mapping[str, Any]], layout: Layout, test: str,
                      view: Config) -> list[BoundRefit]:
    """The bound check's refits (runs/checks.py) in the test's own names, with the temperature
    law's parameters: E(t) at a test's temperature needs a_T of each refit."""
    keys = (*MODULUS_PARAMETERS, *SHIFT_LAW_PARAMETERS[view.model.shift.temperature])
    out = []
    for b in bound_limited:
        est = b.get("estimates")
        if not est:
            continue
        before, after = ({k: v for k in keys
                          if (v := e.get(layout.name(k, test), view.fixed_values.get(k))) is not None}
                         for e in (est["before"], est["after"]))
        if "E" in before and "tau_max" in before and "E" in after and "tau_max" in after:
            out.append(BoundRefit(b["parameter"], before, after))
    return out


def posterior_sources(cfg: Config, layout: Layout, draws: np.ndarray, names: list[str],
                      checks: Mapping[str, Any], log_prior: np.ndarray | None,
                      converged: bool) -> dict[str, Source]:
    """Each test's posterior draws under its own parameter names (tests with an E(t) only)."""
    flat = draws.reshape(-1, draws.shape[-1])
    out = {}
    for test in layout.tests:
        view = cfg.for_test(test)
        if has_modulus(view):
            drawn = {k: flat[:, names.index(layout.name(k, test))] for k in view.parameters
                     if layout.name(k, test) in names}
            out[test] = posterior_source(drawn, view.fixed_values, converged, log_prior,
                                         uses_discrepancy(checks, test))
    return out


def posterior_block(cfg: Config, tests: TestSet, layout: Layout, draws: np.ndarray,
                    names: list[str], bands: Mapping[str, Band], checks: Mapping[str, Any],
                    log_prior: np.ndarray | None, converged: bool,
                    fit: Mapping[str, Any]) -> tuple[Any, Any]:
    """The ``modulus_at`` of summary.json (per test, a list of {t, mean, sd, median, hdi_90, source,
    resolved, why, checks, trust, trust_reasons}; a run with one test gives its list, a run with
    several {"tests": {name: list}}) and ``modulus_curve`` (per test, what the report draws)."""
    per_test: dict[str, list[dict]] = {}
    curves: dict[str, dict] = {}
    for test, source in posterior_sources(cfg, layout, draws, names, checks, log_prior,
                                          converged).items():
        view = cfg.for_test(test)
        own = fit if layout.plain else (fit.get("single_fits") or {}).get(test) or {}
        noise_ok = ((checks.get("noise_model") or {}).get(test) or {}).get("ok", True)
        found = _rows(view, tests.tests[test], source, bands.get(test), own,
                      posterior_refits(checks.get("bound_limited") or [], layout, test, view),
                      noise_ok, "" if layout.plain else f"{test}: ")
        per_test[test], curves[test] = found.rows, found.curve
    if layout.plain:
        return next(iter(per_test.values()), []), next(iter(curves.values()), None)
    return {"tests": per_test}, curves

