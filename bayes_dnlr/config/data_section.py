"""The ``data:`` section: the export file, its columns and units, conversions, window, start state."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, ValidationInfo, field_validator, model_serializer, model_validator

from bayes_dnlr.config.base import Strict, Whole


class Window(Strict):
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


class Columns(Strict):
    """Roles -> CSV header names, or column numbers counted from 1 (within the specimen's column
    group with ``data.specimen``)."""

    time: str | Annotated[Whole, Field(ge=1)] | None = None
    force: str | Annotated[Whole, Field(ge=1)] | None = None
    eps11: str | Annotated[Whole, Field(ge=1)] | None = None
    eps22: str | Annotated[Whole, Field(ge=1)] | None = None
    stress: str | Annotated[Whole, Field(ge=1)] | None = None
    strain: str | Annotated[Whole, Field(ge=1)] | None = None
    extension: str | Annotated[Whole, Field(ge=1)] | None = None

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


class Rows(Strict):
    """The data rows to read, counted from 1 = the first data row (after header and units rows)."""

    first: Whole = Field(default=1, ge=1)
    last: Whole | None = Field(default=None, ge=1)

    @model_validator(mode="after")
    def _ordered(self) -> Rows:
        if self.last is not None and self.last < self.first:
            raise ValueError(f"last ({self.last}) must not be smaller than first ({self.first})")
        return self


class ToeBand(Strict):
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


class TemperatureColumn(Strict):
    """A temperature read per row: the column (a header name, or a number counted from 1) and its
    unit (null: the file's units row or header name, else °C)."""

    column: str | Annotated[Whole, Field(ge=1)]
    unit: Literal["°C", "C", "degC", "K"] | None = None


class DataConfig(Strict):
    file: str
    columns: Columns
    area0: float | None = Field(default=None, description="initial cross-section S0, mm²")
    strain_measure: Literal["hencky", "nominal"] = "hencky"
    stress_measure: Literal["true", "engineering"] = Field(
        default="true", description="the stress column: true (Cauchy) or engineering (F/S0, converted "
                                    "to the true stress s·exp(ε), eq. 4-6)")
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
    repeated_time: Literal["drop", "average"] | None = Field(
        default=None, description="rows that repeat the time stamp before them: drop (keep the first "
                                  "row of each time) or average (their mean); null: an error")
    specimen: Whole | None = Field(default=None, ge=1, description="which specimen of a file with "
                                                                  "several side by side (from 1)")
    specimen_columns: Whole | None = Field(default=None, ge=1, description="columns per specimen; "
                                                                          "null: detected")
    units: dict[str, str] = Field(default_factory=dict, description="role -> unit, overrides the file")
    strain_unit: Literal["fraction", "percent"] | None = None
    gauge_length: float | None = Field(default=None, gt=0, description="L0 in mm, for an extension column")
    toe: Literal["none", "compensate"] | ToeBand = "none"
    initial_state: Literal["first-sample", "ramp-from-zero"] | None = None
    temperature: float | str | TemperatureColumn | None = Field(
        default=None, description="the test's temperature: °C, or a column (a header name, or "
                                  "{column: name or number, unit: °C or K}) read per row")
    reduce: Literal["auto", "none"] | Whole = Field(
        default="auto", description="average consecutive rows in bins: auto (long files, to at most "
                                    "20000 points), none (every row), or the rows per bin")

    @field_validator("temperature")
    @classmethod
    def _temperature(cls, v: float | str | TemperatureColumn | None
                     ) -> float | TemperatureColumn | None:
        if isinstance(v, str):
            if not v.strip():
                raise ValueError("expected °C (a number) or a column name, got an empty text")
            return TemperatureColumn(column=v)
        if isinstance(v, float | int) and not v > -273.15:
            raise ValueError(f"expected a temperature in °C above -273.15, got {v}")
        return v

    @model_serializer(mode="wrap")
    def _without_no_temperature(self, handler):
        """No ``temperature`` key when none is given: a config without one dumps (and digests) as
        before the key existed."""
        out = handler(self)
        if self.temperature is None and isinstance(out, dict):
            out.pop("temperature", None)
        return out

    @property
    def temperature_column(self) -> TemperatureColumn | None:
        """The temperature's column, when it is read per row."""
        return self.temperature if isinstance(self.temperature, TemperatureColumn) else None

    @property
    def has_temperature(self) -> bool:
        return self.temperature is not None

    @field_validator("reduce")
    @classmethod
    def _reduce(cls, v: str | int) -> str | int:
        if isinstance(v, int) and v < 1:
            raise ValueError(f"rows per bin must be at least 1, got {v}")
        return v

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
        from bayes_dnlr.units import factor, known_units

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
        if self.stress_measure == "engineering" and (c.stress is None or self.observable != "stress"):
            raise ValueError("stress_measure: engineering converts the stress column (columns.stress, "
                             "observable: stress) to the true stress; with a force column the "
                             "observable sigma_star (eq. 6) already does")
        if c.time is None and self.strain_rate is None:
            raise ValueError("without a time column, give strain_rate (t = strain / strain_rate)")
        return self
