"""numba's on-disk cache keyed also on the modules a compiled function calls into.

numba keys a cached function on the content of its own file only, not on the njit helpers it
calls from other modules: an edit there would load stale machine code. ``depend_on`` adds their
content to the key, so such an edit compiles the function again.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from types import ModuleType


def _file_digest(module: ModuleType) -> bytes:
    return hashlib.sha256(Path(module.__file__).read_bytes()).digest()


def depend_on(dispatcher, *modules: ModuleType) -> None:
    """Key the on-disk cache of ``dispatcher`` also on the source of ``modules``. A no-op if
    numba's internals differ."""
    try:
        cache_file = dispatcher._cache._cache_file
        cache_file._source_stamp = (cache_file._source_stamp,
                                    *(_file_digest(m) for m in modules))
    except (AttributeError, OSError, TypeError):   # pragma: no cover - another numba
        pass
