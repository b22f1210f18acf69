"""The ``model:`` and ``parameters:`` sections: the spectrum's size and each parameter's prior or fixed
value (docs/config.md)."""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field, model_serializer, model_validator

from bayes_dnlr.config.base import Strict, Whole
from bayes_dnlr.vocabulary import SHIFT_LAW_PARAMETERS


class ShiftConfig(Strict):
    """The shift factor of the relaxation times (model/shift.py; docs/theory.md): each mode relaxes
    in reduced time dψ = dt/(a_T a_σ), its time at the reference state (reference_temperature,
    σ -> 0)."""

    temperature: Literal["arrhenius", "wlf", "none"] = Field(
        default="none", description="a_T: Arrhenius (parameter Ea, kJ/mol) or WLF (C1, C2)")
    reference_temperature: float | None = Field(
        default=None, gt=-273.15, description="°C: where a_T = 1 and tau_max is quoted")
    stress: Literal["eyring", "none"] = Field(
        default="none", description="a_σ = x/sinh x, x = |σ|/sigma_s (parameter sigma_s, MPa)")
    driving: Literal["stress", "peak", "overstress"] = Field(
        default="stress", description="the stress that drives a_σ: the true stress, the largest so "
                                      "far, or the overstress σ − σ^r")

    @model_validator(mode="after")
    def _complete(self) -> ShiftConfig:
        if self.temperature != "none" and self.reference_temperature is None:
            raise ValueError(f"temperature: {self.temperature} needs reference_temperature (°C, "
                             "where a_T = 1 and tau_max is quoted)")
        if self.temperature == "none" and self.reference_temperature is not None:
            raise ValueError("reference_temperature needs a temperature law (temperature: arrhenius "
                             "or wlf)")
        # the default may be written back by a resolved config: only another driving is an error
        if self.stress == "none" and self.driving != "stress":
            raise ValueError("driving needs stress: eyring")
        return self

    @property
    def is_none(self) -> bool:
        return self.temperature == "none" and self.stress == "none"

    @property
    def parameters(self) -> tuple[str, ...]:
        """The shift's parameters (Ea; C1, C2; sigma_s)."""
        return SHIFT_LAW_PARAMETERS[self.temperature] + SHIFT_LAW_PARAMETERS[self.stress]


class ModelConfig(Strict):
    modes: Whole = Field(default=50, ge=1, le=1000)
    decades: float = Field(default=6.0, gt=0, le=20)
    shift: ShiftConfig = Field(default_factory=ShiftConfig)

    @model_serializer(mode="wrap")
    def _without_no_shift(self, handler):
        """No ``shift`` key when there is no shift: a config without one dumps (and digests, so a
        run's identity) as before the key existed."""
        out = handler(self)
        if self.shift.is_none and isinstance(out, dict):
            out.pop("shift", None)
        return out


PriorKind = Literal["uniform", "log-uniform", "normal", "log-normal", "half-normal"]


class ParameterSpec(Strict):
    """A prior for a free parameter, or ``value`` to fix it.

    uniform: low, high. log-uniform: low > 0, high. normal: mean, sd. log-normal: median, sd_log
    (sd of the natural log). half-normal: scale. ``low``/``high`` truncate any of them.
    """

    prior: PriorKind | None = None
    value: float | None = None
    per: Literal["test"] | None = Field(
        default=None, description="with several tests: one parameter per test (tau_max[r5e-3]), "
                                  "else shared by all")
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    sd: float | None = Field(default=None, gt=0)
    median: float | None = Field(default=None, gt=0)
    sd_log: float | None = Field(default=None, gt=0)
    scale: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _complete(self) -> ParameterSpec:
        if self.value is not None:
            others = [k for k in ("prior", "low", "high", "mean", "sd", "median", "sd_log", "scale")
                      if getattr(self, k) is not None]
            if others:
                raise ValueError(
                    f"a fixed parameter (value: {self.value}) takes no prior; remove {others}")
            return self
        if self.prior is None:
            raise ValueError("give a prior (uniform, log-uniform, normal, log-normal, "
                             "half-normal) or a fixed value")
        need = {"uniform": ("low", "high"), "log-uniform": ("low", "high"),
                "normal": ("mean", "sd"), "log-normal": ("median", "sd_log"),
                "half-normal": ("scale",)}[self.prior]
        missing = [k for k in need if getattr(self, k) is None]
        if missing:
            raise ValueError(f"prior '{self.prior}' needs {', '.join(missing)}")
        if self.low is not None and self.high is not None and not self.low < self.high:
            raise ValueError(f"low ({self.low}) must be smaller than high ({self.high})")
        if self.prior in ("log-uniform", "log-normal") and self.low is not None and self.low <= 0:
            raise ValueError(f"prior '{self.prior}' needs low > 0, got {self.low}")
        for k in ("low", "high", "mean"):
            v = getattr(self, k)
            if v is not None and not math.isfinite(v):
                raise ValueError(f"{k} must be finite")
        return self

    @property
    def fixed(self) -> bool:
        return self.value is not None

    @property
    def per_test(self) -> bool:
        return self.per == "test"

    def bounds(self) -> tuple[float, float]:
        """Support of the prior (the truncation where given)."""
        lo = self.low if self.low is not None else -math.inf
        hi = self.high if self.high is not None else math.inf
        if self.prior in ("log-uniform", "log-normal", "half-normal"):
            lo = max(lo, 0.0)
        return lo, hi


DEFAULT_PRIORS: dict[str, dict[str, Any]] = {
    "E": {"prior": "uniform", "low": 100.0, "high": 20000.0},
    "G": {"prior": "uniform", "low": 0.0, "high": 50.0},
    "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 1.0e4},
    "sigma_inf": {"prior": "uniform", "low": 0.0, "high": 500.0},
    "tau_max_R": {"prior": "log-uniform", "low": 0.01, "high": 1.0e5},
    # the shift factor's (model.shift): an activation energy of polymers' relaxations (tens to a
    # few hundred kJ/mol), WLF constants about the universal 17.4 and 51.6 K, an Eyring stress
    # from a fraction of a MPa (strongly nonlinear) to 1000 MPa (no stress shift at all)
    "Ea": {"prior": "uniform", "low": 10.0, "high": 1000.0},
    "C1": {"prior": "uniform", "low": 1.0, "high": 100.0},
    "C2": {"prior": "uniform", "low": 10.0, "high": 1000.0},
    "sigma_s": {"prior": "log-uniform", "low": 0.1, "high": 1000.0},
}
# The spectrum's exponent (p_j ∝ tau_j^alpha) is ½, Cunat's universal spectrum (eq. 12), unless
# parameters.alpha is given; this is the prior the docs propose to marginalise it
# (docs/model-form.md: what it costs and buys, measured).
ALPHA_PRIOR: dict[str, Any] = {"prior": "normal", "mean": 0.5, "sd": 0.05, "low": 0.0, "high": 1.0}
