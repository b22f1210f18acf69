"""YAML config -> validated config (pydantic). All defaults live here.

Every error names the file and the key (``runs/x/config.yaml: parameters.E.low: ...``).
The keys are a contract (see DESIGN.md and docs/config.md).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from bayes_dnlr.errors import BayesDnlrError

PARAMETER_NAMES = ("E", "G", "tau_max", "sigma_inf", "tau_max_R", "alpha")
TENSILE_PARAMETERS = ("E", "G", "tau_max")
RELAXATION_PARAMETERS = ("sigma_inf", "tau_max_R")
SPECTRUM_PARAMETERS = ("alpha",)     # the spectrum's exponent, p_j ∝ tau_j^alpha (eq. 12: ½)
UNITS = {"E": "MPa", "G": "MPa", "tau_max": "s", "sigma_inf": "MPa", "tau_max_R": "s", "alpha": "-",
         "sigma0": "MPa",
         "disc_amplitude": "MPa", "disc_length": "s"}
DISCREPANCY_PARAMETERS = ("disc_amplitude", "disc_length")


class ConfigError(BayesDnlrError, ValueError):
    """A config that cannot be used; the message names the file and the key."""


class _Strict(BaseModel):
    # NaN and ±inf are refused in every number (docs/config.md, "Validation rules")
    model_config = ConfigDict(extra="forbid", frozen=False, allow_inf_nan=False)


class Window(_Strict):
    """Identification interval (paper section 4.1: interval I is ``strain_max: 0.13``)."""

    strain_min: float | None = None
    strain_max: float | None = None
    time_min: float | None = None
    time_max: float | None = None

    @model_validator(mode="after")
    def _ordered(self) -> Window:
        for lo, hi in (("strain_min", "strain_max"), ("time_min", "time_max")):
            a, b = getattr(self, lo), getattr(self, hi)
            if a is not None and b is not None and a >= b:
                raise ValueError(f"{lo} ({a}) must be smaller than {hi} ({b})")
        return self


class Columns(_Strict):
    """Roles -> CSV header names, or column numbers counted from 1 (within the specimen's column
    group with ``data.specimen``)."""

    time: str | Annotated[int, Field(ge=1)] | None = None
    force: str | Annotated[int, Field(ge=1)] | None = None
    eps11: str | Annotated[int, Field(ge=1)] | None = None
    eps22: str | Annotated[int, Field(ge=1)] | None = None
    stress: str | Annotated[int, Field(ge=1)] | None = None
    strain: str | Annotated[int, Field(ge=1)] | None = None
    extension: str | Annotated[int, Field(ge=1)] | None = None

    @model_validator(mode="after")
    def _has_strain(self) -> Columns:
        axial = [r for r in ("eps11", "strain", "extension") if getattr(self, r) is not None]
        if not axial:
            raise ValueError("needs an axial strain column: give 'eps11' (or 'strain'), or 'extension' "
                             "with data.gauge_length")
        if len(axial) > 1:
            raise ValueError(f"give the axial strain once: 'eps11', 'strain' or 'extension', not "
                             f"{' and '.join(repr(r) for r in axial)}")
        if self.force is None and self.stress is None:
            raise ValueError("needs 'force' (with data.area0) or 'stress'")
        return self


class Rows(_Strict):
    """The data rows to read, counted from 1 = the first data row (after header and units rows)."""

    first: int = Field(default=1, ge=1)
    last: int | None = Field(default=None, ge=1)

    @model_validator(mode="after")
    def _ordered(self) -> Rows:
        if self.last is not None and self.last < self.first:
            raise ValueError(f"last ({self.last}) must not be smaller than first ({self.first})")
        return self


class ToeBand(_Strict):
    """The linear part of the curve for toe compensation: a band of nominal stress, MPa."""

    stress_min: float = Field(ge=0)
    stress_max: float = Field(gt=0)

    @model_validator(mode="after")
    def _ordered(self) -> ToeBand:
        if not self.stress_min < self.stress_max:
            raise ValueError(f"stress_min ({self.stress_min}) must be smaller than stress_max "
                             f"({self.stress_max})")
        return self


UNIT_ROLES = ("time", "force", "stress", "eps11", "eps22", "strain", "extension")


class DataConfig(_Strict):
    file: str
    columns: Columns
    area0: float | None = Field(default=None, description="initial cross-section S0, mm²")
    strain_measure: Literal["hencky", "nominal"] = "hencky"
    observable: Literal["sigma_star", "sigma", "stress"] = Field(default="sigma_star", validate_default=True)
    strain_rate: float | None = Field(default=None, gt=0)
    strain_input: Literal["smoothed", "measured"] = "smoothed"
    window: Window = Field(default_factory=Window)
    relaxation_start: Literal["auto"] | float | None = None
    format: Literal["auto", "plain"] = Field(
        default="auto", description="auto: sniff delimiter, decimal mark, header, units row, metadata; "
                                    "plain: a header at line 1 (or none), ',' and '.' unless given")
    delimiter: str | None = Field(default=None, description="a character, 'tab' or 'whitespace'; "
                                                            "null: detected")
    decimal: Literal[".", ","] | None = Field(default=None, description="null: detected")
    header: bool | None = Field(default=None, description="null: detected; false: no header row")
    encoding: str = "utf-8"
    rows: Rows = Field(default_factory=Rows)
    specimen: int | None = Field(default=None, ge=1, description="which specimen of a file with "
                                                                  "several side by side (from 1)")
    specimen_columns: int | None = Field(default=None, ge=1, description="columns per specimen; "
                                                                          "null: detected")
    units: dict[str, str] = Field(default_factory=dict, description="role -> unit, overrides the file")
    strain_unit: Literal["fraction", "percent"] | None = None
    gauge_length: float | None = Field(default=None, gt=0, description="L0 in mm, for an extension column")
    toe: Literal["none", "compensate"] | ToeBand = "none"
    initial_state: Literal["first-sample", "ramp-from-zero"] | None = None

    @field_validator("delimiter")
    @classmethod
    def _delimiter(cls, v: str | None) -> str | None:
        if v is None:
            return v
        v = {"tab": "\t", "\\t": "\t", "space": " "}.get(v, v)
        if v != "whitespace" and len(v) != 1:
            raise ValueError(f"must be one character, 'tab' or 'whitespace', got {v!r}")
        if v in ('"', ".") or v.isalnum():
            raise ValueError(f"{v!r} cannot separate numbers")
        return v

    @field_validator("encoding")
    @classmethod
    def _encoding(cls, v: str) -> str:
        import codecs

        try:
            codecs.lookup(v)
        except LookupError:
            raise ValueError(f"unknown text encoding {v!r} (e.g. utf-8, cp1252, latin-1, utf-16)") from None
        return v

    @field_validator("units")
    @classmethod
    def _units(cls, v: dict[str, str]) -> dict[str, str]:
        from bayes_dnlr.data.units import factor, known_units

        for role, unit in v.items():
            if role not in UNIT_ROLES:
                raise ValueError(f"unknown role {role!r}; expected one of {list(UNIT_ROLES)}")
            if factor(role, unit) is None:
                raise ValueError(f"{role}: unit {unit!r} is not a unit of "
                                 f"{'strain' if role in ('eps11', 'eps22', 'strain') else role}; "
                                 f"known: {', '.join(known_units(role))}")
        return v

    @field_validator("observable")
    @classmethod
    def _observable_columns(cls, v: str, info: ValidationInfo) -> str:
        c = info.data.get("columns")
        if c is None:  # columns failed validation: reported there
            return v
        if v in ("sigma_star", "sigma") and c.force is None:
            eq = "eq. 6" if v == "sigma_star" else "eq. 2"
            raise ValueError(f"'{v}' ({eq}) is computed from the force: give columns.force (with "
                             f"area0), or use observable: stress to take the stress column as the "
                             f"true stress")
        return v

    @field_validator("area0")
    @classmethod
    def _positive_area(cls, v: float | None) -> float | None:
        if v is not None and not v > 0:
            raise ValueError(f"must be a positive cross-section in mm², got {v}")
        return v

    @model_validator(mode="after")
    def _consistent(self) -> DataConfig:
        c = self.columns
        mapped = {r: getattr(c, r) for r in type(c).model_fields if getattr(c, r) is not None}
        if self.header is False:
            names = [r for r, v in mapped.items() if not isinstance(v, int)]
            if names:
                raise ValueError(f"header: false needs every column as a number counted from 1; "
                                 f"columns {names} are names")
        if c.extension is not None and self.gauge_length is None:
            raise ValueError("an extension column needs gauge_length (L0, mm): strain = extension / L0")
        if self.specimen_columns is not None and self.specimen is None:
            raise ValueError("specimen_columns needs specimen (which specimen to read)")
        if self.initial_state == "first-sample" and self.toe != "none":
            raise ValueError("toe compensation puts the unloaded start at the corrected zero point B: "
                             "initial_state: first-sample contradicts it (leave initial_state out)")
        if c.force is not None and c.stress is None and self.area0 is None:
            raise ValueError("area0 is needed to turn the force column into a stress")
        if self.observable == "sigma" and c.eps22 is None:
            raise ValueError("observable 'sigma' (eq. 2) needs the transverse strain column eps22")
        if self.observable == "stress" and c.stress is None:
            raise ValueError("observable 'stress' needs a stress column (columns.stress)")
        if c.time is None and self.strain_rate is None:
            raise ValueError("without a time column, give strain_rate (t = strain / strain_rate)")
        return self


class ModelConfig(_Strict):
    modes: int = Field(default=50, ge=1, le=1000)
    decades: float = Field(default=6.0, gt=0, le=20)


PriorKind = Literal["uniform", "log-uniform", "normal", "log-normal", "half-normal"]


class ParameterSpec(_Strict):
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
# (docs/theory.md, "The spectrum's exponent": what it costs and buys, measured).
ALPHA_PRIOR: dict[str, Any] = {"prior": "normal", "mean": 0.5, "sd": 0.05, "low": 0.0, "high": 1.0}


class BaselineNoise(_Strict):
    baseline: Window


class SampledNoise(_Strict):
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


class DiscrepancyConfig(_Strict):
    """The model discrepancy δ: a zero-mean Gaussian process on the residuals (docs/model-error.md).

    amplitude (MPa) and length (s on the time axis, strain on the strain axis) take a prior, or
    ``value:`` to fix them; left out, their priors scale with the test: amplitude half-normal with
    scale 2 × max(maximum-likelihood amplitude, rms/√n), length log-uniform from three sampling
    steps to the span of the window.
    """

    kernel: Literal["auto", "exp", "matern32"] = Field(
        default="auto", description="auto: fit chooses exp (Ornstein-Uhlenbeck) or matern32 by their "
                                    "maximum likelihood, keeping exp when matern32 would move a "
                                    "parameter by more than 2 sd (it absorbs the model's response, "
                                    "as on the real ETFE curves); docs/model-error.md")
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


class NoiseConfig(_Strict):
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


class SamplerConfig(_Strict):
    walkers: int = Field(default=32, ge=2)
    max_steps: int = Field(default=20000, ge=1)
    target_ess: float = Field(default=1000.0, gt=0)
    seed: int = Field(default=1, ge=0, lt=2**32, description="numpy's RandomState takes 0 <= seed < 2**32")
    checkpoint_every: int = Field(default=100, ge=1)
    moves: Literal["de-snooker", "stretch", "de"] = Field(
        default="de", description="emcee moves; DEMove alone mixes best here (benchmarks/moves.py)")
    burn_in_tau: float = Field(default=5.0, ge=0, description="burn-in, in autocorrelation times")
    min_tau_multiple: float = Field(default=50.0, gt=0, description="chain length >= this many tau")
    threads: int | None = Field(
        default=None, ge=1, description="threads of the compiled likelihood (walkers in parallel); "
                                         "null: NUMBA_NUM_THREADS lowered to OMP_NUM_THREADS, which "
                                         "also cap a number given here; the chain does not depend on it")


class FitConfig(_Strict):
    method: Literal["lm", "gauss-newton"] = "lm"
    multistart: int = Field(default=8, ge=0)
    max_iterations: int = Field(default=200, ge=1)


class TruthCorrelated(_Strict):
    """A smooth correlated error added to the observable stress of a synthetic test: a zero-mean
    Gaussian process on the time axis with the kernels of noise.discrepancy (exp: Ornstein-Uhlenbeck,
    matern32), to test the model-discrepancy likelihood on data it describes."""

    kernel: Literal["exp", "matern32"] = "exp"
    amplitude: float = Field(ge=0, description="MPa, the process sd")
    length: float = Field(gt=0, description="s, the correlation length")


class TruthModelForm(_Strict):
    """A richer generating model than the fitted one (bayes_dnlr/truth_forms.py): another spectrum
    shape, a stiffer hardening law, a toe or drift in the strain channel, or a second relaxation
    process; ``strength`` is mild, strong or the kind's parameter."""

    kind: Literal["spectrum-power", "spectrum-lognormal", "spectrum-two-slope", "hardening-langevin",
                  "strain-toe", "strain-drift", "two-process"]
    strength: Literal["mild", "strong"] | float = "mild"


class TruthNoise(_Strict):
    strain_sd: float = Field(default=1.0e-4, ge=0)
    stress_sd: float = Field(default=0.3, ge=0, description="MPa, on the observable stress")
    force_sd: float = Field(default=0.0, ge=0, description="N, on the force signal")
    correlated: TruthCorrelated | None = None


class TruthConfig(_Strict):
    """Known parameters and test protocol for ``simulate`` (a synthetic test)."""

    params: dict[str, float]
    strain_rate: float = Field(gt=0, description="true (Hencky) strain rate of the ramp, 1/s")
    strain_max: float = Field(gt=0, description="Hencky strain at the end of the ramp")
    hold: float = Field(default=0.0, ge=0, description="length of the relaxation hold, s")
    n_points: int | None = Field(default=None, ge=3)
    sample_rate: float | None = Field(default=None, gt=0, description="Hz")
    time_jitter: float = Field(default=0.0, ge=0, lt=0.5, description="relative, uniform ±")
    noise: TruthNoise = Field(default_factory=TruthNoise)
    model_form: TruthModelForm | None = Field(
        default=None, description="data from a richer model than the fitted one (docs/model-error.md)")
    seed: int = Field(default=0, ge=0, lt=2**32)
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

    @model_validator(mode="after")
    def _sampling(self) -> TruthConfig:
        if (self.n_points is None) == (self.sample_rate is None):
            raise ValueError("give exactly one of n_points or sample_rate")
        if self.hold > 0 and not all(k in self.params for k in RELAXATION_PARAMETERS):
            raise ValueError("a hold needs params sigma_inf and tau_max_R")
        return self


class PulseEchoCheck(_Strict):
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


class NanoindentationCheck(_Strict):
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


class CrossCheckConfig(_Strict):
    """Independent measurements of E shown beside the model's in the report (paper Table 4)."""

    manufacturer: float | None = Field(default=None, gt=0, description="data-sheet modulus, MPa")
    pulse_echo: PulseEchoCheck | None = None
    nanoindentation: NanoindentationCheck | None = None


class OutputConfig(_Strict):
    dir: str | None = None


NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9._-]*$"


class TestSpec(_Strict):
    """One test of a run with several tests: its own data, noise model and (for simulate) truth."""

    __test__ = False  # not a pytest test class despite its name

    name: str = Field(pattern=NAME_PATTERN)
    data: DataConfig
    noise: NoiseConfig = Field(default_factory=NoiseConfig)
    truth: TruthConfig | None = None


class Config(_Strict):
    name: str = Field(pattern=NAME_PATTERN)
    data: DataConfig | None = None
    tests: list[TestSpec] | None = None
    model: ModelConfig = Field(default_factory=ModelConfig)
    parameters: dict[str, ParameterSpec] = Field(default_factory=dict)
    noise: NoiseConfig = Field(default_factory=NoiseConfig)
    sampler: SamplerConfig = Field(default_factory=SamplerConfig)
    fit: FitConfig = Field(default_factory=FitConfig)
    truth: TruthConfig | None = None
    crosscheck: CrossCheckConfig | None = None
    output: OutputConfig = Field(default_factory=OutputConfig)
    # where the config was read from (not a YAML key)
    source: Path | None = Field(default=None, exclude=True)

    @field_validator("parameters", mode="before")
    @classmethod
    def _known_parameters(cls, v: Any) -> Any:
        if isinstance(v, dict):
            unknown = sorted(set(v) - set(PARAMETER_NAMES))
            if unknown:
                raise ValueError(
                    f"unknown parameter(s) {unknown}; expected some of {list(PARAMETER_NAMES)}")
        return v

    @model_validator(mode="after")
    def _one_kind_of_run(self) -> Config:
        if (self.data is None) == (self.tests is None):
            raise ValueError("give either data: (one test) or tests: (a list of tests), not both "
                             "and not neither")
        if self.tests is not None:
            if len(self.tests) == 0:
                raise ValueError("tests: is empty; give at least one test, or data: for one test")
            seen: dict[str, int] = {}
            for i, t in enumerate(self.tests):
                if t.name in seen:
                    raise ValueError(f"tests[{i}].name: {t.name!r} is used twice (tests[{seen[t.name]}] "
                                     "has it too); every test needs its own name")
                seen[t.name] = i
            if self.truth is not None:
                raise ValueError("truth: belongs to each test (tests[i].truth) in a run with tests:")
            if "noise" in self.model_fields_set:
                raise ValueError("noise: belongs to each test (tests[i].noise) in a run with tests:")
        else:
            per = [k for k, v in self.parameters.items() if v is not None and v.per_test]
            if per:
                raise ValueError(f"parameters.{per[0]}.per: test needs several tests (a tests: list); "
                                 "with one test (data:) every parameter is that test's own")
        return self

    @model_validator(mode="after")
    def _fill_parameters(self) -> Config:
        wanted = list(TENSILE_PARAMETERS)
        if self.has_relaxation:
            wanted += list(RELAXATION_PARAMETERS)
        else:
            extra = [k for k in RELAXATION_PARAMETERS if k in self.parameters]
            if extra:
                where = ("tests[i].data.relaxation_start of some test" if self.tests is not None
                         else "data.relaxation_start")
                raise ValueError(f"parameters {extra} need a relaxation hold: set {where} "
                                 "(auto or a time)")
        wanted += [k for k in SPECTRUM_PARAMETERS if self.parameters.get(k) is not None]
        filled = {k: self.parameters.get(k) or ParameterSpec(**DEFAULT_PRIORS[k]) for k in wanted}
        self.parameters = filled
        if not self.free_parameters:
            raise ValueError("every parameter is fixed: nothing to identify")
        return self

    @property
    def is_joint(self) -> bool:
        """A run with several tests (``tests:``) and one joint posterior."""
        return self.tests is not None

    @property
    def test_names(self) -> list[str]:
        return [t.name for t in self.tests] if self.tests is not None else [self.name]

    @property
    def has_relaxation(self) -> bool:
        if self.tests is not None:
            return any(t.data.relaxation_start is not None for t in self.tests)
        return self.data.relaxation_start is not None

    @property
    def per_test_parameters(self) -> list[str]:
        """The parameters with one value per test (``per: test``), canonical order."""
        return [k for k in self.parameter_names if self.parameters[k].per_test]

    def for_test(self, name: str) -> Config:
        """The single-test view of one test of a joint run: its data, noise and truth with the shared
        model, parameters (``per`` dropped), sampler and fit sections; outputs (if any) under
        ``<run_dir>/tests/<name>``."""
        if self.tests is None:
            if name != self.name:
                raise KeyError(name)
            return self
        spec = next((t for t in self.tests if t.name == name), None)
        if spec is None:
            raise KeyError(f"no test named {name!r}; the tests are {self.test_names}")
        params = {k: v.model_copy(update={"per": None}) for k, v in self.parameters.items()}
        if spec.data.relaxation_start is None:
            params = {k: v for k, v in params.items() if k not in RELAXATION_PARAMETERS}
        view = Config.model_construct(
            name=spec.name, data=spec.data, tests=None, model=self.model, parameters=params,
            noise=spec.noise, sampler=self.sampler, fit=self.fit, truth=spec.truth,
            crosscheck=self.crosscheck,
            output=OutputConfig(dir=str(self.run_dir / "tests" / spec.name)), source=self.source)
        return view

    def test_configs(self) -> list[Config]:
        """One single-test config per test (just ``[self]`` for a run with one test)."""
        return [self.for_test(n) for n in self.test_names]

    @property
    def parameter_names(self) -> list[str]:
        """All model parameters, in the canonical order."""
        return [k for k in PARAMETER_NAMES if k in self.parameters]

    @property
    def free_parameters(self) -> list[str]:
        return [k for k in self.parameter_names if not self.parameters[k].fixed]

    @property
    def fixed_values(self) -> dict[str, float]:
        return {k: s.value for k, s in self.parameters.items() if s.fixed}  # type: ignore[misc]

    @property
    def base_dir(self) -> Path:
        return self.source.parent if self.source is not None else Path.cwd()

    @property
    def data_path(self) -> Path:
        if self.data is None:
            raise ConfigError(f"{self.source or 'config'}: a run with tests: has one data file per "
                              "test (for_test(name).data_path)")
        p = Path(self.data.file)
        return p if p.is_absolute() else self.base_dir / p

    @property
    def run_dir(self) -> Path:
        """Where outputs go: output.dir, else the config's folder when it is named after the run,
        else ``<config folder>/<name>/``."""
        if self.output.dir is not None:
            p = Path(self.output.dir)
            return p if p.is_absolute() else self.base_dir / p
        if self.base_dir.name == self.name:
            return self.base_dir
        return self.base_dir / self.name

    def to_yaml(self) -> str:
        """The config as resolved (defaults filled in), as YAML."""
        return yaml.safe_dump(self.as_dict(), sort_keys=False)

    def as_dict(self) -> dict[str, Any]:
        """The config as resolved, as plain data that ``parse_config`` reads back (a run with tests:
        has each test's noise under tests[i]: the top-level default is left out)."""
        return self.model_dump(mode="json", exclude_none=True,
                               exclude={"noise"} if self.is_joint else None)


_UNION_TAGS = {"BaselineNoise", "SampledNoise", "DiscrepancyConfig", "float", "int", "str", "none",
               "constrained-float"}


def _is_type_tag(part: str) -> bool:
    return part in _UNION_TAGS or part.startswith(("function-", "literal["))


_BOUND_TYPES = {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}


def _names_a_key(msg: str) -> bool:
    """A top-level message that already starts with the key it is about (``tests[3].name: ...``)."""
    import re

    return re.match(r"^(tests\[\d+\]|parameters|noise|truth|data)[.\w\[\]]*: ", msg) is not None


def _format_errors(err: ValidationError, where: str) -> str:
    entries = []
    for e in err.errors():
        # pydantic puts union member tags in loc; drop them to keep the key readable
        loc = tuple(str(x) for x in e["loc"] if not _is_type_tag(str(x)))
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "extra_forbidden":
            msg = "unknown key (check the spelling; see docs/config.md)"
        elif e["type"] == "missing":
            msg = "required key is missing"
        elif e["type"] == "finite_number":
            msg = f"expected a finite number, got {e.get('input')!r}"
        elif e["type"] in ("int_parsing", "int_from_float"):
            msg = f"expected a whole number, got {e.get('input')!r}"
        elif e["type"] in _BOUND_TYPES:
            msg = f"{msg}, got {e.get('input')!r}"
        entries.append((loc, msg))
    # a union lists why each member failed: keep the deepest errors, those that name a key inside
    # the value, and drop the members that failed on the value as a whole (e.g. "should be 'none'")
    keep = [(loc, msg) for loc, msg in entries
            if not any(len(other) > len(loc) and other[:len(loc)] == loc for other, _ in entries)]
    items = list(dict.fromkeys(f"{'.'.join(loc)}: {msg}" if loc else
                               msg if _names_a_key(msg) else f"(top level): {msg}" for loc, msg in keep))
    # one line: the first problem, then the others in brackets (the CLI prints one line)
    more = f" (also {len(items) - 1} more: {'; '.join(items[1:])})" if len(items) > 1 else ""
    return f"{where}: {items[0]}{more}"


def parse_config(raw: dict[str, Any], source: Path | None = None) -> Config:
    """Validate a config mapping; ``source`` anchors relative paths and names the file in errors."""
    where = str(source) if source is not None else "config"
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: expected a mapping of keys at the top level")
    try:
        cfg = Config.model_validate(raw)
    except ValidationError as err:
        raise ConfigError(_format_errors(err, where)) from None
    from bayes_dnlr.config_limits import range_errors

    bad = range_errors(cfg)
    if bad:
        raise ConfigError(f"{where}: {bad[0]}")
    cfg.source = source
    return cfg


def load_config(path: str | Path) -> Config:
    """Read and validate a YAML config (bayes_dnlr/yamlio.py: UTF-8, no duplicated key). Errors
    name the file and the key (or line)."""
    from bayes_dnlr.yamlio import YamlError, load_yaml

    path = Path(path)
    try:
        raw = load_yaml(path, "config file")
    except YamlError as err:
        raise ConfigError(str(err)) from None
    return parse_config(raw, source=path.resolve())
