"""Threads of the compiled batch functions (numba prange): the environment's default and a setter.

numba sizes its pool from ``NUMBA_NUM_THREADS`` (default: the CPU count) when the process starts;
the number used by the parallel functions can only be lowered below that. ``OMP_NUM_THREADS`` is
honoured as well, so that batch runs started with ``OMP_NUM_THREADS=1`` do not oversubscribe.
Parallelism never changes results here: every parameter set is computed on its own.

Importing this module chooses how idle OpenMP threads wait, unless the environment sets
``OMP_WAIT_POLICY`` itself (it only takes effect if OpenMP has not started yet in this process):

- **a free core** (no other runnable task would need the second thread's core, by the kernel's count
  of runnable tasks when the module is imported): a short spin,
  ``OMP_WAIT_POLICY=ACTIVE`` with ``GOMP_SPINCOUNT=30000`` (tens of microseconds, then sleep). The
  second thread is awake when the next call of the likelihood comes: the sampling loop of the
  shipped example took 0.32 s against 0.44 s, both cores busy (CPU/wall 1.85 against 1.25);
  after the spin it sleeps, so a long session does not burn a core.
- **a busy machine**: ``PASSIVE``. A spinning thread then holds a core that the Python thread
  waits for: the same loop took 1.0 s spinning against 0.46 s passive with one core taken by another
  process (and 30 ms instead of 1 ms per call in a 2-thread batch before).
"""

from __future__ import annotations

import os

import numba
import numpy as np

from bayes_dnlr.machine_load import other_runnable

SPIN_COUNT = "30000"


def _wait_policy() -> dict[str, str]:
    """The OpenMP wait settings for this process (see the module doc): spin briefly only when a
    core is free for the second thread besides this one."""
    if (os.cpu_count() or 1) - other_runnable() >= 2:
        return {"OMP_WAIT_POLICY": "ACTIVE", "GOMP_SPINCOUNT": SPIN_COUNT}
    return {"OMP_WAIT_POLICY": "PASSIVE"}


if "OMP_WAIT_POLICY" not in os.environ:
    os.environ.update(_wait_policy())

_configured = False
_forked = False


def _after_fork_in_child() -> None:
    global _forked
    _forked = True


os.register_at_fork(after_in_child=_after_fork_in_child)


def parallel_allowed() -> bool:
    """Whether a compiled function may start numba threads here: more than one thread is set,
    and this is not a process forked from one that imported this module. numba terminates a forked
    child that starts a parallel region when its parent used GNU OpenMP (numba's "omp" layer, the
    fastest here), so forked children (multiprocessing's fork start method, fork servers) compute
    in one thread, with the same results."""
    ensure_configured()
    return not _forked and numba.get_num_threads() > 1


def available_threads() -> int:
    """The size of numba's pool: ``NUMBA_NUM_THREADS`` or the CPU count."""
    return int(numba.config.NUMBA_NUM_THREADS)


def default_threads() -> int:
    """Threads used unless ``set_threads`` is called: the pool size, lowered to ``OMP_NUM_THREADS``
    when that is set to a positive integer (an unparsable value is ignored)."""
    n = available_threads()
    omp = os.environ.get("OMP_NUM_THREADS", "").strip()
    if omp.isdigit() and int(omp) > 0:
        n = min(n, int(omp))
    return n


def set_threads(n: int | None = None) -> int:
    """Use ``n`` threads in the batch functions (None: ``default_threads()``); returns the number
    in use, which is ``n`` capped at the pool size (``available_threads()``).

    Applies to calls made from the calling thread (numba's rule). Raises ValueError for n < 1.
    """
    global _configured
    if n is None:
        n = default_threads()
    if isinstance(n, bool) or not isinstance(n, int | np.integer):
        raise ValueError(f"threads must be a positive integer, got {n!r}")
    if n < 1:
        raise ValueError(f"threads must be >= 1, got {n}")
    n = min(int(n), available_threads())
    numba.set_num_threads(n)
    _configured = True
    return n


def use_threads(n: int | None = None) -> int:
    """Threads for a run: ``n`` (a user setting, e.g. config ``sampler.threads``) capped at
    ``default_threads()``, so that ``NUMBA_NUM_THREADS`` and ``OMP_NUM_THREADS`` are upper limits
    a setting cannot exceed (batch workers started with 1 thread stay at 1); None: the default.
    Returns the number in use."""
    limit = default_threads()
    return set_threads(limit if n is None else min(int(n), limit))


def get_threads() -> int:
    """The number of threads the batch functions use now."""
    ensure_configured()
    return int(numba.get_num_threads())


def ensure_configured() -> None:
    """Apply ``default_threads()`` once, unless ``set_threads`` was called before."""
    if not _configured:
        set_threads(None)

