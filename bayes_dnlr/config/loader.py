"""Reading a config: YAML file -> validated ``Config`` with its range checks (config/limits.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import ValidationError

from bayes_dnlr.config.errors import ConfigError, format_errors
from bayes_dnlr.config.limits import range_errors
from bayes_dnlr.config.schema import Config
from bayes_dnlr.config.yamlio import YamlError, load_yaml


def parse_config(raw: dict[str, Any], source: Path | None = None) -> Config:
    """Validate a config mapping; ``source`` anchors relative paths and names the file in errors."""
    where = str(source) if source is not None else "config"
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: expected a mapping of keys at the top level")
    if "conditions" in raw and "data" not in raw and "tests" not in raw:
        # a design file given by mistake: pydantic's errors would list its keys one by one
        raise ConfigError(f"{where}: a design file (it has conditions:, no data:), not a run config: "
                          "`python -m bayes_dnlr design` reads it (docs/design.md); fit, sample and "
                          "batch read a run config with data: (docs/config.md)")
    try:
        cfg = Config.model_validate(raw)
    except ValidationError as err:
        raise ConfigError(format_errors(err, where, Config)) from None
    bad = range_errors(cfg)
    if bad:
        raise ConfigError(f"{where}: {bad[0]}")
    cfg.source = source
    return cfg


def load_config(path: str | Path) -> Config:
    """Read and validate a YAML config (bayes_dnlr/config/yamlio.py: UTF-8, no duplicated key). Errors
    name the file and the key (or line)."""
    path = Path(path)
    try:
        raw = load_yaml(path, "config file")
    except YamlError as err:
        raise ConfigError(str(err)) from None
    return parse_config(raw, source=path.resolve())
