"""The ``noise:`` section: the measurement noise σ0 and the model discrepancy δ (docs/model-error.md)."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import Discriminator, Field, Tag, field_validator, model_validator

from bayes_dnlr.config.base import Strict
from bayes_dnlr.config.data_section import Window
from bayes_dnlr.config.parameter_section import ParameterSpec


class BaselineNoise(Strict):
    baseline: Window


class SampledNoise(Strict):
    prior: Literal["half-normal", "log-uniform", "uniform"]
    scale: float | None = Field(default=None, gt=0)
    low: float | None = None
    high: float | None = None

    @model_validator(mode="after")
    def _complete(self) -> SampledNoise:
        if self.prior == "half-normal" and self.scale is None:
            raise ValueError("prior 'half-normal' needs scale")
        if self.prior in ("uniform", "log-uniform") and (self.low is None or self.high is None):
            raise ValueError(f"prior '{self.prior}' needs low and high")
        if self.low is not None and self.high is not None and not self.low < self.high:
            raise ValueError(f"low ({self.low}) must be smaller than high ({self.high})")
        return self


KERNELS = ("auto", "exp", "matern32")
DISCREPANCY_AXES = ("time", "strain")


class DiscrepancyConfig(Strict):
    """The model discrepancy δ: a zero-mean Gaussian process on the residuals (docs/model-error.md).

    amplitude (MPa) and length (s on the time axis, strain on the strain axis) take a prior, or
    ``value:`` to fix them; left out, their priors scale with the test: amplitude half-normal with
    scale 2 × the rms residual, length log-uniform from three sampling steps to the span of the
    window.
    """

    kernel: Literal["auto", "exp", "matern32"] = Field(
        default="auto", description="the model of the error that sets the interval's width: auto "
                                    "weighs exp (Ornstein-Uhlenbeck) and matern32 by their restricted "
                                    "likelihood; the estimate does not depend on it; "
                                    "docs/model-error.md")
    target: Literal["generalized", "l2"] = Field(
        default="generalized", description="what the estimate is: generalized, the model curve closest "
                                           "to the data in the metric of an Ornstein-Uhlenbeck "
                                           "discrepancy; l2, the closest in the plain least-squares "
                                           "metric (the orthogonal discrepancy); docs/model-error.md")
    axis: Literal["time", "strain"] = "time"
    start: Literal["pinned", "stationary"] = Field(
        default="stationary", description="pinned: δ = 0 (and, for matern32, δ' = 0) at the test's first "
                                      "sample, where the specimen is unloaded and the model exact; "
                                      "stationary: δ has its stationary spread everywhere")
    amplitude: ParameterSpec | None = None
    length: ParameterSpec | None = None

    @field_validator("amplitude")
    @classmethod
    def _non_negative(cls, v: ParameterSpec | None) -> ParameterSpec | None:
        if v is None:
            return v
        if v.fixed and not v.value >= 0:  # type: ignore[operator]
            raise ValueError(f"an amplitude is >= 0 MPa, got value {v.value}")
        if not v.fixed and v.bounds()[0] < 0:
            raise ValueError("an amplitude is >= 0 MPa: give the prior low >= 0 (or use half-normal)")
        return v

    @field_validator("length")
    @classmethod
    def _positive(cls, v: ParameterSpec | None) -> ParameterSpec | None:
        if v is None:
            return v
        if v.fixed and not v.value > 0:  # type: ignore[operator]
            raise ValueError(f"a correlation length is > 0, got value {v.value}")
        if not v.fixed and not v.bounds()[0] > 0:
            raise ValueError("a correlation length is > 0: give the prior low > 0 "
                             "(log-uniform is the usual choice)")
        return v


def _sigma0_form(v: Any) -> str:
    """Which form of noise.sigma0 a value is: a mapping with ``baseline`` or a prior, a word, a number."""
    if isinstance(v, dict):
        return "BaselineNoise" if "baseline" in v else "SampledNoise"
    if isinstance(v, BaselineNoise | SampledNoise):
        return type(v).__name__
    return "str" if isinstance(v, str) else "float"


class NoiseConfig(Strict):
    """sigma0: a number (MPa), 'residuals', {baseline: {time_max: ...}} or a prior to sample it.

    discrepancy: the model-error term (on by default: kernel chosen from the data, time axis), or ``none``
    for the white likelihood that assumes the model is exact.
    """

    sigma0: Annotated[
        Annotated[Annotated[float, Field(gt=0)], Tag("float")] | Annotated[Literal["residuals"], Tag("str")]
        | Annotated[BaselineNoise, Tag("BaselineNoise")] | Annotated[SampledNoise, Tag("SampledNoise")],
        Discriminator(_sigma0_form)] = "residuals"

    discrepancy: DiscrepancyConfig | Literal["none"] = Field(default_factory=DiscrepancyConfig)

    @field_validator("discrepancy", mode="before")
    @classmethod
    def _discrepancy_forms(cls, v: Any) -> Any:
        if v is None or v is False or (isinstance(v, str) and v.strip().lower() == "none"):
            return "none"
        if isinstance(v, str):
            raise ValueError(f"unknown form {v!r}; expected none, or a mapping such as {{kernel: "
                             f"exp, axis: time}} (kernels: {', '.join(KERNELS)})")
        return v

    @property
    def has_discrepancy(self) -> bool:
        return isinstance(self.discrepancy, DiscrepancyConfig)

    @field_validator("sigma0", mode="before")
    @classmethod
    def _plain_forms(cls, v: Any) -> Any:
        expected = ("a positive number (MPa), 'residuals', {baseline: {time_max: ...}} "
                    "or a prior such as {prior: half-normal, scale: 5}")
        if isinstance(v, bool) or v is None:
            raise ValueError(f"expected {expected}")
        if isinstance(v, int | float) and not (math.isfinite(v) and v > 0):
            raise ValueError(f"must be a finite number > 0, got {v}; expected {expected}")
        if isinstance(v, str) and v != "residuals":
            raise ValueError(f"unknown form {v!r}; expected {expected}")
        return v
