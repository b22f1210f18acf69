"""The sections that say how to run, not what to fit: ``sampler:``, ``fit:``, ``truth:`` (for
``simulate``), ``crosscheck:`` and ``output:``."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_serializer, model_validator

from bayes_dnlr.config.base import Strict, Whole
from bayes_dnlr.config.parameter_section import ShiftConfig
from bayes_dnlr.vocabulary import (
    PARAMETER_NAMES,
    RELAXATION_PARAMETERS,
    SHIFT_PARAMETERS,
    TENSILE_PARAMETERS,
)


class SamplerConfig(Strict):
    walkers: Whole = Field(default=32, ge=2)
    max_steps: Whole = Field(default=20000, ge=1)
    target_ess: float = Field(default=1000.0, gt=0)
    seed: Whole = Field(default=1, ge=0, lt=2**32, description="numpy's RandomState takes 0 <= seed < 2**32")
    checkpoint_every: Whole = Field(default=100, ge=1)
    moves: Literal["de-snooker", "stretch", "de", "de-plain"] = Field(
        default="de", description="emcee moves; DEMove mixes best here (benchmarks/moves.py); with "
        "the discrepancy's hyperparameters sampled `de` adds the conditional move, `de-plain` does not")
    burn_in_tau: float = Field(default=5.0, ge=0, description="burn-in, in autocorrelation times")
    min_tau_multiple: float = Field(default=50.0, gt=0, description="chain length >= this many tau")
    threads: Whole | None = Field(
        default=None, ge=1, description="threads of the compiled likelihood (walkers in parallel); "
                                         "null: NUMBA_NUM_THREADS lowered to OMP_NUM_THREADS, which "
                                         "also cap a number given here; the chain does not depend on it")


class FitConfig(Strict):
    method: Literal["lm", "gauss-newton"] = "lm"
    multistart: Whole = Field(default=8, ge=0)
    max_iterations: Whole = Field(default=200, ge=1)
    hold_unidentified: bool = Field(
        default=True, description="hold G at 0 where its normalised sensitivity on the window is "
                                  "below 5 % of the largest (paper 4.2, interval I) instead of "
                                  "leaving it to its prior box")


class TruthCorrelated(Strict):
    """A smooth correlated error added to the observable stress of a synthetic test: a zero-mean
    Gaussian process on the time axis with the kernels of noise.discrepancy (exp: Ornstein-Uhlenbeck,
    matern32), to test the model-discrepancy likelihood on data it describes."""

    kernel: Literal["exp", "matern32"] = "exp"
    amplitude: float = Field(ge=0, description="MPa, the process sd")
    length: float = Field(gt=0, description="s, the correlation length")


class TruthModelForm(Strict):
    """A richer generating model than the fitted one (workflows/truth_forms.py): another spectrum
    shape, a stiffer hardening law, a toe or drift in the strain channel, or a second relaxation
    process; ``strength`` is mild, strong or the kind's parameter."""

    kind: Literal["spectrum-power", "spectrum-lognormal", "spectrum-two-slope", "hardening-langevin",
                  "strain-toe", "strain-drift", "two-process"]
    strength: Literal["mild", "strong"] | float = "mild"


class TruthCycles(Strict):
    """Loading-unloading cycles for ``simulate``: each cycle loads at the ramp's rate to its peak
    strain, then unloads at the same rate until the stress falls to ``unload_stress`` (as a machine
    that reverses at a force), and the next cycle loads from there. The last peak is
    ``truth.strain_max``."""

    count: Whole | None = Field(default=None, ge=1, description="peaks evenly spaced up to strain_max")
    peaks: list[float] | None = Field(default=None, description="Hencky strains, increasing")
    unload_stress: float = Field(default=0.0, description="MPa: the stress at which unloading stops")

    @model_validator(mode="after")
    def _one_form(self) -> TruthCycles:
        if (self.count is None) == (self.peaks is None):
            raise ValueError("give exactly one of count or peaks")
        if self.peaks is not None:
            if not self.peaks or any(not p > 0 for p in self.peaks):
                raise ValueError("peaks must be positive Hencky strains")
            if any(b <= a for a, b in zip(self.peaks, self.peaks[1:], strict=False)):
                raise ValueError("peaks must increase")
        return self


class TruthNoise(Strict):
    strain_sd: float = Field(default=1.0e-4, ge=0)
    stress_sd: float = Field(default=0.3, ge=0, description="MPa, on the observable stress")
    force_sd: float = Field(default=0.0, ge=0, description="N, on the force signal")
    correlated: TruthCorrelated | None = None


class TruthTemperature(Strict):
    """A temperature that drifts during the test: start + rate·t (°C, t in s from the first sample)."""

    start: float = Field(gt=-273.15, description="°C at t = 0")
    rate: float = Field(description="°C/s")


class TruthConfig(Strict):
    """Known parameters and test protocol for ``simulate`` (a synthetic test)."""

    params: dict[str, float]
    strain_rate: float = Field(gt=0, description="true (Hencky) strain rate of the ramp, 1/s")
    strain_max: float = Field(gt=0, description="Hencky strain at the end of the ramp")
    hold: float = Field(default=0.0, ge=0, description="length of the relaxation hold, s")
    cycles: TruthCycles | None = Field(
        default=None, description="loading-unloading cycles instead of one ramp (needs sample_rate)")
    n_points: Whole | None = Field(default=None, ge=3)
    sample_rate: float | None = Field(default=None, gt=0, description="Hz")
    time_jitter: float = Field(default=0.0, ge=0, lt=0.5, description="relative, uniform ±")
    noise: TruthNoise = Field(default_factory=TruthNoise)
    model_form: TruthModelForm | None = Field(
        default=None, description="data from a richer model than the fitted one (docs/model-form.md)")
    shift: ShiftConfig = Field(
        default_factory=ShiftConfig, description="the generating model's shift factor (model/shift.py); "
                                                 "its parameters go in params")
    temperature: float | TruthTemperature | None = Field(
        default=None, description="°C: the test's temperature, or {start, rate} drifting in time")
    seed: Whole = Field(default=0, ge=0, lt=2**32)
    layout: Literal["plain", "bluehill", "zwick"] = Field(
        default="plain", description="plain CSV; bluehill: Instron-like metadata block, units row, "
                                     "quoted thousands, strain in %; zwick: ';' and decimal comma, "
                                     "metadata, units row, strain in %")

    @field_validator("params")
    @classmethod
    def _known_names(cls, v: dict[str, float]) -> dict[str, float]:
        unknown = sorted(set(v) - set(PARAMETER_NAMES))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown}; expected {list(PARAMETER_NAMES)}")
        missing = [k for k in TENSILE_PARAMETERS if k not in v]
        if missing:
            raise ValueError(f"missing {missing}")
        return v

    @model_serializer(mode="wrap")
    def _without_no_shift(self, handler):
        """No ``shift`` or ``temperature`` key when unused: the truth dumps as before they existed."""
        out = handler(self)
        if isinstance(out, dict):
            if self.shift.is_none:
                out.pop("shift", None)
            if self.temperature is None:
                out.pop("temperature", None)
        return out

    @model_validator(mode="after")
    def _shifted(self) -> TruthConfig:
        missing = [k for k in self.shift.parameters if k not in self.params]
        if missing:
            raise ValueError(f"params: truth.shift needs {missing}")
        unused = [k for k in SHIFT_PARAMETERS if k in self.params and k not in self.shift.parameters]
        if unused:
            raise ValueError(f"params: {unused} belong to a shift truth.shift does not have")
        if self.shift.temperature != "none" and self.temperature is None:
            raise ValueError(f"shift.temperature: {self.shift.temperature} needs truth.temperature (°C)")
        if self.model_form is not None and not self.shift.is_none:
            raise ValueError("model_form and shift: a richer model with a shift is not made; give one")
        if isinstance(self.temperature, float | int) and not self.temperature > -273.15:
            raise ValueError(f"temperature: expected °C above -273.15, got {self.temperature}")
        return self

    def temperature_at(self, time: np.ndarray) -> float | np.ndarray | None:
        """The test's temperature (°C) at the times ``time``: the constant, or the drift."""
        t = self.temperature
        if t is None or isinstance(t, float | int):
            return None if t is None else float(t)
        return t.start + t.rate * (np.asarray(time, dtype=float) - float(np.asarray(time)[0]))

    @model_validator(mode="after")
    def _sampling(self) -> TruthConfig:
        if (self.n_points is None) == (self.sample_rate is None):
            raise ValueError("give exactly one of n_points or sample_rate")
        if self.hold > 0 and not all(k in self.params for k in RELAXATION_PARAMETERS):
            raise ValueError("a hold needs params sigma_inf and tau_max_R")
        if self.cycles is not None:
            if self.sample_rate is None:
                raise ValueError("cycles need sample_rate (their length is known only once each "
                                 "unloading has reached its stress)")
            if self.hold > 0:
                raise ValueError("give either cycles or a hold, not both")
            if self.cycles.peaks is not None and self.cycles.peaks[-1] > self.strain_max:
                raise ValueError(f"cycles.peaks end at {self.cycles.peaks[-1]:g}, above strain_max "
                                 f"{self.strain_max:g}")
        return self

    def cycle_peaks(self) -> list[float]:
        """The peak strain of every cycle (the last is strain_max)."""
        if self.cycles is None:
            return [self.strain_max]
        if self.cycles.peaks is not None:
            return list(self.cycles.peaks)
        n = int(self.cycles.count)
        return [self.strain_max * (k + 1) / n for k in range(n)]


class PulseEchoCheck(Strict):
    """Pulse-echo measurement (eq. 38-39): a modulus as given, or density with wave speeds (m/s),
    or density with thickness (mm) and echo periods (µs)."""

    modulus: float | None = Field(default=None, gt=0, description="MPa, when already computed")
    sd: float | None = Field(default=None, ge=0, description="MPa, reported uncertainty")
    density: float | None = Field(default=None, gt=0, description="kg/m³")
    v_l: float | None = Field(default=None, gt=0, description="longitudinal wave speed, m/s")
    v_t: float | None = Field(default=None, gt=0, description="transverse wave speed, m/s")
    thickness: float | None = Field(default=None, gt=0, description="sample thickness e, mm")
    period_l: float | None = Field(default=None, gt=0, description="longitudinal echo period, µs")
    period_t: float | None = Field(default=None, gt=0, description="transverse echo period, µs")

    @model_validator(mode="after")
    def _one_form(self) -> PulseEchoCheck:
        speeds = self.v_l is not None or self.v_t is not None
        periods = any(v is not None for v in (self.thickness, self.period_l, self.period_t))
        if self.modulus is not None:
            if speeds or periods or self.density is not None:
                raise ValueError("give either modulus, or density with speeds/periods, not both")
            return self
        if self.density is None:
            raise ValueError("give modulus (MPa), or density (kg/m³) with v_l, v_t or "
                             "thickness, period_l, period_t")
        if speeds == periods:
            raise ValueError("give either v_l and v_t (m/s) or thickness (mm), period_l and "
                             "period_t (µs)")
        if speeds and (self.v_l is None or self.v_t is None):
            raise ValueError("needs both v_l and v_t")
        if periods and None in (self.thickness, self.period_l, self.period_t):
            raise ValueError("needs thickness, period_l and period_t")
        return self


class NanoindentationCheck(Strict):
    """CSM nanoindentation (eq. 40-44): a modulus as given, or S_m (N/m), h (m), F (N)."""

    modulus: float | None = Field(default=None, gt=0, description="MPa, when already computed")
    sd: float | None = Field(default=None, ge=0, description="MPa, reported uncertainty")
    S_m: float | None = Field(default=None, gt=0, description="modulated contact stiffness, N/m")
    h: float | None = Field(default=None, gt=0, description="indentation depth, m")
    F: float | None = Field(default=None, ge=0, description="force at depth h, N")
    nu: float = Field(default=0.5, ge=-1, le=0.5, description="Poisson ratio of the sample")
    phase_deg: float = Field(default=0.0, ge=0, lt=90, description="phase lag φ of eq. 40, degrees")
    indenter_correction: bool = Field(default=False, description="eq. 42 with E_i = 1040 GPa")

    @model_validator(mode="after")
    def _one_form(self) -> NanoindentationCheck:
        raw = [k for k in ("S_m", "h", "F") if getattr(self, k) is not None]
        if self.modulus is not None and raw:
            raise ValueError(f"give either modulus or S_m, h, F, not both (found {raw})")
        if self.modulus is None and len(raw) != 3:
            raise ValueError("give modulus (MPa), or all of S_m (N/m), h (m) and F (N)")
        return self


class CrossCheckConfig(Strict):
    """Independent measurements of E shown beside the model's in the report (paper Table 4)."""

    manufacturer: float | None = Field(default=None, gt=0, description="data-sheet modulus, MPa")
    pulse_echo: PulseEchoCheck | None = None
    nanoindentation: NanoindentationCheck | None = None


class OutputConfig(Strict):
    dir: str | None = None
    modulus_at: list[float] | None = Field(
        default=None, description="times (s after the loading began) at which to report E(t), "
                                  "the relaxation modulus; null: the shortest time the test resolves")

    @field_validator("modulus_at")
    @classmethod
    def _positive_times(cls, v: list[float] | None) -> list[float] | None:
        if v is None:
            return None
        if not v:
            raise ValueError("give at least one time (s), or leave modulus_at out for the default")
        bad = [t for t in v if not (t > 0 and t < float("inf"))]
        if bad:
            raise ValueError(f"times must be positive numbers of seconds, got {bad}")
        return sorted(set(float(t) for t in v))
