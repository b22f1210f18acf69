"""E(t) of a loading-unloading test, taken where the model holds: its first loading.

The relaxed state of eq. 16-17 does not follow unloading (a real film reads about 0 MPa where the
model predicts a compression), and from the second cycle on the model sits below the data: a fit
over the whole history pulls E and the early slope down with it. What a cyclic test determines
about E(t) its first loading holds, and there the model describes it. So where a test's window
runs past its first turning point, its E(t) comes from the first loading alone: the same
least-squares analysis as ``fit`` (the generalized one under model error, the parameters the
window cannot identify held), linearized, with the spectrum exponent's spread (runs/modulus.py)
and the same trust checks on that fit: the band where E(t) draws its information and the start.
The run's posterior, E and its verdict stay the whole window's.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.checks.predictive import band_floor, turning_points
from bayes_dnlr.inference.checks.start import Noise, start_check
from bayes_dnlr.inference.modulus import (
    MODULUS_PARAMETERS,
    gradient,
    information_weights,
    linearized,
    times_for,
)
from bayes_dnlr.runs.modulus_view import FIRST_LOADING
from bayes_dnlr.vocabulary import Z90

FIRST_LOADING_STARTS = 2


def first_peak(data) -> float | None:
    """The time of a test's first turning point inside its window, when the window runs past it
    (None for a test that never turns there)."""
    rows = np.flatnonzero(np.asarray(data.window)[: data.model_end])
    if rows.size < 3 or data.relaxation_start is not None:
        return None
    turns = turning_points(np.asarray(data.strain_input, dtype=float)[rows])
    return float(np.asarray(data.time)[rows[turns[0]]]) if turns else None


def first_loading_rows(cfg: Config, data, fit_test, spread) -> dict[str, Any] | None:
    """E(t) of the first loading of a cyclic test: {rows, curve, peak} in the layout of summary.json's
    ``modulus_at`` entries and ``modulus_curve``; None for a test without unloading in its window.
    ``fit_test``: inference.lsq.identify.fit_test; ``spread``: runs.modulus.spectrum_spread."""
    peak = first_peak(data)
    if peak is None:
        return None
    window = np.asarray(data.window, dtype=bool) & (np.asarray(data.time) <= peak)
    first = replace(data, window=window)
    # two starts spread over the box, not the run's eight: the first loading is a small problem
    # near the whole window's optimum (the whole fit already checked the box)
    cfg = cfg.model_copy(update={"fit": cfg.fit.model_copy(
        update={"multistart": min(cfg.fit.multistart, FIRST_LOADING_STARTS)})})
    result = fit_test(cfg, first)
    fit = result.to_dict()
    d = fit.get("discrepancy") or {}
    model_error = bool(d.get("evidence") and d.get("estimate") and d.get("covariance") is not None)
    estimate = {**fit["estimate"], **(d.get("estimate") or {})} if model_error else dict(fit["estimate"])
    names = list(fit["parameters"])
    cov = np.asarray(d["covariance"] if model_error else fit["covariance"], dtype=float)
    times, why, w = times_for(cfg, first)
    modes, decades = cfg.model.modes, cfg.model.decades
    point = {k: estimate.get(k, cfg.fixed_values.get(k)) for k in MODULUS_PARAMETERS
             if estimate.get(k, cfg.fixed_values.get(k)) is not None}
    shape = spread(fit, point, times, model_error, modes, decades)
    lin = linearized(estimate, cov, names, times, modes, decades)
    band, start = _checks(cfg, first, result, estimate, names, model_error, times, w.origin)
    rows = []
    for i, row in enumerate(lin):
        sd = row["sd"]
        if shape is not None:
            sd = math.hypot(sd, float(shape["added_sd"][i]))
        mean = row["mean"]
        rows.append({
            "t": row["t"], "mean": mean, "sd": sd, "median": mean,
            "hdi_90": [mean - Z90 * sd, mean + Z90 * sd],
            "resolved": [w.shortest, w.longest],
            "why": (f"{why}; from the first loading (to its peak at t = {peak:.6g} s), where the "
                    "model holds: it does not follow unloading"),
            "source": f"{FIRST_LOADING}, " + ("generalized least squares (model error)" if model_error
                                           else "white least squares") + ", linearized",
            "checks": {"inside_window": w.contains(row["t"]), "band": band[i], "start": start,
                       "bounds": {}, "prior": None, "noise_model": True,
                       "converged": bool(result.converged)},
        })
    grid = np.geomspace(min(w.shortest, min(times)) / 100.0, max(w.longest, max(times)), 80)
    g = linearized(estimate, cov, names, list(grid), modes, decades)
    curve = {"t": grid.tolist(), "q05": [r["hdi_90"][0] for r in g], "q50": [r["mean"] for r in g],
             "q95": [r["hdi_90"][1] for r in g], "resolved": [w.shortest, w.longest],
             "E_median": float(estimate["E"]),
             "E_hdi_90": [float(estimate["E"] - Z90 * math.sqrt(cov[names.index("E"), names.index("E")])),
                          float(estimate["E"] + Z90 * math.sqrt(cov[names.index("E"), names.index("E")]))]
             if "E" in names else [float(estimate["E"])] * 2}
    return {"rows": rows, "curve": curve, "peak": peak}


def _checks(cfg: Config, data, result, estimate: dict, names: list[str], model_error: bool,
            times: list[float], origin: float) -> tuple[list[dict | None], dict | None]:
    """The band check of each time and the start check, on the first loading's fit: the residuals
    at its estimate against what its likelihood puts around the model (σ0², and the discrepancy's
    amplitude² under model error), weighted by E(t)'s information."""
    from bayes_dnlr.inference.lsq.problem import LsqProblem

    held = ((result.identifiability or {}).get("held") or {})
    problem = LsqProblem.for_config(cfg.with_holds({k: v["value"] for k, v in held.items()}), data)
    params = problem.params([estimate[k] for k in names])
    residuals = problem.raw_residuals(params)
    X = problem.jacobian(params)
    d = result.discrepancy or {}
    h = d.get("hyperparameters") or {}
    var = float(h.get("sigma0", result.sigma0)) ** 2 if model_error else float(result.sigma0) ** 2
    amp = float(h.get("amplitude") or 0.0) if model_error else 0.0
    # the predictive band of the linearized posterior: the model's spread x_iᵀ Σ x_i beside the
    # noise, as the posterior's band has its draws' spread (runs/bands.py)
    cov = np.asarray(d["covariance"] if model_error else result.covariance, dtype=float)
    spread = np.einsum("ij,jk,ik->i", X, np.nan_to_num(cov), X)
    inside = np.abs(residuals) <= Z90 * np.sqrt(var + amp**2 + np.maximum(spread, 0.0))
    rows = np.flatnonzero(np.asarray(data.window)[: data.model_end])
    time = np.asarray(data.time, dtype=float)[rows]
    bands: list[dict | None] = []
    for t in times:
        gv = gradient(params, names, [t])[0]
        if not np.any(gv):
            bands.append(None)
            continue
        wts = information_weights(X, gv)
        share = float(np.sum(wts * inside))
        n_eff = float(1.0 / np.sum(wts**2))
        order = np.argsort(wts)[::-1]
        top = order[: int(np.searchsorted(np.cumsum(wts[order]), 0.9)) + 1]
        bands.append({"share": share, "n_eff": n_eff, "floor": band_floor(n_eff),
                      "ok": share >= band_floor(n_eff),
                      "information_times": [float(time[top].min() - origin), float(time[top].max() - origin)],
                      "remedy": "the model's form does not describe the first loading where E(t) is "
                                "measured (docs/model-form.md): read the residuals there"})
    fitted = np.asarray(data.stress, dtype=float)[rows] - residuals
    observed = np.asarray(data.stress, dtype=float)[rows]
    strain = np.asarray(data.strain, dtype=float)[rows]
    nominal = (np.asarray(data.nominal_stress, dtype=float)[rows] if data.nominal_stress is not None
               else observed * np.exp(-strain))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(observed != 0, nominal / observed, np.exp(-strain))
    noise = Noise(var)
    if amp > 0 and cfg.noise.discrepancy is not None:
        spec = cfg.noise.discrepancy
        axis = time if spec.axis == "time" else np.asarray(data.strain_input, dtype=float)[rows]
        noise = Noise(var, amp, float(h.get("length") or 1.0), str(d.get("kernel") or "exp"), axis,
                      float(axis[0]) if spec.start == "pinned" else None)
    check = start_check(np.asarray(data.nominal_strain, dtype=float)[rows], nominal,
                        np.vstack([fitted * ratio, fitted * ratio]), noise, time, origin)
    return bands, None if check is None else check.to_dict()

