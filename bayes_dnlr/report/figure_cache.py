"""How the report's figures are drawn: only when their inputs change, and beside the page.

- A rebuilt report (``report --force``, a batch page, a config comment edited) keeps each PNG whose
  inputs are the same: the report draws each figure through ``drawn(figure_function, ...)``; the
  function's name, its arguments (arrays by their bytes), the package's and matplotlib's versions
  and the source of the figure modules make a key, written into the PNG's text chunk. A PNG that
  holds the same key is not drawn again. The figure functions themselves always draw.
- When a core is free (two or more, and one of them idle now), a worker process forked when the
  session starts (before this process runs any other Python thread; ``warm``, its first task)
  draws the figures handed to it (``aside=True``) while this process draws the others. The
  worker is given one figure at a time, the next when it is done with the last: a process pool
  moves a task to its worker's queue ahead of time, and a moved task can no longer be taken back.
  At the session's end this process draws those the worker has not started yet, the last handed
  over first, then waits for the rest; the page embeds every PNG after that
  (``page_parts.embed``). Under load the figures are drawn here, one by one.
- During a session what is already loaded (the modules, the run, the model) is kept out of the
  garbage collector's full passes (``gc.freeze``, again before each figure and before the model
  curves: ``keep_long_lived``): each full pass walked all of it, 0.1-0.45 s, five times in a first
  build of a real curve's report. The figures' own garbage is still collected; the session's end
  returns everything to the collector.
"""

from __future__ import annotations

import functools
import gc
import hashlib
import os
import pickle
import sys
import threading
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Future
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.machine_load import other_runnable

KEY = "bayes_dnlr-figure-key"
_current: ContextVar[str | None] = ContextVar("figure_key", default=None)


@dataclass
class _Figures:
    used: set[Path] = field(default_factory=set)
    worker: Any = None                          # a ProcessPoolExecutor of one forked process
    waiting: list[Callable[[], Path]] = field(default_factory=list)   # not handed to the worker yet
    pending: list[tuple[Future, Callable[[], Path]]] = field(default_factory=list)   # handed
    busy: Future | None = None                  # the worker's task now (its warm-up first)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def feed(self, _done: Future | None = None) -> None:
        """Hand the worker the first waiting figure when it has nothing to do (also called in
        the pool's own thread, as the worker's last task ends)."""
        with self.lock:
            if self.worker is None or not self.waiting or (self.busy is not None
                                                          and not self.busy.done()):
                return
            task = self.waiting.pop(0)
            try:
                future = self.busy = self.worker.submit(task)
            except RuntimeError:          # the pool is shutting down, or broken: drawn here
                self.waiting.insert(0, task)
                return
            self.pending.append((future, task))
        future.add_done_callback(self.feed)

    def take_back(self) -> Callable[[], Path] | None:
        """The last waiting figure, which the worker will not be given (None: there is none)."""
        with self.lock:
            return self.waiting.pop() if self.waiting else None


_session: ContextVar[_Figures | None] = ContextVar("figures", default=None)


def _single_threaded() -> bool:
    """No other Python thread (one could hold the import lock the worker needs). Native threads
    (BLAS's, numba's) stay idle in the worker, which uses neither."""
    import threading

    return threading.active_count() == 1


def _nothing() -> None:
    return None


def _free_core() -> bool:
    """Two cores or more for this process, and one of them free now (``machine_load``: not the
    last minute's load, which still counts the ``sample`` run just before the report)."""
    cores = len(os.sched_getaffinity(0))
    return cores >= 2 and other_runnable() <= cores - 2


def _fork_worker():
    if not (sys.platform == "linux" and _free_core() and _single_threaded()):
        return None
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # the pool forks at its first task (the warm-up, submitted by the session at once), while this
    # process has no other thread
    return ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork"))


@contextmanager
def figure_session(aside: bool = True, warm: Callable[[], None] | None = None) -> Iterator[set[Path]]:
    """The block's figures: yields the set of the PNGs ``drawn`` returns in it (drawn or kept);
    with ``aside``, a worker process draws those handed to it (``warm``: its first task, before any
    figure). At the end every PNG is written."""
    gc.freeze()                  # before the fork, too: the worker shares these pages untouched
    worker = _fork_worker() if aside else None
    session = _Figures(worker=worker, busy=worker.submit(warm or _nothing) if worker else None)
    token = _session.set(session)
    try:
        if session.busy is not None:
            session.busy.add_done_callback(session.feed)
        yield session.used
        # This process is done with its own figures: it draws those the worker has not started
        # yet, the last handed over first (the worker takes them in order), so that the two
        # finish about together whatever the figures cost on this run.
        while (again := session.take_back()) is not None:
            again()
        with session.lock:
            handed = list(session.pending)
        for future, again in handed:
            try:
                future.result()
            except Exception as err:  # noqa: BLE001 - a lost worker: draw here; a figure's own error again
                from concurrent.futures.process import BrokenProcessPool

                if not isinstance(err, BrokenProcessPool):
                    raise
                again()
    finally:
        _session.reset(token)
        if session.worker is not None:
            session.worker.shutdown(wait=True, cancel_futures=True)
        gc.unfreeze()


def keep_long_lived() -> None:
    """In a figure session, what exists now is kept out of the collector's full passes until the
    session ends (it outlives what comes next: a figure, the model curves)."""
    if _session.get() is not None:
        gc.freeze()


def png_metadata() -> dict[str, str]:
    """The text chunk of the figure being saved (empty outside ``drawn``)."""
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
    elif isinstance(obj, float | int | str | bool | np.generic | Path) or obj is None:
        h.update(f"{type(obj).__name__}:{obj!r};".encode())
    else:
        h.update(f"{type(obj).__name__}:{np.asarray(obj).tobytes().hex()};".encode())


def _matplotlib_version() -> str:
    """matplotlib's version, without importing it when no figure is drawn yet (a rebuild that keeps
    every figure: the import took 0.2-0.35 s, the package metadata 0.1 s)."""
    if "matplotlib" in sys.modules:
        return sys.modules["matplotlib"].__version__
    from importlib.metadata import version

    return version("matplotlib")


@functools.cache
def _code_key() -> str:
    """The versions and the figure modules' source: a figure drawn by other code is drawn again."""
    from bayes_dnlr import __version__

    here = Path(__file__).parent
    h = hashlib.sha256(f"{__version__} {_matplotlib_version()}".encode())
    for name in ("figures.py", "rank.py", "canvas.py", "corner_loader.py", "figure_cache.py"):
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


def _draw(key: str, func: Callable[..., Path], args: tuple, kwargs: dict) -> Path:
    keep_long_lived()
    token = _current.set(key)
    try:
        return func(*args, **kwargs)
    finally:
        _current.reset(token)


def _picklable(func: Callable[..., Path]) -> bool:
    try:
        pickle.dumps(func)
    except (pickle.PicklingError, AttributeError, TypeError):
        return False
    return True


def drawn(func: Callable[..., Path], *args: Any, aside: bool = False, **kwargs: Any) -> Path:
    """``func(*args, **kwargs)``, a figure function writing the PNG given as its ``Path`` argument,
    unless that PNG was drawn from the same inputs; returns the PNG's path. ``aside``: by the
    worker process when there is one (the PNG is then written by the end of ``figure_session``)."""
    path = Path(kwargs.get("path") or next(a for a in args if isinstance(a, Path)))
    h = hashlib.sha256(f"{getattr(func, '__name__', func)} {_code_key()}".encode())
    for value in args:
        if not isinstance(value, Path) or value != path:
            _feed(h, value)
    for name, value in sorted(kwargs.items()):
        if name != "path":
            _feed(h, name)
            _feed(h, value)
    key = h.hexdigest()
    session = _session.get()
    if session is not None:
        session.used.add(path)
    if stored_key(path) == key:
        return path
    if aside and session is not None and session.worker is not None and _picklable(func):
        with session.lock:
            session.waiting.append(functools.partial(_draw, key, func, args, kwargs))
        session.feed()
        return path
    return _draw(key, func, args, kwargs)
