"""``ConfigError`` and pydantic's validation errors in the package's words: one line that names the
file and the key."""

from __future__ import annotations

import re

from pydantic import ValidationError

from bayes_dnlr.config.suggest import close_key
from bayes_dnlr.errors import BayesDnlrError


class ConfigError(BayesDnlrError, ValueError):
    """A config that cannot be used; the message names the file and the key."""


_UNION_TAGS = {"BaselineNoise", "SampledNoise", "DiscrepancyConfig", "float", "int", "str", "none",
               "constrained-float"}


def _is_type_tag(part: str) -> bool:
    return part in _UNION_TAGS or part.startswith(("function-", "literal["))


_BOUND_TYPES = {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}


def _names_a_key(msg: str) -> bool:
    """A top-level message that already starts with the key it is about (``tests[3].name: ...``)."""
    return re.match(r"^(tests\[\d+\]|parameters|noise|truth|data)[.\w\[\]]*: ", msg) is not None


def _shown(value: object) -> str:
    """A value as the user wrote it in YAML: ``true``, not ``True`` (booleans are not numbers)."""
    if isinstance(value, bool):
        return f"{str(value).lower()} (a YAML boolean)"
    if value is None:
        return "null"
    return repr(value)


def format_errors(err: ValidationError, where: str, model: type | None = None) -> str:
    """One line: the first problem, then the others. ``model``: the pydantic model validated, for
    the key a misspelt one was probably meant to be (config/suggest.py)."""
    entries = []
    for e in err.errors():
        # pydantic puts union member tags in loc; drop them to keep the key readable
        loc = tuple(str(x) for x in e["loc"] if not _is_type_tag(str(x)))
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "extra_forbidden":
            close = close_key(model, loc) if model is not None else None
            msg = (f"unknown key (did you mean {close}? see docs/config.md)" if close else
                   "unknown key (check the spelling; see docs/config.md)")
        elif e["type"] == "missing":
            msg = "required key is missing"
        elif e["type"] == "finite_number":
            msg = f"expected a finite number, got {e.get('input')!r}"
        elif e["type"] in ("int_parsing", "int_from_float", "int_type"):
            msg = f"expected a whole number, got {_shown(e.get('input'))}"
        elif e["type"] in ("float_type", "float_parsing"):
            msg = f"expected a number, got {_shown(e.get('input'))}"
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
