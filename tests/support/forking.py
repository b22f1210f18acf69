"""The same computation in this process on numba's threads, then in a child forked from it.

numba terminates a forked child that starts a parallel region when its parent used GNU OpenMP; the
package computes in one thread there (``model.threads.parallel_allowed``). The tests of that rule
call ``in_parent_and_forked_child`` and compare the two results.
"""

from __future__ import annotations

import os
import pickle
import warnings
from collections.abc import Callable
from typing import Any


def in_parent_and_forked_child(compute: Callable[[], Any]) -> tuple[Any, Any]:
    """(compute() here on 2 threads, compute() in a child forked right after); asserts that the
    child exited normally (a child numba terminated ends by SIGTERM)."""
    from bayes_dnlr.model import set_threads

    try:
        set_threads(2)
        parent = compute()                                # the parallel driver, in this process
        r, w = os.pipe()
        with warnings.catch_warnings():           # numba's threads are alive here: on purpose
            warnings.filterwarnings("ignore", "This process .* is multi-threaded",
                                    DeprecationWarning)
            pid = os.fork()
        if pid == 0:                                      # pragma: no cover - the child
            try:
                os.write(w, pickle.dumps(compute()))
            finally:
                os._exit(0)
        os.close(w)
        with os.fdopen(r, "rb") as f:
            child = pickle.loads(f.read())
        _, status = os.waitpid(pid, 0)
    finally:
        set_threads(None)
    assert os.waitstatus_to_exitcode(status) == 0
    return parent, child
