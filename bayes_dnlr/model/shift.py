"""The shift factor of the relaxation times (paper section 3.1.2, after eq. 14): a(T, σ) = a_T · a_σ.

Each mode relaxes in the reduced time ψ, dψ = dt / (a_T(T) · a_σ(σ)), with its relaxation time
τ_j (eq. 14) at the reference state (T = T_ref, σ → 0). a > 1 slows every mode, a < 1 speeds it.

Temperature (time-temperature superposition), T and T_ref in °C:

- Arrhenius:  ln a_T = (1000 Ea / R) (1/(T + 273.15) − 1/(T_ref + 273.15)),   Ea in kJ/mol;
- WLF:        log10 a_T = −C1 (T − T_ref) / (C2 + T − T_ref),                 C1 (−), C2 (K).

Stress (Eyring): a_σ = x / sinh(x), x = |σ| / sigma_s (sigma_s in MPa): 1 at σ = 0, e^{−x}·2x at
large stress, so a mode at stress σ relaxes sinh(x)/x times faster than at rest.

Plain numpy, no state: the compiled kernel takes ln a_T per step from here and evaluates ln a_σ
itself (the same formula, ``log_stress_shift``). These are the functions other layers share (a
DMA master curve, the E(t) at a test's temperature):

    log_temperature_shift(T, law, reference_temperature, Ea=..., C1=..., C2=...) -> ln a_T
    temperature_shift(...)                                                      -> a_T
    log_stress_shift(sigma, sigma_s)                                            -> ln a_σ
    stress_shift(sigma, sigma_s)                                                -> a_σ
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from bayes_dnlr.vocabulary import SHIFT_LAW_PARAMETERS

GAS_CONSTANT = 8.314462618          # J/(mol K)
KELVIN = 273.15                     # 0 °C in K
LN10 = math.log(10.0)

TemperatureLaw = Literal["arrhenius", "wlf", "none"]
StressLaw = Literal["eyring", "none"]
# which stress drives a_σ (docs/theory.md, "The shift factor"): the current true stress, the largest
# stress so far (held while the stress falls), or the overstress σ − σ^r that the modes carry
Driving = Literal["stress", "peak", "overstress"]
DRIVING_CODE = {"stress": 0, "peak": 1, "overstress": 2}


@dataclass(frozen=True)
class Shift:
    """The shift laws of a model (``model.shift`` of the config; docs/config.md).

    temperature: the law of a_T; reference_temperature (°C): where a_T = 1 and τ_max is quoted.
    stress: the law of a_σ; driving: which stress drives it.
    """

    temperature: TemperatureLaw = "none"
    reference_temperature: float | None = None
    stress: StressLaw = "none"
    driving: Driving = "stress"

    @property
    def is_none(self) -> bool:
        return self.temperature == "none" and self.stress == "none"

    @property
    def parameters(self) -> tuple[str, ...]:
        """The shift's parameters, in the canonical order (Ea; C1, C2; sigma_s)."""
        return SHIFT_LAW_PARAMETERS[self.temperature] + SHIFT_LAW_PARAMETERS[self.stress]


NO_SHIFT = Shift()


def log_temperature_shift(temperature: np.ndarray | float, law: TemperatureLaw,
                          reference_temperature: float | None, Ea: np.ndarray | float | None = None,
                          C1: np.ndarray | float | None = None, C2: np.ndarray | float | None = None
                          ) -> np.ndarray | float:
    """ln a_T at the temperatures ``temperature`` (°C): 0 for ``law`` none or T = T_ref.

    Arrhenius needs Ea (kJ/mol); WLF needs C1 (−) and C2 (K). The arguments broadcast against
    each other (e.g. temperatures (1, m) and Ea (k, 1) give (k, m)); a float for scalars. Below the
    WLF singularity (T − T_ref <= −C2) a_T is not defined: inf there.
    """
    if law == "none":
        return 0.0 if np.ndim(temperature) == 0 else np.zeros(np.shape(temperature))
    if reference_temperature is None:
        raise ValueError(f"a temperature shift ({law}) needs reference_temperature (°C)")
    t = np.asarray(temperature, dtype=float)
    t_ref = float(reference_temperature)
    if law == "arrhenius":
        if Ea is None:
            raise ValueError("the Arrhenius shift needs Ea (kJ/mol)")
        out = (1000.0 * np.asarray(Ea, dtype=float) / GAS_CONSTANT) * (
            1.0 / (t + KELVIN) - 1.0 / (t_ref + KELVIN))
    elif law == "wlf":
        if C1 is None or C2 is None:
            raise ValueError("the WLF shift needs C1 and C2 (K)")
        dt = t - t_ref
        den = np.asarray(C2, dtype=float) + dt
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.where(den > 0, -LN10 * np.asarray(C1, dtype=float) * dt
                           / np.where(den > 0, den, 1.0), np.inf)
    else:
        raise ValueError(f"unknown temperature law {law!r}; expected arrhenius, wlf or none")
    return float(out) if np.ndim(out) == 0 else out


def temperature_shift(temperature: np.ndarray | float, law: TemperatureLaw,
                      reference_temperature: float | None, Ea: float | None = None,
                      C1: float | None = None, C2: float | None = None) -> np.ndarray | float:
    """a_T at the temperatures ``temperature`` (°C) (``log_temperature_shift``, exponentiated)."""
    return np.exp(log_temperature_shift(temperature, law, reference_temperature, Ea, C1, C2))


def log_stress_shift(sigma: np.ndarray | float, sigma_s: float) -> np.ndarray | float:
    """ln a_σ = ln(x / sinh x), x = |σ| / sigma_s: 0 at σ = 0, about ln(2x) − x at large x.

    Written without overflow for any x: ln sinh x = x + ln((1 − e^{−2x})/2); for x < 1e-4 the
    series −x²/6 + x⁴/180 keeps full accuracy. sigma_s = inf gives 0 (no stress shift).
    """
    x = np.abs(np.asarray(sigma, dtype=float)) / float(sigma_s)
    small = x < 1e-4
    xs = np.where(small, 1.0, x)
    with np.errstate(divide="ignore"):
        big = np.log(xs) - xs - np.log1p(-np.exp(-2.0 * xs)) + math.log(2.0)
    out = np.where(small, -x * x / 6.0 + x ** 4 / 180.0, big)
    return float(out) if np.ndim(out) == 0 else out


def stress_shift(sigma: np.ndarray | float, sigma_s: float) -> np.ndarray | float:
    """a_σ = x / sinh(x), x = |σ| / sigma_s (Eyring)."""
    return np.exp(log_stress_shift(sigma, sigma_s))
