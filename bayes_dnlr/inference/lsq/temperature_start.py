"""Tests at several temperatures in one fit: each test alone, then the start of the joint fit.

A test at one constant temperature cannot tell its temperature law's parameters (Ea; C1, C2) from
tau_max: a_T only multiplies the spectrum's time scale. So each test is first fitted alone with the
law's parameters held at NOMINAL values; its tau_max (the reference state's under that law) times
a_T(T) at the nominal values is the time scale the test sees, τ_T, whatever the nominal values.
Across the temperatures, ln τ_T = ln τ_ref + ln a_T(T): for Arrhenius a line in 1/T, whose slope is
Ea (the joint fit's start), for WLF the nominal (universal) constants with the mean ln τ_ref.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.layout import test_of
from bayes_dnlr.model.shift import GAS_CONSTANT, KELVIN, log_temperature_shift
from bayes_dnlr.vocabulary import SHIFT_LAW_PARAMETERS, base_name

# the temperature law's parameters of a test fitted alone: an Arrhenius Ea typical of a polymer's
# secondary relaxation, and the WLF "universal" constants (Williams, Landel and Ferry 1955)
NOMINAL = {"Ea": 100.0, "C1": 17.44, "C2": 51.6}


def constant_temperature(test) -> float | None:
    """The test's temperature when it is one number (°C), else None (a column read per row)."""
    t = getattr(test, "temperature", None)
    return None if t is None or np.ndim(t) else float(t)


def alone(view: Config, test) -> Config:
    """The config of a test fitted alone: its temperature law's free parameters held at NOMINAL
    when its temperature is constant (alone, they have no effect but through tau_max), and the
    prior boxes of its time constants moved by a_T at those values, so that the box the config
    gives holds the test's own time scale τ_T = tau_max a_T, whatever the nominal law."""
    law = view.model.shift.temperature
    T = constant_temperature(test)
    if law == "none" or T is None:
        return view
    hold = {k: NOMINAL[k] for k in SHIFT_LAW_PARAMETERS[law] if k in view.free_parameters}
    if not hold:
        return view
    a = math.exp(log_temperature_shift(T, law, view.model.shift.reference_temperature,
                                       **{**{k: view.fixed_values.get(k) for k in NOMINAL}, **hold}))
    params = dict(view.with_holds(hold).parameters)
    for k in ("tau_max", "tau_max_R"):
        spec = params.get(k)
        if spec is not None and not spec.fixed:
            params[k] = spec.model_copy(update={
                key: getattr(spec, key) / a for key in ("low", "high") if getattr(spec, key)})
    return view.model_copy(update={"parameters": params})


def time_scale(view: Config, test, fixed: Mapping[str, float], tau: float) -> float:
    """τ_T: a test's reference tau_max times a_T at its temperature and ``fixed`` law parameters."""
    s = view.model.shift
    T = constant_temperature(test)
    if s.temperature == "none" or T is None:
        return tau
    return tau * math.exp(log_temperature_shift(T, s.temperature, s.reference_temperature,
                                                **{k: fixed.get(k) for k in ("Ea", "C1", "C2")}))


def joint_start(cfg: Config, start: dict[str, float], singles: Mapping[str, Any],
                tests: Mapping[str, Any]) -> dict[str, float]:
    """The joint fit's start with the temperature law's parameters and a shared tau_max placed from
    the tests' own time scales τ_T (``alone``); ``start`` as pooled from the single fits."""
    s = cfg.model.shift
    law_names = SHIFT_LAW_PARAMETERS.get(s.temperature, ())
    if s.temperature == "none" or not any(k in start for k in law_names):
        return start
    temps, log_tau = [], []
    for t, r in singles.items():
        T = constant_temperature(tests[t])
        tau = r.estimate.get("tau_max")
        if T is None or tau is None:
            continue
        temps.append(T)
        log_tau.append(math.log(time_scale(cfg.for_test(t), tests[t], r.fixed, float(tau))))
    if len(set(temps)) < 2:
        return start
    out = dict(start)
    x = 1000.0 / GAS_CONSTANT * (1.0 / (np.array(temps) + KELVIN) - 1.0 / (s.reference_temperature + KELVIN))
    y = np.array(log_tau)
    if s.temperature == "arrhenius":
        slope, intercept = np.polyfit(x, y, 1)
        lo, hi = cfg.parameters["Ea"].bounds()
        out["Ea"] = float(np.clip(slope, lo, hi)) if "Ea" in out else out.get("Ea")
        ea = out.get("Ea", cfg.fixed_values.get("Ea"))
        ref = float(np.mean(y - x * ea))
    else:
        fixed = {k: out.get(k, cfg.fixed_values.get(k, NOMINAL[k])) for k in ("C1", "C2")}
        for k in ("C1", "C2"):
            if k in out:
                out[k] = fixed[k] = NOMINAL[k]
        ref = float(np.mean([ly - log_temperature_shift(T, "wlf", s.reference_temperature, **fixed)
                             for T, ly in zip(temps, y, strict=True)]))
    for name in out:
        if base_name(name) == "tau_max" and test_of(name) is None:
            out[name] = math.exp(ref)
    return out
