"""One process per folder: an advisory ``flock`` on a lock file that is removed on the way out.

The kernel drops an ``flock`` with its process, so a SIGKILL never leaves a lock that blocks the
next run. On a normal exit the file is removed too, while still held, so no lock file is left behind.
A process that locked a file its predecessor has just removed notices it (the path no longer names
the inode it holds) and takes the new file, so two processes can never both hold the lock.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


class LockBusy(Exception):
    """Another process holds the lock."""


@contextmanager
def exclusive_lock(path: Path) -> Iterator[None]:
    """Hold ``path`` locked for the block; raise ``LockBusy`` at once when another process holds it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        f = open(path, "a+")  # noqa: SIM115 - held for the whole block
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.close()
            raise LockBusy(str(path)) from None
        try:
            same = os.stat(path).st_ino == os.fstat(f.fileno()).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        f.close()
    try:
        yield
    finally:
        path.unlink(missing_ok=True)
        fcntl.flock(f, fcntl.LOCK_UN)
        f.close()
