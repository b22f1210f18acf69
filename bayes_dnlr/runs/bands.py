"""Each test's 90 % posterior predictive band against its data, with what the checks read off it:
the Jacobian at the posterior median (which samples carry a quantity's information) and the start
check (the data's ISO chord against the model curves', inference/checks/start.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.checks import predictive
from bayes_dnlr.inference.checks.start import Noise, StartCheck, start_check
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.modulus import test_window
from bayes_dnlr.inference.posterior.likelihood import build_model, window_rows
from bayes_dnlr.runs.testset import TestSet

N_CURVES = 200              # posterior draws pushed through the model for the predictive band


def column(draws: np.ndarray, names: list[str], name: str) -> np.ndarray | None:
    return draws[..., names.index(name)] if name in names else None


def _test_curves(cfg: Config, data, layout: Layout, test: str, flat: np.ndarray,
                 names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(the observed values on the window, the model curves of the draws there)."""
    view = cfg.for_test(test)
    model = build_model(view, data)
    rows = window_rows(data)
    y = np.asarray(data.stress[: data.model_end], dtype=float)[rows]
    used = model.parameter_names()
    columns = {k: flat[:, names.index(layout.name(k, test))] if layout.name(k, test) in names
               else np.full(flat.shape[0], view.fixed_values[k]) for k in used}
    # one compiled serial call per draw: a forked batch worker must not start OpenMP threads
    curves = np.array([model.stress({k: float(v[i]) for k, v in columns.items()})[rows]
                       for i in range(flat.shape[0])])
    return y, curves


def _noise_var(summary_noise: dict[str, Any], flat: np.ndarray, names: list[str], layout: Layout,
               test: str, sigma0: float) -> float:
    """What the likelihood puts around the model at one sample: E[σ0²] (+ E[a²] with model error)."""
    s0 = column(flat, names, layout.name("sigma0", test))
    var = float(np.mean(s0**2)) if s0 is not None else float(sigma0) ** 2
    if summary_noise.get("model") == "discrepancy":
        amp = column(flat, names, layout.name("disc_amplitude", test))
        fixed = (summary_noise.get("amplitude") or {}).get("value") or 0.0
        var += float(np.mean(amp**2)) if amp is not None else float(fixed) ** 2
    return var


@dataclass(frozen=True)
class Band:
    """One test's 90 % posterior predictive band against its data on the window."""

    inside: np.ndarray          # which compared samples lie inside the band
    time: np.ndarray            # their times, s
    strain: np.ndarray          # the strain that drives the model there
    relaxation_start: float | None
    X: np.ndarray | None        # the Jacobian (eq. 22) at the posterior median, rows = samples
    free: list[str]             # its columns
    point: dict[str, float]     # the posterior median (fixed parameters at their values)
    start: StartCheck | None = None   # the data's ISO chord against the model curves'


def predictive_bands(cfg: Config, tests: TestSet, layout: Layout, draws: np.ndarray,
                     names: list[str], noise: dict[str, dict], sigma0: dict[str, float],
                     seed: int = 0) -> dict[str, Band]:
    """Each test's predictive band (N_CURVES draws pushed through the model) and the Jacobian at
    the posterior median, which tells the samples each quantity draws its information from."""
    flat = draws.reshape(-1, draws.shape[-1])
    pick = np.random.default_rng(seed).choice(flat.shape[0], size=min(N_CURVES, flat.shape[0]),
                                              replace=False)
    flat = flat[np.sort(pick)]
    out = {}
    for t in layout.tests:
        data = tests.tests[t]
        y, curves = _test_curves(cfg, data, layout, t, flat, names)
        var = _noise_var(noise.get(t) or {}, flat, names, layout, t, sigma0.get(t, math.nan))
        inside = predictive.inside_band(y, curves, var)
        rows = window_rows(data)
        time = np.asarray(data.time[: data.model_end], dtype=float)[rows]
        strain = np.asarray(data.strain_input[: data.model_end], dtype=float)[rows]
        X, free, point = _jacobian_at_median(cfg, data, layout, t, flat, names, inside.size)
        out[t] = Band(inside, time, strain, data.relaxation_start, X, free, point,
                      _start(cfg, data, t, layout, rows, curves, noise.get(t) or {}, flat, names,
                             sigma0.get(t, math.nan)))
    return out


def _start(cfg: Config, data, test: str, layout: Layout, rows: slice | np.ndarray, curves: np.ndarray,
           summary_noise: dict[str, Any], flat: np.ndarray, names: list[str],
           sigma0: float) -> StartCheck | None:
    """The start check of a test whose window begins at its first measured sample: the data's
    ISO chord against the model curves' (inference/checks/start.py)."""
    first = int(getattr(data, "virtual_start", 0))
    rows = np.arange(data.model_end)[rows]
    noise = _noise(cfg.for_test(test), data, summary_noise, flat, names, layout, test, sigma0)
    if rows.size == 0 or int(rows[0]) != first or not math.isfinite(noise.sigma0_sq):
        return None
    time = np.asarray(data.time, dtype=float)[rows]
    # the first loading: up to the hold, or to the first turning point of cycles
    loading = time <= data.relaxation_start if data.relaxation_start is not None else np.ones(
        rows.size, dtype=bool)
    turns = predictive.turning_points(np.asarray(data.strain_input, dtype=float)[rows])
    if turns:
        loading &= np.arange(rows.size) <= turns[0]
    observed = np.asarray(data.stress, dtype=float)[rows][loading]
    strain = np.asarray(data.strain, dtype=float)[rows][loading]
    nominal = (np.asarray(data.nominal_stress, dtype=float)[rows][loading]
               if data.nominal_stress is not None else observed * np.exp(-strain))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(observed != 0, nominal / observed, np.exp(-strain))
    window = test_window(data)
    if noise.axis is not None:
        noise = replace(noise, axis=noise.axis[loading])
    return start_check(np.asarray(data.nominal_strain, dtype=float)[rows][loading], nominal,
                       curves[:, loading] * ratio, noise, time[loading], window.origin)


def _noise(view: Config, data, summary_noise: dict[str, Any], flat: np.ndarray, names: list[str],
           layout: Layout, test: str, sigma0: float) -> Noise:
    """The likelihood's noise on a test's compared samples, at the posterior: σ0² and the
    discrepancy's process (mean amplitude², median length, its kernel, axis and pinning)."""
    s0 = column(flat, names, layout.name("sigma0", test))
    var = float(np.mean(s0**2)) if s0 is not None else float(sigma0) ** 2
    if summary_noise.get("model") != "discrepancy" or view.noise.discrepancy is None:
        return Noise(var)
    amp = column(flat, names, layout.name("disc_amplitude", test))
    length = column(flat, names, layout.name("disc_length", test))
    a = (math.sqrt(float(np.mean(amp**2))) if amp is not None
         else float((summary_noise.get("amplitude") or {}).get("value") or 0.0))
    ell = (float(np.median(length)) if length is not None
           else float((summary_noise.get("length") or {}).get("value") or math.nan))
    if not (a > 0 and math.isfinite(ell) and ell > 0):
        return Noise(var)
    spec = view.noise.discrepancy
    rows = window_rows(data)
    axis = np.asarray(data.time if spec.axis == "time" else data.strain_input, dtype=float)
    axis = axis[: data.model_end][rows]
    start = float(axis[0]) if spec.start == "pinned" else None
    return Noise(var, a, ell, str(summary_noise.get("kernel") or "exp"), axis, start)


def _jacobian_at_median(cfg: Config, data, layout: Layout, test: str, flat: np.ndarray,
                        names: list[str], n: int) -> tuple[np.ndarray | None, list[str], dict]:
    """The Jacobian (eq. 22) of a test's free parameters at the posterior median, with its columns
    and that point (X None when it does not line up with the compared samples)."""
    from bayes_dnlr.inference.lsq.problem import LsqProblem

    view = cfg.for_test(test)
    free = view.free_parameters
    point = dict(view.fixed_values)
    for k in free:
        name = layout.name(k, test)
        if name in names:
            point[k] = float(np.median(flat[:, names.index(name)]))
    problem = LsqProblem.for_config(view, data)
    X = problem.jacobian(point)
    return (X if X.shape[0] == n else None), free, point



