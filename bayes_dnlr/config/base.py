"""The base of every config section: unknown keys refused, NaN and ±inf refused in every number, and
numbers strict: a boolean or a string where a number is expected is an error."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict


def _whole_float(v: Any) -> Any:
    """An integral float (``max_steps: 1e5``, ``walkers: 32.0``) as the whole number it is; anything
    else is left to the strict int (a bool, a string or 32.5 is refused)."""
    if type(v) is float and v.is_integer() and abs(v) < 2.0**63:
        return int(v)
    return v


# a whole number in a strict section: an int, or a float without a fractional part
Whole = Annotated[int, BeforeValidator(_whole_float)]


class Strict(BaseModel):
    """A config section: unknown keys and non-finite numbers are errors (docs/config.md), and numbers
    are strict: YAML's ``true`` is not 1 (``area0: true`` was read as 1 mm²), nor is the string
    ``'24'`` a number. A float field takes an int; a whole-number field (``Whole``) an integral
    float."""

    # NaN and ±inf are refused in every number (docs/config.md, "Validation rules")
    model_config = ConfigDict(extra="forbid", frozen=False, allow_inf_nan=False, strict=True)
