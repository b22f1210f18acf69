"""Figures drawn only when their inputs change: a rebuilt report (``report --force``, a batch page, a
config comment edited) keeps each PNG whose inputs are the same.

The report draws each figure through ``drawn(figure_function, ...)``: the function's name, its
arguments (arrays by their bytes), the package's and matplotlib's versions and the source of the
figure modules make a key, written into the PNG's text chunk. When the PNG the call would write
holds the same key, the figure is not drawn again. The figure functions themselves always draw.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

import numpy as np

KEY = "bayes_dnlr-figure-key"
_current: ContextVar[str | None] = ContextVar("figure_key", default=None)
_used: ContextVar[set[Path] | None] = ContextVar("figures_used", default=None)


@contextmanager
def tracking() -> Iterator[set[Path]]:
    """The set of the PNGs ``drawn`` returns inside the block (drawn or kept)."""
    used: set[Path] = set()
    token = _used.set(used)
    try:
        yield used
    finally:
        _used.reset(token)


def png_metadata() -> dict[str, str]:
    """The text chunk of the figure being saved (empty outside ``cached``)."""
    key = _current.get()
    return {KEY: key} if key else {}


def _feed(h, obj: Any) -> None:
    """Hash ``obj`` by value: arrays by dtype, shape and bytes; containers element by element."""
    if isinstance(obj, np.ndarray):
        a = np.ascontiguousarray(obj)
        h.update(f"a{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    elif isinstance(obj, Mapping):
        h.update(b"{")
        for k, v in obj.items():
            _feed(h, k)
            _feed(h, v)
        h.update(b"}")
    elif isinstance(obj, list | tuple):
        h.update(b"[")
        for v in obj:
            _feed(h, v)
        h.update(b"]")
    elif isinstance(obj, float | int | str | bool | np.generic) or obj is None:
        h.update(f"{type(obj).__name__}:{obj!r};".encode())
    else:
        h.update(f"{type(obj).__name__}:{np.asarray(obj).tobytes().hex()};".encode())


@functools.cache
def _code_key() -> str:
    """The versions and the figure modules' source: a figure drawn by other code is drawn again."""
    import matplotlib

    from bayes_dnlr import __version__

    here = Path(__file__).parent
    h = hashlib.sha256(f"{__version__} {matplotlib.__version__}".encode())
    for name in ("figures.py", "rank.py", "figure_cache.py"):
        h.update((here / name).read_bytes())
    return h.hexdigest()


def stored_key(path: Path) -> str | None:
    """The key in the text chunk of the PNG at ``path`` (None: no file, or none written)."""
    if not path.is_file():
        return None
    try:
        from PIL import Image

        with Image.open(path) as im:
            return im.info.get(KEY)
    except (OSError, ValueError):
        return None


def drawn(func: Callable[..., Path], *args: Any, **kwargs: Any) -> Path:
    """``func(*args, **kwargs)``, a figure function writing the PNG given as its ``Path`` argument,
    unless that PNG was drawn from the same inputs; returns the PNG's path."""
    path = kwargs.get("path") or next(a for a in args if isinstance(a, Path))
    h = hashlib.sha256(f"{getattr(func, '__name__', func)} {_code_key()}".encode())
    for value in args:
        if value is not path:
            _feed(h, value)
    for name, value in sorted(kwargs.items()):
        if name != "path":
            _feed(h, name)
            _feed(h, value)
    key = h.hexdigest()
    used = _used.get()
    if used is not None:
        used.add(Path(path))
    if stored_key(Path(path)) == key:
        return Path(path)
    token = _current.set(key)
    try:
        return func(*args, **kwargs)
    finally:
        _current.reset(token)
