"""The ``model:`` and ``parameters:`` sections: the spectrum's size and each parameter's prior or fixed
value (docs/config.md)."""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field, model_validator

from bayes_dnlr.config.base import Strict, Whole


class ModelConfig(Strict):
    modes: Whole = Field(default=50, ge=1, le=1000)
    decades: float = Field(default=6.0, gt=0, le=20)


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
}
# The spectrum's exponent (p_j ∝ tau_j^alpha) is ½, Cunat's universal spectrum (eq. 12), unless
# parameters.alpha is given; this is the prior the docs propose to marginalise it
# (docs/model-form.md: what it costs and buys, measured).
ALPHA_PRIOR: dict[str, Any] = {"prior": "normal", "mean": 0.5, "sd": 0.05, "low": 0.0, "high": 1.0}
