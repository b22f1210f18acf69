"""``reference_moduli:``: moduli measured by other techniques (the paper's Table 4: pulse-echo,
nanoindentation, a DMA, the manufacturer's value), each at its own time scale, to be checked
against the model's prediction there or to enter the likelihood (docs/config.md,
"reference_moduli: independent moduli").

An entry is a point (``value`` with its ``sd``, at a ``frequency`` or a ``time``) or a DMA sweep
(``file``: one row per frequency with E' and E'' or tan δ, and optionally the temperature).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator, model_validator

from bayes_dnlr.config.base import Strict, Whole

METHODS = ("pulse-echo", "nanoindentation", "dma", "manufacturer", "other")
USES = ("check", "data")
# the columns of a DMA export (data/dma.py reads them by name when not given)
SWEEP_ROLES = ("frequency", "angular_frequency", "storage", "loss", "tan_delta", "temperature")
SWEEP_LAYOUTS = ("plain", "trios", "netzsch", "anton-paar")
ABSOLUTE_ZERO_C = -273.15
NAME = r"^[A-Za-z0-9][A-Za-z0-9._-]*$"


class SweepTruth(Strict):
    """How ``simulate`` writes a DMA sweep from the run's truth: log-spaced frequencies, relative
    Gaussian noise on E' and E''."""

    frequency_min: float = Field(default=0.1, gt=0, description="Hz")
    frequency_max: float = Field(default=100.0, gt=0, description="Hz")
    points_per_decade: Whole = Field(default=5, ge=1)
    relative_sd: float = Field(default=0.01, ge=0, lt=0.5, description="noise, a fraction of each value")
    temperature: float | None = Field(default=None, gt=ABSOLUTE_ZERO_C, description="°C, written per row")
    seed: Whole = Field(default=0, ge=0, lt=2**32)
    layout: Literal["plain", "trios", "netzsch", "anton-paar"] = Field(
        default="plain", description="how the file looks: plain CSV in MPa and Hz, or like a TA "
                                     "TRIOS, Netzsch or Anton Paar export (their names and units)")

    @model_validator(mode="after")
    def _range(self) -> SweepTruth:
        if not self.frequency_max > self.frequency_min:
            raise ValueError(f"frequency_max ({self.frequency_max:g}) must be above frequency_min "
                             f"({self.frequency_min:g})")
        return self


class ReferenceModulus(Strict):
    """One independent modulus: a point or a DMA sweep (module doc)."""

    method: Literal["pulse-echo", "nanoindentation", "dma", "manufacturer", "other"]
    name: str | None = Field(default=None, pattern=NAME,
                             description="a label in the outputs; default the method (numbered when "
                                         "several entries share it)")
    value: float | None = Field(default=None, gt=0, description="MPa")
    sd: float | None = Field(default=None, gt=0, description="MPa, the measurement's standard deviation")
    relative_sd: float | None = Field(default=None, gt=0, lt=1,
                                      description="the sd as a fraction of the value (of each row's "
                                                  "E' and E'' for a sweep)")
    frequency: float | None = Field(default=None, gt=0, description="Hz")
    time: float | None = Field(default=None, gt=0, description="s: E(t) after a small step")
    temperature: float | None = Field(default=None, gt=ABSOLUTE_ZERO_C, description="°C")
    use: Literal["check", "data"] = Field(
        default="check", description="check: a held-out comparison with the posterior's prediction, "
                                     "a line of the verdict when it disagrees; data: a Gaussian term "
                                     "of the likelihood")
    note: str | None = None
    test: str | None = Field(default=None, description="the test whose parameters predict it (only "
                                                       "needed in a run whose spectrum is per test)")
    # a DMA sweep
    file: str | None = Field(default=None, description="a DMA export, relative to the config")
    columns: dict[str, str | Whole] | None = Field(
        default=None, description="role -> header name or column number (from 1); default: found "
                                  "by name")
    units: dict[str, str] = Field(default_factory=dict, description="role -> unit, over the file's")
    truth: SweepTruth | None = Field(default=None, description="simulate: the sweep from the run's truth")

    @field_validator("columns", "units")
    @classmethod
    def _roles(cls, v: dict | None) -> dict | None:
        unknown = sorted(set(v or {}) - set(SWEEP_ROLES))
        if unknown:
            raise ValueError(f"unknown column role(s) {unknown}; expected some of {list(SWEEP_ROLES)}")
        return v

    @model_validator(mode="after")
    def _one_form(self) -> ReferenceModulus:
        if (self.value is None) == (self.file is None):
            raise ValueError("give value (MPa, a point) or file (a DMA sweep), one of them")
        if self.sd is not None and self.relative_sd is not None:
            raise ValueError("give sd (MPa) or relative_sd (a fraction), not both")
        if self.file is not None:
            if self.method != "dma":
                raise ValueError(f"a file is a DMA sweep: method must be dma, not {self.method}")
            if self.frequency is not None or self.time is not None:
                raise ValueError("a sweep has its frequencies in its file: leave frequency and time out")
            if self.sd is None and self.relative_sd is None:
                raise ValueError("a sweep needs its uncertainty: relative_sd (e.g. 0.02 for 2 % of "
                                 "each E' and E'') or sd (MPa)")
            return self
        if self.columns is not None or self.units or self.truth is not None:
            raise ValueError("columns, units and truth belong to a sweep (file:), not to a value")
        if self.frequency is not None and self.time is not None:
            raise ValueError("give the time scale once: frequency (Hz) or time (s)")
        if self.use == "data":
            if self.sd is None and self.relative_sd is None:
                raise ValueError("use: data needs the measurement's sd (MPa) or relative_sd: it is the "
                                 "width of its likelihood term")
            if self.frequency is None and self.time is None:
                raise ValueError("use: data needs the time scale the value was measured at: "
                                 "frequency (Hz) or time (s)")
        return self

    @property
    def is_sweep(self) -> bool:
        return self.file is not None

    def value_sd(self) -> float | None:
        """The point's sd in MPa (from relative_sd when so given), None when not given."""
        if self.sd is not None:
            return float(self.sd)
        if self.relative_sd is not None and self.value is not None:
            return float(self.relative_sd * self.value)
        return None


def label_references(entries: list[ReferenceModulus]) -> list[str]:
    """The outputs' label of each entry: its ``name``, else its method, numbered (``pulse-echo-2``)
    when several entries share it. Labels are unique (an error names a clash)."""
    counts: dict[str, int] = {}
    for e in entries:
        if e.name is None:
            counts[e.method] = counts.get(e.method, 0) + 1
    seen: dict[str, int] = {}
    labels = []
    for i, e in enumerate(entries):
        if e.name is not None:
            label = e.name
        else:
            seen[e.method] = seen.get(e.method, 0) + 1
            label = e.method if counts[e.method] == 1 else f"{e.method}-{seen[e.method]}"
        if label in labels:
            raise ValueError(f"reference_moduli[{i}]: the label {label!r} is used twice; give the "
                             "entries distinct names")
        labels.append(label)
    return labels


def crosscheck_entries(cfg) -> list:
    """The moduli of a ``crosscheck:`` section (eq. 38-44) as ``reference_moduli`` entries to check:
    pulse-echo at the paper's 5 MHz, the CSM nanoindentation at its 45 Hz (paper section 5.1), the
    manufacturer's value without a time scale."""
    from bayes_dnlr.crosscheck import crosscheck_values
    from bayes_dnlr.numbers import frequency_text

    out = []
    for v in crosscheck_values(cfg.crosscheck):
        method = {"Pulse-echo": "pulse-echo", "Nanoindentation": "nanoindentation"}.get(v.technique,
                                                                                       "manufacturer")
        freq = {"pulse-echo": 5.0e6, "nanoindentation": 45.0}.get(method)
        out.append(ReferenceModulus(method=method, value=v.modulus, sd=v.sd or None, frequency=freq,
                                    note=f"crosscheck: {v.detail}" + (
                                        f"; at the paper's {frequency_text(freq)}" if freq else "")))
    return out
