"""Each test's 90 % predictive band against its data, from parameter draws (the posterior's, or a
fit's Laplace draws), with what the checks read off it: the Jacobian at the draws' median (which
samples carry a quantity's information, inference/checks/band.py) and the start check (the data's
ISO chord against the model curves', inference/checks/start.py)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.checks import predictive
from bayes_dnlr.inference.checks.band import Band
from bayes_dnlr.inference.checks.start import Noise, StartCheck, start_check
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.modulus_window import test_window
from bayes_dnlr.inference.posterior.likelihood import build_model, window_rows
from bayes_dnlr.runs.testset import TestSet
from bayes_dnlr.vocabulary import SPECTRUM_EXPONENT

N_CURVES = 200              # draws pushed through the model for the predictive band


def column(draws: np.ndarray, names: list[str], name: str) -> np.ndarray | None:
    return draws[..., names.index(name)] if name in names else None


@dataclass(frozen=True)
class TestNoise:
    """What the likelihood puts around the model on a test's compared samples: the variance at one
    sample (σ0², plus the discrepancy's amplitude² under model error) and its process, for the
    start check."""

    var: float
    process: Noise


def test_band(view: Config, data, columns: Mapping[str, np.ndarray | float],
              noise: TestNoise) -> Band:
    """One test's band from draws of its parameters (``columns``: each model parameter, (n,) or
    a fixed value), and the Jacobian at their median."""
    model = build_model(view, data)
    rows = window_rows(data)
    n = max((np.size(v) for v in columns.values()), default=1)
    # the spectrum's exponent is no parameter of every model, but moves the curve where it is drawn
    used = model.parameter_names() + [k for k in view.parameters if k == SPECTRUM_EXPONENT]
    full = {k: np.broadcast_to(np.asarray(columns[k] if k in columns else view.fixed_values[k],
                                          dtype=float), (n,)) for k in used}
    # one compiled serial call per draw: a forked batch worker must not start OpenMP threads
    curves = np.array([model.stress({k: float(v[i]) for k, v in full.items()})[rows]
                       for i in range(n)])
    y = np.asarray(data.stress[: data.model_end], dtype=float)[rows]
    inside = predictive.inside_band(y, curves, noise.var)
    time = np.asarray(data.time[: data.model_end], dtype=float)[rows]
    strain = np.asarray(data.strain_input[: data.model_end], dtype=float)[rows]
    point = dict(view.fixed_values)
    point.update({k: float(np.median(v)) for k, v in full.items()})
    X, free = _jacobian(view, data, point, inside.size)
    peak = data.first_peak
    return Band(inside, time, strain, data.relaxation_start, X, free, point,
                _start(data, rows, curves, noise.process, compensated=view.data.toe != "none"),
                None if peak is None else float(data.time[peak]),
                data.turns.within(np.arange(data.model_end)[rows]))


def predictive_bands(cfg: Config, tests: TestSet, layout: Layout, draws: np.ndarray,
                     names: list[str], noise: dict[str, dict], sigma0: dict[str, float],
                     seed: int = 0) -> dict[str, Band]:
    """Each test's posterior predictive band (N_CURVES draws pushed through the model)."""
    flat = draws.reshape(-1, draws.shape[-1])
    pick = np.random.default_rng(seed).choice(flat.shape[0], size=min(N_CURVES, flat.shape[0]),
                                              replace=False)
    flat = flat[np.sort(pick)]
    out = {}
    for t in layout.tests:
        view = cfg.for_test(t)
        columns = {k: flat[:, names.index(layout.name(k, t))] for k in view.parameters
                   if layout.name(k, t) in names}
        out[t] = test_band(view, tests.tests[t], columns,
                           posterior_noise(view, tests.tests[t], noise.get(t) or {}, flat, names,
                                           layout, t, sigma0.get(t, math.nan)))
    return out


def _start(data, rows: slice | np.ndarray, curves: np.ndarray, noise: Noise,
           compensated: bool = False) -> StartCheck | None:
    """The start check of a test whose window begins at its first measured sample: the data's
    ISO chord against the model curves' (inference/checks/start.py); ``compensated``: the test's
    toe was compensated (data.toe)."""
    first = int(getattr(data, "virtual_start", 0))
    rows = np.arange(data.model_end)[rows]
    if rows.size == 0 or int(rows[0]) != first or not math.isfinite(noise.sigma0_sq):
        return None
    time = np.asarray(data.time, dtype=float)[rows]
    # the first loading: up to the hold, or to the first peak of cycles (data/cycles.py)
    loading = time <= data.relaxation_start if data.relaxation_start is not None else np.ones(
        rows.size, dtype=bool)
    peak = data.turns.first_peak_within(rows)
    if peak is not None:
        loading &= rows <= peak
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
                       curves[:, loading] * ratio, noise, time[loading], window.origin,
                       compensated=compensated)


def _process(view: Config, data, var: float, amplitude: float, length: float,
             kernel: str) -> Noise:
    """The likelihood's noise process on a test's compared samples: white with variance ``var``,
    plus the discrepancy (amplitude, length, kernel on its axis) when there is one."""
    if view.noise.discrepancy is None or not (amplitude > 0 and math.isfinite(length) and length > 0):
        return Noise(var)
    spec = view.noise.discrepancy
    rows = window_rows(data)
    axis = np.asarray(data.time if spec.axis == "time" else data.strain_input, dtype=float)
    axis = axis[: data.model_end][rows]
    start = float(axis[0]) if spec.start == "pinned" else None
    return Noise(var, amplitude, length, kernel, axis, start)


def posterior_noise(view: Config, data, summary_noise: Mapping[str, Any], flat: np.ndarray,
                    names: list[str], layout: Layout, test: str, sigma0: float) -> TestNoise:
    """The noise of a test at the posterior: E[σ0²] (the draws', else the fixed σ0), and under the
    discrepancy E[a²] and the median length (the draws', else the summary's fixed values)."""
    s0 = column(flat, names, layout.name("sigma0", test))
    var = float(np.mean(s0**2)) if s0 is not None else float(sigma0) ** 2
    if summary_noise.get("model") != "discrepancy":
        return TestNoise(var, Noise(var))
    amp = column(flat, names, layout.name("disc_amplitude", test))
    length = column(flat, names, layout.name("disc_length", test))
    a2 = (float(np.mean(amp**2)) if amp is not None
          else float((summary_noise.get("amplitude") or {}).get("value") or 0.0) ** 2)
    ell = (float(np.median(length)) if length is not None
           else float((summary_noise.get("length") or {}).get("value") or math.nan))
    return TestNoise(var + a2, _process(view, data, var, math.sqrt(a2), ell,
                                        str(summary_noise.get("kernel") or "exp")))


def fit_noise(view: Config, data, fit: Mapping[str, Any], under_model_error: bool) -> TestNoise:
    """The noise of a test's fit: σ0², and under model error the generalized analysis's σ0 and
    discrepancy amplitude and length (fit.json ``discrepancy.hyperparameters``)."""
    if not under_model_error:
        var = float(fit.get("sigma0", math.nan)) ** 2
        return TestNoise(var, Noise(var))
    d = fit.get("discrepancy") or {}
    h = d.get("hyperparameters") or {}
    var = float(h.get("sigma0", fit.get("sigma0", math.nan))) ** 2
    amp = float(h.get("amplitude") or 0.0)
    return TestNoise(var + amp**2, _process(view, data, var, amp, float(h.get("length") or math.nan),
                                            str(d.get("kernel") or "exp")))


def _jacobian(view: Config, data, point: dict[str, float], n: int) -> tuple[np.ndarray | None, list[str]]:
    """The Jacobian (eq. 22) of a test's free parameters at ``point``, with its columns (X None
    when it does not line up with the compared samples)."""
    from bayes_dnlr.inference.lsq.problem import LsqProblem

    free = view.free_parameters
    X = LsqProblem.for_config(view, data).jacobian(point)
    return (X if X.shape[0] == n else None), free
