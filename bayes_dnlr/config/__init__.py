"""The config: YAML -> a validated ``Config`` whose every error names the file and the key.

Modules, one section or concern each (they import only ``errors``, ``vocabulary``, ``units``
and each other; nothing else of the package):

- ``yamlio``: reading the YAML a user wrote (UTF-8, no duplicated key, line numbers in errors).
- ``base``: ``Strict``, the base of every section (unknown keys and NaN refused).
- ``data_section``, ``parameter_section``, ``noise_section``, ``run_sections``: the sections.
- ``schema``: ``Config``, the whole config, and its single-test views.
- ``limits``: range checks that need several keys (magnitudes, memory).
- ``errors``: ``ConfigError`` and pydantic's errors in one line.
- ``loader``: ``load_config`` and ``parse_config``.

The rest of the package imports from here: ``from bayes_dnlr.config import Config, load_config``.
"""

from bayes_dnlr.config.data_section import UNIT_ROLES, Columns, DataConfig, Rows, ToeBand, Window
from bayes_dnlr.config.errors import ConfigError, format_errors
from bayes_dnlr.config.loader import load_config, parse_config
from bayes_dnlr.config.noise_section import (
    DISCREPANCY_AXES,
    KERNELS,
    BaselineNoise,
    DiscrepancyConfig,
    NoiseConfig,
    SampledNoise,
)
from bayes_dnlr.config.parameter_section import ALPHA_PRIOR, DEFAULT_PRIORS, ModelConfig, ParameterSpec
from bayes_dnlr.config.run_sections import (
    CrossCheckConfig,
    FitConfig,
    OutputConfig,
    SamplerConfig,
    TruthConfig,
)
from bayes_dnlr.config.schema import NAME_PATTERN, Config, TestSpec

__all__ = [
    "ALPHA_PRIOR", "DEFAULT_PRIORS", "DISCREPANCY_AXES", "KERNELS", "NAME_PATTERN", "UNIT_ROLES",
    "BaselineNoise",
    "Columns", "Config", "ConfigError", "CrossCheckConfig", "DataConfig", "DiscrepancyConfig",
    "FitConfig", "ModelConfig", "NoiseConfig", "OutputConfig", "ParameterSpec", "Rows",
    "SampledNoise", "SamplerConfig", "TestSpec", "ToeBand", "TruthConfig", "Window", "format_errors",
    "load_config", "parse_config",
]
