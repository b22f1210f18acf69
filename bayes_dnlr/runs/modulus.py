"""The ``modulus_at`` block of summary.json: E(t), the relaxation modulus of the identified model
(model/modulus.py), from every kept posterior draw at the run's times, each with a trust of its own.

E(t) inside the times a test resolves is what its data determine; E = E(0) is its extrapolation
through the spectrum's fast end. Its interval carries the one degree of freedom of the spectrum's
shape the package knows, its exponent (``spectrum_spread``: with alpha held at ½, the sd freeing
it would add, linearized). Its trust does not inherit E's flags about the fast end (the score test
of the spectrum's exponent): it rests on checks of where E(t) draws its information
(docs/model-form.md, "E(t), the modulus the data determine"):

- ``inside_window``: t lies inside the times the test resolves (else E(t) is an extrapolation);
- ``band``: the 90 % predictive band holds the samples that carry E(t)'s information (each sample
  weighted by its share of E(t)'s least-squares variance) as a calibrated band would: a weighted
  share below 0.9 − BAND_Z · sqrt(0.09 / n_eff) fails (a one-sided 1 % binomial test, n_eff the
  weights' effective number of samples);
- ``start``: the data's ISO 527-1 chord against the model curves' (inference/checks/start.py), for
  the times up to where the chord is measured and beyond: the model follows the start of the curve;
- ``bounds``: widening a prior bound the posterior piles against moves E(t) by at most SHIFT_SD
  of its posterior sd (the prior box does not decide it);
- ``prior``: E(t)'s own power-scaling sensitivity to the prior is below the package's threshold;
- ``noise_model``: a white likelihood was not used on residuals that are not white;
- ``converged``: the chain reached its stopping rule.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.checks import power_scaling
from bayes_dnlr.inference.checks.predictive import band_floor
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.modulus import (
    MODULUS_PARAMETERS,
    draw_stats,
    gradient,
    information_weights,
    modulus_draws,
    times_for,
)
from bayes_dnlr.model.modulus import relaxation_modulus
from bayes_dnlr.numbers import fmt
from bayes_dnlr.runs.bands import Band
from bayes_dnlr.runs.testset import TestSet
from bayes_dnlr.runs.verdict import SHIFT_SD
from bayes_dnlr.vocabulary import SPECTRUM_EXPONENT, UNIVERSAL_EXPONENT

SHAPE_SEED = 7919       # the draws of the spectrum exponent's spread: the same outputs every time
CURVE_TIMES = 80        # the report's E(t) curve: times and draws
CURVE_DRAWS = 400


def test_columns(cfg: Config, layout: Layout, test: str, draws: np.ndarray,
                 names: list[str]) -> dict[str, np.ndarray | float]:
    """E, G, tau_max and alpha of one test, from the draws (steps, walkers, ndim) or the fixed
    values."""
    view = cfg.for_test(test)
    flat = draws.reshape(-1, draws.shape[-1])
    out: dict[str, np.ndarray | float] = {}
    for k in MODULUS_PARAMETERS:
        name = layout.name(k, test)
        if name in names:
            out[k] = flat[:, names.index(name)]
        elif k in view.fixed_values:
            out[k] = float(view.fixed_values[k])
        elif k == SPECTRUM_EXPONENT:
            out[k] = UNIVERSAL_EXPONENT
        elif k == "G":
            out[k] = 0.0
    return out


def _band_check(band: Band | None, t: float, origin: float) -> dict[str, Any] | None:
    if band is None or band.X is None:
        return None
    g = gradient(band.point, band.free, [t])[0]
    if not np.any(g):
        return None
    w = information_weights(band.X, g)
    share = float(np.sum(w * band.inside))
    n_eff = float(1.0 / np.sum(w**2))
    floor = band_floor(n_eff)
    # where E(t) draws most of its information: the samples holding 90 % of its weight
    order = np.argsort(w)[::-1]
    top = order[: int(np.searchsorted(np.cumsum(w[order]), 0.9)) + 1]
    span = [float(band.time[top].min()) - origin, float(band.time[top].max()) - origin]
    return {"share": share, "n_eff": n_eff, "floor": floor, "ok": share >= floor,
            "information_times": span, "remedy": _window_remedy(band)}


def _window_remedy(band: Band) -> str:
    """What to do when the model misses the data where E(t) is measured: where the test has parts
    the model does not describe (unloading, a long hold), identify on the part it does."""
    from bayes_dnlr.inference.checks.predictive import turning_points

    turns = turning_points(band.strain)
    if turns:
        end = float(band.time[turns[0]])
        return (f"the model does not follow unloading: identify on the first loading, "
                f"data.window: {{time_max: {end:.6g}}} (its peak), where E(t) is measured")
    if band.relaxation_start is not None:
        ramp = float(band.relaxation_start - band.time[0])
        end = float(band.relaxation_start + 10.0 * ramp)
        if end < float(band.time[-1]):
            return (f"one spectrum does not describe the whole hold: identify on the loading and the "
                    f"start of the hold, e.g. data.window: {{time_max: {end:.4g}}} (ten times "
                    "the loading's length), and compare")
    return ("the model's form does not describe the curve where E(t) is measured (docs/model-form.md): "
            "read the residuals there")


def _bound_shift(bound_limited: list[dict], layout: Layout, test: str, t: float, sd: float,
                 cfg: Config) -> dict[str, float]:
    """E(t)'s move, in its posterior sd, when each piled-up bound is widened (the bound check's
    refits)."""
    out = {}
    if not sd > 0:
        return out
    view = cfg.for_test(test)
    for b in bound_limited:
        est = b.get("estimates")
        if not est:
            continue
        values = []
        for side in ("before", "after"):
            e = est[side]
            params = {k: e.get(layout.name(k, test), view.fixed_values.get(k)) for k in
                      MODULUS_PARAMETERS}
            params = {k: (v if v is not None else (UNIVERSAL_EXPONENT if k == SPECTRUM_EXPONENT else 0.0))
                      for k, v in params.items()}
            values.append(float(relaxation_modulus([t], params["E"], params["G"], params["tau_max"],
                                                   params[SPECTRUM_EXPONENT], cfg.model.modes,
                                                   cfg.model.decades)[0]))
        out[b["parameter"]] = (values[1] - values[0]) / sd
    return out


def _reasons(row: dict[str, Any], who: str) -> list[str]:
    """The sentences of the checks that withdraw E(t)'s trust."""
    t = f"E({fmt(row['t'], 3)} s)"
    c = row["checks"]
    out = []
    if not c["inside_window"]:
        lo, hi = row["resolved"]
        out.append(f"{who}{t} lies outside the times the test resolves ({fmt(lo, 3)}-{fmt(hi, 4)} s): "
                   "an extrapolation through the model's spectrum, not a measurement")
    band = c.get("band")
    if band and not band["ok"]:
        lo, hi = band["information_times"]
        out.append(f"{who}the 90 % band holds {100 * band['share']:.0f} % of the samples that carry "
                   f"{t}'s information (t = {fmt(lo, 3)}-{fmt(hi, 3)} s; at least "
                   f"{100 * max(band['floor'], 0):.0f} % expected of a calibrated band): the model "
                   f"misses the data where this modulus is measured; {band.get('remedy') or ''}")
    start = c.get("start")
    if start and start.get("toe"):
        out.append(f"{who}the curve's slope rises over its start ({start['convexity_z']:+.1f} sd): "
                   "a toe (slack, seating), which no relaxing material gives and the model fits as a "
                   f"softer start, so {t} comes out low; compensate it (data.toe: compensate) or "
                   "fix the start (docs/data-input.md)")
    elif start and not start["ok"]:
        out.append(f"{who}the data's {start.get('standard', 'ISO 527-1')} chord "
                   f"({fmt(start['data_chord'])} MPa, measured "
                   f"{fmt(start['times'][0], 2)}-{fmt(start['times'][1], 2)} s into the loading) is "
                   f"{abs(start['z']):.1f} sd from the model's ({fmt(start['model_chord'])} MPa): the "
                   "model does not follow the start of this curve (a preload, a loading it misses)")
    big = {k: v for k, v in (c.get("bounds") or {}).items() if abs(v) > SHIFT_SD}
    if big:
        moves = ", ".join(f"{k} moves it by {v:+.1f} sd" for k, v in big.items())
        out.append(f"{who}the prior box decides {t}: widening the bound of {moves}")
    prior = c.get("prior")
    if prior is not None and prior > power_scaling.SENSITIVE:
        out.append(f"{who}the prior shapes {t} (power-scaling sensitivity {prior:.2f})")
    if c.get("noise_model") is False:
        out.append(f"{who}a white likelihood on residuals that are not white: {t}'s interval ignores "
                   "the model error")
    if not c["converged"]:
        out.append(f"{who}the chain has not converged")
    return out


def spread(values: np.ndarray, added_sd: np.ndarray) -> np.ndarray:
    """E(t) draws (draws, times) with the exponent's spread: each multiplied by exp(σ z), σ the
    added sd over the median, z standard normal (seeded): the sd it adds where it is small, and no
    negative modulus where it is not."""
    rel = np.asarray(added_sd, dtype=float) / np.maximum(np.median(values, axis=0), 1e-300)
    z = np.random.default_rng(SHAPE_SEED).standard_normal(values.shape)
    return values * np.exp(z * rel[None, :])


def uses_discrepancy(checks: Mapping[str, Any], layout: Layout, test: str) -> bool:
    """Whether a test's posterior used the model discrepancy (its noise-model check says)."""
    return ((checks.get("noise_model") or {}).get(test) or {}).get("likelihood") == "discrepancy"


def spectrum_spread(fit: Mapping[str, Any], columns: Mapping[str, Any], times: list[float],
                    discrepancy: bool, modes: int, decades: float) -> dict[str, Any] | None:
    """What freeing the spectrum's exponent adds to E(t), linearized: with alpha held at ½ (eq. 12),
    the data still leave it an sd σ_α (the score test's, under the discrepancy when the posterior
    used it) and E(t) moves by dE(t)/dα along the least-squares path (the other parameters
    re-optimised: fit.json ``spectrum_exponent.derivative``). E(t) gets the sd |dE(t)/dα| σ_α
    added, as a posterior with alpha free and a flat prior would give it. Inside the resolved
    times the data pin E(t) and the slope is small; E = E(0) is where it is large. None when alpha
    is sampled (its draws carry it) or fit.json has no derivative."""
    block = fit.get("spectrum_exponent") or {}
    if block.get("sampled") or not block.get("derivative"):
        return None
    score = ((fit.get("discrepancy") or {}).get("alpha_score") if discrepancy else None) or block.get("score")
    if not score or not (score.get("sd") and np.isfinite(score["sd"])):
        return None
    point = {k: float(np.median(v)) if np.ndim(v) else float(v) for k, v in columns.items()}
    names = list(MODULUS_PARAMETERS)
    g = gradient(point, names, times, modes, decades)
    slope = g[:, names.index(SPECTRUM_EXPONENT)] + sum(
        g[:, names.index(k)] * float(d) for k, d in block["derivative"].items() if k in names)
    return {"slope": slope, "alpha_sd": float(score["sd"]), "added_sd": np.abs(slope) * float(score["sd"]),
            "derivative": dict(block["derivative"])}


def modulus_block(cfg: Config, tests: TestSet, layout: Layout, draws: np.ndarray, names: list[str],
                  bands: Mapping[str, Band], checks: Mapping[str, Any], log_prior: np.ndarray | None,
                  converged: bool, fit: Mapping[str, Any]) -> tuple[Any, Any]:
    """``modulus_at`` of summary.json: per test, a list of {t, mean, sd, median, hdi_90, trust,
    trust_reasons, checks, resolved, why}; a run with one test gives its list, a run with several
    {"tests": {name: list}}. And ``modulus_curve``, E(t)'s quantiles over the resolved times and
    below them, for the report's figure (the report computes no model: ``_curve``)."""
    per_test: dict[str, list[dict]] = {}
    curves: dict[str, dict] = {}
    noise_ok = checks.get("noise_model") or {}
    for test in layout.tests:
        data = tests.tests[test]
        view = cfg.for_test(test)
        if not ({"E", "tau_max"} <= set(view.parameters)):
            continue
        columns = test_columns(cfg, layout, test, draws, names)
        first = first_loading(view, data, columns)
        if first is not None:
            per_test[test], curves[test] = first
            continue
        times, why, window = times_for(view, data)
        values = modulus_draws(columns, times, cfg.model.modes, cfg.model.decades)
        own = fit if layout.plain else (fit.get("single_fits") or {}).get(test) or {}
        shape = spectrum_spread(own, columns, times, uses_discrepancy(checks, layout, test),
                                cfg.model.modes, cfg.model.decades)
        if shape is not None:
            values = spread(values, shape["added_sd"])
        band = bands.get(test)
        start = band.start.to_dict() if band is not None and band.start is not None else None
        rows = []
        for i, t in enumerate(times):
            stats = draw_stats(values[:, i])
            prior = None
            ok = np.isfinite(log_prior) if log_prior is not None else None
            if ok is not None and ok.sum() > 1 and np.ptp(log_prior[ok]) > 0:
                prior = power_scaling.sensitivity({"E(t)": values[ok, i]}, log_prior[ok])["E(t)"]
            row_checks = {
                "inside_window": window.contains(t),
                "band": _band_check(band, t, window.origin),
                "start": start,
                "bounds": _bound_shift(checks.get("bound_limited") or [], layout, test, t,
                                       float(stats["sd"]), cfg),
                "prior": prior,
                "noise_model": (noise_ok.get(test) or {}).get("ok", True),
                "converged": bool(converged),
            }
            row = {"t": float(t), **stats, "resolved": [window.shortest, window.longest],
                   "why": why, "checks": row_checks}
            if shape is not None:
                row["spectrum_exponent"] = {"dE_dalpha": float(shape["slope"][i]),
                                            "alpha_sd": shape["alpha_sd"],
                                            "added_sd": float(shape["added_sd"][i])}
            row["trust_reasons"] = _reasons(row, "" if layout.plain else f"{test}: ")
            row["trust"] = not row["trust_reasons"]
            rows.append(row)
        per_test[test] = rows
        curves[test] = _curve(columns, values, window, cfg.model.modes, cfg.model.decades,
                              shape, times)
    if layout.plain:
        return next(iter(per_test.values()), []), next(iter(curves.values()), None)
    return {"tests": per_test}, curves


def first_loading(view: Config, data, columns: Mapping[str, Any]) -> tuple[list[dict], dict] | None:
    """A cyclic test whose window runs past its first turning point: E(t) from its first loading
    (runs/first_loading.py), each row with the whole window's posterior E(t) beside it
    (``whole_window``) and its trust; None for any other test."""
    from bayes_dnlr.inference.lsq.identify import fit_test
    from bayes_dnlr.runs.first_loading import first_loading_rows, first_peak

    if first_peak(data) is None:
        return None
    found = first_loading_rows(view, data, fit_test, spectrum_spread)
    if found is None:
        return None
    values = modulus_draws(columns, [r["t"] for r in found["rows"]], view.model.modes,
                           view.model.decades)
    for i, row in enumerate(found["rows"]):
        row["whole_window"] = draw_stats(values[:, i])
        row["trust_reasons"] = _reasons(row, "")
        row["trust"] = not row["trust_reasons"]
    return found["rows"], found["curve"]


def _curve(columns: Mapping[str, Any], values: np.ndarray, window, modes: int, decades: float,
           shape: dict | None, times: list[float]) -> dict[str, Any]:
    """E(t)'s 5, 50 and 95 % quantiles on CURVE_TIMES log-spaced times from a hundredth of the
    shortest resolved time to the longest, over CURVE_DRAWS draws (the exponent's spread added
    as for the reported times), and E's median and 90 % HDI: what the report draws."""
    n = np.size(columns["E"])
    pick = np.linspace(0, n - 1, min(CURVE_DRAWS, n)).astype(int)
    sub = {k: (np.asarray(v)[pick] if np.ndim(v) else v) for k, v in columns.items()}
    grid = np.geomspace(min(window.shortest, min(times)) / 100.0, max(window.longest, max(times)),
                        CURVE_TIMES)
    e_t = modulus_draws(sub, grid, modes, decades)
    if shape is not None:
        e_t = spread(e_t, spectrum_spread_on(shape, sub, grid, modes, decades))
    q = np.quantile(e_t, [0.05, 0.5, 0.95], axis=0)
    e = np.asarray(columns["E"], dtype=float).ravel()
    lo, hi = draw_stats(e)["hdi_90"]
    return {"t": grid.tolist(), "q05": q[0].tolist(), "q50": q[1].tolist(), "q95": q[2].tolist(),
            "resolved": [window.shortest, window.longest], "E_median": float(np.median(e)),
            "E_hdi_90": [lo, hi]}


def spectrum_spread_on(shape: dict, columns: Mapping[str, Any], times: np.ndarray, modes: int,
                       decades: float) -> np.ndarray:
    """The exponent's added sd (``spectrum_spread``) at other times, from the same slope of the
    estimate on alpha."""
    point = {k: float(np.median(v)) if np.ndim(v) else float(v) for k, v in columns.items()}
    names = list(MODULUS_PARAMETERS)
    g = gradient(point, names, times, modes, decades)
    slope = g[:, names.index(SPECTRUM_EXPONENT)] + sum(
        g[:, names.index(k)] * float(d) for k, d in shape["derivative"].items() if k in names)
    return np.abs(slope) * shape["alpha_sd"]
