"""``import emcee`` without scipy.stats.

emcee's ``moves/__init__.py`` imports its KDEMove, whose module imports ``scipy.stats`` at import
time: about 0.4 s on an idle machine and over 1 s on a busy one, paid by every ``sample`` for a
move it never uses. ``load_emcee`` imports emcee with that one module deferred: ``emcee.moves.
KDEMove`` and ``emcee.moves.kde`` stay available and import the real module (and scipy.stats) on
first use. Everything else is emcee's own code, unchanged.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import Any

_KDE = "emcee.moves.kde"


def load_emcee() -> types.ModuleType:
    """The emcee module, imported without scipy.stats when it was not imported yet."""
    if "emcee" in sys.modules or "scipy.stats" in sys.modules:
        import emcee

        return emcee
    placeholder = types.ModuleType(_KDE)
    placeholder.KDEMove = None          # what `from .kde import KDEMove` reads while emcee loads
    placeholder.__all__ = ["KDEMove"]
    sys.modules[_KDE] = placeholder
    try:
        import emcee
        import emcee.moves as moves
    finally:
        if sys.modules.get(_KDE) is placeholder:
            del sys.modules[_KDE]
    for name in ("KDEMove", "kde"):
        if getattr(moves, name, placeholder) in (None, placeholder):
            moves.__dict__.pop(name, None)
    previous = moves.__dict__.get("__getattr__")

    def __getattr__(name: str) -> Any:      # PEP 562: only names not found in the module
        if name in ("KDEMove", "kde"):
            real = importlib.import_module(_KDE)
            moves.kde = real
            moves.KDEMove = real.KDEMove
            return getattr(moves, name)
        if previous is not None:
            return previous(name)
        raise AttributeError(f"module 'emcee.moves' has no attribute {name!r}")

    moves.__getattr__ = __getattr__
    return emcee
