"""The whole config: ``Config`` (one test under ``data:``, or several under ``tests:``) and its
single-test views. All defaults live in the section modules; the keys are a contract (docs/config.md)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any

from pydantic import BeforeValidator, Field, field_validator, model_validator

from bayes_dnlr.config.base import Strict
from bayes_dnlr.config.data_section import DataConfig
from bayes_dnlr.config.errors import ConfigError
from bayes_dnlr.config.noise_section import NoiseConfig
from bayes_dnlr.config.parameter_section import DEFAULT_PRIORS, ModelConfig, ParameterSpec
from bayes_dnlr.config.reference_section import ReferenceModulus, label_references
from bayes_dnlr.config.run_sections import (
    CrossCheckConfig,
    FitConfig,
    OutputConfig,
    SamplerConfig,
    TruthConfig,
)
from bayes_dnlr.config.yamlio import dump_yaml
from bayes_dnlr.vocabulary import (
    PARAMETER_NAMES,
    RELAXATION_PARAMETERS,
    SHIFT_PARAMETERS,
    SPECTRUM_PARAMETERS,
    TENSILE_PARAMETERS,
)

NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9._-]*$"
MATERIAL_MAX = 60       # characters of ``material:``, a label for tables and figures


def _material_text(v: Any) -> Any:
    """``material: 19`` (a resin number) is the label "19"; another number or a boolean is refused (a
    float would come back as another spelling: 1e3 as 1000.0)."""
    if type(v) is int:
        return str(v)
    if isinstance(v, bool | float):
        shown = str(v).lower() if isinstance(v, bool) else repr(v)
        raise ValueError(f"expected a short label, got {shown} (quote it: material: '{shown}')")
    return v


class TestSpec(Strict):
    """One test of a run with several tests: its own data, noise model and (for simulate) truth."""

    __test__ = False  # not a pytest test class despite its name

    name: str = Field(pattern=NAME_PATTERN)
    data: DataConfig
    noise: NoiseConfig = Field(default_factory=NoiseConfig)
    truth: TruthConfig | None = None


class Config(Strict):
    name: str = Field(pattern=NAME_PATTERN)
    # which material the specimen is of: batch, population and compare give one result per material
    material: Annotated[str | None, BeforeValidator(_material_text)] = None
    data: DataConfig | None = None
    tests: list[TestSpec] | None = None
    model: ModelConfig = Field(default_factory=ModelConfig)
    parameters: dict[str, ParameterSpec] = Field(default_factory=dict)
    noise: NoiseConfig = Field(default_factory=NoiseConfig)
    sampler: SamplerConfig = Field(default_factory=SamplerConfig)
    fit: FitConfig = Field(default_factory=FitConfig)
    truth: TruthConfig | None = None
    crosscheck: CrossCheckConfig | None = None
    reference_moduli: list[ReferenceModulus] | None = None
    output: OutputConfig = Field(default_factory=OutputConfig)
    # where the config was read from (not a YAML key)
    source: Path | None = Field(default=None, exclude=True)

    @field_validator("material")
    @classmethod
    def _short_label(cls, v: str | None) -> str | None:
        if v is None:
            return v
        if not v.strip() or v != v.strip() or len(v) > MATERIAL_MAX or not v.isprintable():
            raise ValueError(f"expected a short label (1 to {MATERIAL_MAX} printable characters, no "
                             f"leading or trailing space, e.g. HDPE-A or 'resin 19'), got {v!r}")
        return v

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
    def _references_of_this_run(self) -> Config:
        if not self.reference_moduli:
            return self
        label_references(self.reference_moduli)
        for i, r in enumerate(self.reference_moduli):
            if r.test is not None and r.test not in self.test_names:
                raise ValueError(f"reference_moduli[{i}].test: no test named {r.test!r}; the tests are "
                                 f"{self.test_names}")
        return self

    @property
    def reference_labels(self) -> list[str]:
        """The label of each ``reference_moduli`` entry (its name, else its method, numbered)."""
        return label_references(self.reference_moduli or [])

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
        shift = self.model.shift
        unused = [k for k in SHIFT_PARAMETERS if k in self.parameters and k not in shift.parameters]
        if unused:
            law = {"Ea": "temperature: arrhenius", "C1": "temperature: wlf",
                   "C2": "temperature: wlf", "sigma_s": "stress: eyring"}[unused[0]]
            raise ValueError(f"parameters.{unused[0]} belongs to a shift the model does not have: "
                             f"set model.shift.{law}, or remove it")
        wanted += list(shift.parameters)
        filled = {k: self.parameters.get(k) or ParameterSpec(**DEFAULT_PRIORS[k]) for k in wanted}
        self.parameters = filled
        if not self.free_parameters:
            raise ValueError("every parameter is fixed: nothing to identify")
        return self

    @model_validator(mode="after")
    def _temperatures(self) -> Config:
        """A temperature shift needs every test's temperature; its parameters need two of them."""
        law = self.model.shift.temperature
        if law == "none":
            return self
        data = ([(f"tests[{i}].data.temperature", t.data) for i, t in enumerate(self.tests)]
                if self.tests is not None else [("data.temperature", self.data)])
        missing = [key for key, d in data if not d.has_temperature]
        if missing:
            raise ValueError(f"model.shift.temperature: {law} needs the test's temperature: set "
                             f"{missing[0]} (°C, or a column read per row)")
        constants = {d.temperature for _, d in data if d.temperature_column is None}
        if len(constants) == 1 and all(d.temperature_column is None for _, d in data):
            free = [k for k in self.model.shift.parameters
                    if k in ("Ea", "C1", "C2") and not self.parameters[k].fixed]
            if free:
                t = next(iter(constants))
                raise ValueError(
                    f"parameters.{free[0]}: every test is at {t:g} °C, where the temperature shift "
                    f"only rescales tau_max (a_T multiplies it): the data cannot identify "
                    f"{' and '.join(free)}. Fix {'them' if len(free) > 1 else 'it'} "
                    f"(parameters.{free[0]}: {{value: ...}}), or add tests at other temperatures "
                    "(tests:), or read the temperature per row")
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
            output=OutputConfig(dir=str(self.run_dir / "tests" / spec.name),
                                modulus_at=self.output.modulus_at), source=self.source)
        return view

    def test_configs(self) -> list[Config]:
        """One single-test config per test (just ``[self]`` for a run with one test)."""
        return [self.for_test(n) for n in self.test_names]

    @property
    def parameter_names(self) -> list[str]:
        """All model parameters, in the canonical order."""
        return [k for k in PARAMETER_NAMES if k in self.parameters]

    def with_shift(self, **laws: str) -> Config:
        """This config with other shift laws (keys of ``model.shift``: stress="eyring", ...), the
        parameters of a law it did not have at their default priors."""
        shift = self.model.shift.model_copy(update=laws)
        params = dict(self.parameters)
        for k in shift.parameters:
            params.setdefault(k, ParameterSpec(**DEFAULT_PRIORS[k]))
        return self.model_copy(update={"model": self.model.model_copy(update={"shift": shift}),
                                       "parameters": params})

    def with_holds(self, held: Mapping[str, float]) -> Config:
        """This config with the parameters of ``held`` fixed at the given values (a parameter the
        window cannot identify, held by the fit: inference/lsq/sensitivity.py ``unidentified``)."""
        if not held:
            return self
        params = dict(self.parameters)
        for k, v in held.items():
            params[k] = ParameterSpec(value=float(v))
        return self.model_copy(update={"parameters": params})

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
        return dump_yaml(self.as_dict())

    def as_dict(self) -> dict[str, Any]:
        """The config as resolved, as plain data that ``parse_config`` reads back (a run with tests:
        has each test's noise under tests[i]: the top-level default is left out)."""
        return self.model_dump(mode="json", exclude_none=True,
                               exclude={"noise"} if self.tests is not None else None)
