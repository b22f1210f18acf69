"""Ctrl-C (SIGINT) during sampling, taken at a step boundary.

Python raises KeyboardInterrupt wherever the signal lands; inside the log-density emcee catches it,
prints the walkers' positions and a traceback, then re-raises. While ``deferred_interrupt()`` is
active the first SIGINT only sets ``requested``: the sampler finishes the step in progress, commits
the block (inference/mcmc/ensemble.py) and raises ``Interrupted`` outside emcee. A second Ctrl-C interrupts
at once (the default handler is back). Outside the main thread (Dask workers) it does nothing.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager


class Interrupted(KeyboardInterrupt):
    """Ctrl-C, taken cleanly: the message says what was kept; the CLI prints it and exits with 130."""


class InterruptRequest:
    """Whether a deferred SIGINT has arrived."""

    def __init__(self) -> None:
        self.requested = False


@contextmanager
def deferred_interrupt() -> Iterator[InterruptRequest]:
    """Turn the first SIGINT into ``request.requested = True`` for the block (see the module doc)."""
    request = InterruptRequest()
    if threading.current_thread() is not threading.main_thread():
        yield request
        return
    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.SIG_IGN:          # started in the background with SIGINT ignored
        yield request
        return

    def handler(signum, frame) -> None:
        request.requested = True
        signal.signal(signal.SIGINT, previous)      # a second Ctrl-C interrupts at once

    signal.signal(signal.SIGINT, handler)
    try:
        yield request
    finally:
        signal.signal(signal.SIGINT, previous)
