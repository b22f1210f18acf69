"""The key a misspelt config key was probably meant to be: ``conditions.sampling`` -> ``sample_rate``.

The keys allowed where the unknown one stands are read from the pydantic models along its path
(through optional values, unions, lists and mappings of models); the closest by ``difflib`` is
offered when it is close enough. Nothing is offered when the path cannot be followed.
"""

from __future__ import annotations

import difflib
import types
import typing
from collections.abc import Sequence

from pydantic import BaseModel

CUTOFF = 0.5        # difflib's ratio: "sampling" -> "sample_rate" 0.53, "strain_mx" -> "strain_max" 0.95


def _members(annotation: object) -> list[object]:
    """The types an annotation may hold: the members of a union (``X | None``, ``Union``,
    ``Annotated``), else the annotation itself."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _members(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return [m for a in typing.get_args(annotation) for m in _members(a)]
    return [annotation]


def _step(annotation: object, part: str) -> list[object]:
    """The annotations reached from ``annotation`` by the path element ``part``."""
    out = []
    for member in _members(annotation):
        origin = typing.get_origin(member)
        args = typing.get_args(member)
        if isinstance(member, type) and issubclass(member, BaseModel):
            field = member.model_fields.get(part) or next(
                (f for f in member.model_fields.values() if f.alias == part), None)
            if field is not None:
                out.append(field.annotation)
        elif origin in (dict, typing.Mapping) and len(args) == 2:
            out.append(args[1])
        elif origin in (list, tuple, Sequence) and args and part.isdigit():
            out.append(args[0])
    return out


def _keys(annotation: object) -> list[str]:
    keys: list[str] = []
    for member in _members(annotation):
        if isinstance(member, type) and issubclass(member, BaseModel):
            for name, field in member.model_fields.items():
                keys.append(field.alias or name)
    return list(dict.fromkeys(keys))


def close_key(model: type[BaseModel], loc: Sequence[str]) -> str | None:
    """The allowed key closest to ``loc[-1]`` at the path ``loc[:-1]`` of ``model`` (None: none
    close, or the path cannot be followed)."""
    if not loc:
        return None
    here: list[object] = [model]
    for part in loc[:-1]:
        here = [nxt for a in here for nxt in _step(a, str(part))]
        if not here:
            return None
    keys = [k for a in here for k in _keys(a)]
    close = difflib.get_close_matches(str(loc[-1]), keys, n=1, cutoff=CUTOFF)
    return close[0] if close else None
