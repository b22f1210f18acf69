"""The base of every config section: unknown keys refused, NaN and ±inf refused in every number."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class Strict(BaseModel):
    """A config section: unknown keys and non-finite numbers are errors (docs/config.md)."""

    # NaN and ±inf are refused in every number (docs/config.md, "Validation rules")
    model_config = ConfigDict(extra="forbid", frozen=False, allow_inf_nan=False)
