"""Whether this machine has the model's machine code yet.

numba compiles the model the first time a clone runs it, for this machine's CPU, and keeps the
result beside the source (``__pycache__``, or ``NUMBA_CACHE_DIR``): the first ``fit``,
``sample`` or local ``batch`` of a clone waits up to a minute (the demo's functions took 36 s of
CPU on this project's 2-core machine, the discrepancy's filter 10-20 s more); every later run
loads the code in under a second. The commands say so before that wait, instead of a silent
minute.
"""

from __future__ import annotations

import sys

FIRST_COMPILE_NOTE = ("compiling the model for this machine (numba, the first run of this copy "
                      "only: about a minute; later runs load it in under a second)")


def has_machine_code(dispatcher) -> bool:
    """True when numba's on-disk cache holds code of ``dispatcher`` (an ``njit(cache=True)``
    function) made from its current source: its first call then loads instead of compiling. True
    as well when numba's internals differ from what this reads (no note rather than a wrong one)."""
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except (AttributeError, OSError, EOFError, TypeError, ValueError):
        return True


def first_compile_note() -> str | None:
    """The note to print before the model's first compile on this machine, or None when its code is
    cached (the model's integrator stands for the rest: one clone compiles them together)."""
    from bayes_dnlr.model import kernel

    return None if has_machine_code(kernel.integrate) else FIRST_COMPILE_NOTE


def announce_first_compile() -> None:
    """Print ``first_compile_note()`` on stderr when there is one (before the command's wait)."""
    note = first_compile_note()
    if note:
        print(note, file=sys.stderr, flush=True)
