"""design.yaml -> a validated design (pydantic). Errors name the file and the key
(``design.yaml: conditions.strain_rate: low (0.01) must be smaller than high (0.001)``).

The keys are documented in docs/design.md.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from bayes_dnlr.config import NAME_PATTERN, ConfigError, ModelConfig, OutputConfig, Window, format_errors
from bayes_dnlr.config.base import Whole
from bayes_dnlr.vocabulary import PARAMETER_NAMES, RELAXATION_PARAMETERS, TENSILE_PARAMETERS

CRITERIA = ("D", "A")


class _Strict(BaseModel):
    # numbers as strict as the config's (bayes_dnlr/config/base.py): `n: true` is not 1
    model_config = ConfigDict(extra="forbid", strict=True)


class Grid(_Strict):
    """Planned values of one condition: a number, a list of numbers, or a range
    ``{low, high, n, scale: log|linear}`` (n values from low to high)."""

    values: list[float] | None = None
    low: float | None = None
    high: float | None = None
    n: Whole | None = Field(default=None, ge=2, le=1000)
    scale: Literal["log", "linear"] = "log"

    @model_validator(mode="before")
    @classmethod
    def _forms(cls, v: Any) -> Any:
        if isinstance(v, bool):
            raise ValueError("expected a number, a list of numbers or {low, high, n}")
        if isinstance(v, int | float):
            return {"values": [v]}
        if isinstance(v, list | tuple):
            return {"values": list(v)}
        return v

    @model_validator(mode="after")
    def _complete(self) -> Grid:
        ranged = [k for k in ("low", "high", "n") if getattr(self, k) is not None]
        if self.values is not None:
            if ranged:
                raise ValueError(f"give either a list of values or low/high/n, not both ({ranged})")
            if not self.values:
                raise ValueError("the list of values is empty")
            bad = [v for v in self.values if not math.isfinite(v)]
            if bad:
                raise ValueError(f"values must be finite numbers, got {bad}")
            return self
        missing = [k for k in ("low", "high", "n") if getattr(self, k) is None]
        if missing:
            raise ValueError(f"a range needs low, high and n (missing {', '.join(missing)}); or give a "
                             "number or a list")
        if not (math.isfinite(self.low) and math.isfinite(self.high)):
            raise ValueError("low and high must be finite numbers")
        if not self.low < self.high:
            raise ValueError(f"low ({self.low:g}) must be smaller than high ({self.high:g})")
        if self.scale == "log" and self.low <= 0:
            raise ValueError(f"a log range needs low > 0, got {self.low:g} (or scale: linear)")
        return self

    def points(self) -> list[float]:
        if self.values is not None:
            return [float(v) for v in self.values]
        space = np.geomspace if self.scale == "log" else np.linspace
        return [float(v) for v in space(self.low, self.high, self.n)]


class DesignWindow(Window):
    """An identification window (interval I: ``{strain_max: 0.13, fixed: [G]}``) and the parameters
    held at their guess on it (the paper fixes G on interval I, where the data barely see it)."""

    fixed: list[str] = Field(default_factory=list)

    @field_validator("fixed")
    @classmethod
    def _known(cls, v: list[str]) -> list[str]:
        unknown = sorted(set(v) - set(PARAMETER_NAMES))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown}; expected some of {list(PARAMETER_NAMES)}")
        return v


class Conditions(_Strict):
    """The planned test conditions; every combination is a candidate."""

    strain_rate: Grid = Field(description="true (Hencky) strain rate of the ramp, 1/s")
    strain_max: Grid = Field(description="Hencky strain at the end of the ramp")
    sample_rate: Grid | None = Field(default=None, description="Hz")
    n_points: Grid | None = Field(default=None, description="samples over the whole test")
    hold: Grid = Field(default_factory=lambda: Grid(values=[0.0]),
                       description="relaxation hold after the ramp, s")
    windows: dict[str, DesignWindow] = Field(default_factory=lambda: {"whole": DesignWindow()})

    @model_validator(mode="after")
    def _sampling(self) -> Conditions:
        if (self.sample_rate is None) == (self.n_points is None):
            raise ValueError("give exactly one of sample_rate (Hz) or n_points")
        for key in ("strain_rate", "strain_max", "sample_rate", "n_points"):
            g = getattr(self, key)
            if g is not None and min(g.points()) <= 0:
                raise ValueError(f"{key}: every value must be > 0, got {min(g.points()):g}")
        if self.n_points is not None and min(self.n_points.points()) < 3:
            raise ValueError("n_points: every value must be >= 3")
        if min(self.hold.points()) < 0:
            raise ValueError(f"hold: every value must be >= 0 s, got {min(self.hold.points()):g}")
        if not self.windows:
            raise ValueError("windows: give at least one window ({} is the whole test)")
        return self


class Constraints(_Strict):
    max_duration: float | None = Field(default=None, gt=0, description="s, ramp plus hold")
    max_points: Whole | None = Field(default=None, ge=3, description="samples over the whole test")


class FixedDiscrepancy(_Strict):
    """The model discrepancy with fixed hyperparameters (docs/model-error.md)."""

    kernel: Literal["exp", "matern32"] = "exp"
    axis: Literal["time", "strain"] = "time"
    start: Literal["stationary", "pinned"] = Field(
        default="stationary", description="pinned: δ = 0 at the test's first sample (as the run config)")
    amplitude: float = Field(ge=0, description="MPa")
    length: float = Field(gt=0, description="s on the time axis, strain units on the strain axis")


class DesignNoise(_Strict):
    sigma0: float = Field(gt=0, description="white measurement noise, MPa")
    discrepancy: FixedDiscrepancy | Literal["none"] = "none"

    @field_validator("discrepancy", mode="before")
    @classmethod
    def _none(cls, v: Any) -> Any:
        if v is None or v is False or (isinstance(v, str) and v.strip().lower() == "none"):
            return "none"
        return v


class DesignConfig(_Strict):
    name: str = Field(pattern=NAME_PATTERN)
    parameters: dict[str, float] | None = None
    from_run: str | None = None
    draws: Whole = Field(default=100, ge=1, description="posterior draws averaged over (with from_run)")
    seed: Whole = Field(default=0, ge=0, lt=2**32)
    model: ModelConfig = Field(default_factory=ModelConfig)
    free: list[str] | None = None
    noise: DesignNoise | Literal["from_run"] | None = None
    conditions: Conditions
    constraints: Constraints = Field(default_factory=Constraints)
    criterion: str = "sd_E"
    output: OutputConfig = Field(default_factory=OutputConfig)
    source: Path | None = Field(default=None, exclude=True)

    @field_validator("parameters")
    @classmethod
    def _guess(cls, v: dict[str, float] | None) -> dict[str, float] | None:
        if v is None:
            return v
        unknown = sorted(set(v) - set(PARAMETER_NAMES))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown}; expected some of {list(PARAMETER_NAMES)}")
        missing = [k for k in TENSILE_PARAMETERS if k not in v]
        if missing:
            raise ValueError(f"missing {missing}: the guess needs E, G and tau_max")
        bad = [k for k, x in v.items() if not (math.isfinite(x) and (x > 0 or (k == "G" and x >= 0)))]
        if bad:
            raise ValueError(f"{bad}: expected positive numbers")
        return v

    @field_validator("free")
    @classmethod
    def _free(cls, v: list[str] | None) -> list[str] | None:
        if v is None:
            return v
        unknown = sorted(set(v) - set(PARAMETER_NAMES))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown}; expected some of {list(PARAMETER_NAMES)}")
        if not v:
            raise ValueError("give at least one free parameter")
        return [k for k in PARAMETER_NAMES if k in v]

    @field_validator("criterion")
    @classmethod
    def _criterion(cls, v: str) -> str:
        if v in CRITERIA:
            return v
        kind, _, name = v.partition("_")
        if kind in ("sd", "err") and name in PARAMETER_NAMES:
            return v
        raise ValueError(f"unknown criterion {v!r}; expected sd_<parameter> or err_<parameter> "
                         f"(parameter one of {', '.join(PARAMETER_NAMES)}), D or A")

    def cross_check(self) -> str | None:
        """The first inconsistency between sections, as 'key: message' (None when consistent)."""
        if (self.parameters is None) == (self.from_run is None):
            return ("parameters: give either parameters: (a guess) or from_run: (a finished run), not "
                    "both and not neither")
        if self.noise is None:
            if self.from_run is None:
                return ("noise: required with a parameter guess, e.g. {sigma0: 0.3} or {sigma0: 0.3, "
                        "discrepancy: {kernel: exp, amplitude: 0.5, length: 20}}")
            self.noise = "from_run"
        if self.noise == "from_run" and self.from_run is None:
            return "noise: from_run needs from_run: (a finished run)"
        hold = max(self.conditions.hold.points()) > 0
        if hold and self.parameters is not None:
            missing = [k for k in RELAXATION_PARAMETERS if k not in self.parameters]
            if missing:
                return f"conditions.hold: a hold > 0 needs the guess of {missing} in parameters:"
        for name, w in self.conditions.windows.items():
            if self.free is not None and not [k for k in self.free if k not in w.fixed]:
                return f"conditions.windows.{name}.fixed: every free parameter is fixed"
        return None

    @property
    def base_dir(self) -> Path:
        return self.source.parent if self.source is not None else Path.cwd()

    @property
    def out_dir(self) -> Path:
        """output.dir, else ``<design folder>/<name>/``."""
        if self.output.dir is not None:
            p = Path(self.output.dir)
            return p if p.is_absolute() else self.base_dir / p
        return self.base_dir / self.name

    @property
    def run_path(self) -> Path | None:
        if self.from_run is None:
            return None
        p = Path(self.from_run)
        return p if p.is_absolute() else self.base_dir / p


def parse_design(raw: Any, source: Path | None = None) -> DesignConfig:
    where = str(source) if source is not None else "design"
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: expected a mapping of keys at the top level")
    if "conditions" not in raw and ("data" in raw or "tests" in raw):
        # a run's config given by mistake: its first pydantic error (noise.sigma0) says nothing of it
        raise ConfigError(f"{where}: a run config (it has {'data' if 'data' in raw else 'tests'}:), "
                          "not a design file: design reads a design.yaml with conditions: (the planned "
                          "tests); to start from this run's posterior, write one with from_run: "
                          "<its run folder> (docs/design.md)")
    try:
        cfg = DesignConfig.model_validate(raw)
    except ValidationError as err:
        text = format_errors(err, where, DesignConfig)
        for tag in (".DesignNoise", ".FixedDiscrepancy"):
            text = text.replace(tag, "")
        raise ConfigError(text.replace("docs/config.md", "docs/design.md")) from None
    problem = cfg.cross_check()
    if problem is not None:
        raise ConfigError(f"{where}: {problem}")
    cfg.source = source
    return cfg


def load_design(path: str | Path) -> DesignConfig:
    """Read and validate a design.yaml. Errors name the file and the key."""
    from bayes_dnlr.config.yamlio import YamlError, load_yaml

    path = Path(path)
    try:
        raw = load_yaml(path, "design file")
    except YamlError as err:
        raise ConfigError(str(err)) from None
    return parse_design(raw, source=path.resolve())
