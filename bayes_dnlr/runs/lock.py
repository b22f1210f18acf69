"""One writer per run directory (``sample.lock``; ``batch.lock`` for a batch's output folder): an
advisory ``flock`` that the kernel releases even when the process is killed, and a file that is
removed when the command ends (no lock is left behind, on success or failure).

Removing a lock file is safe with the inode check: a process that opened the file just before the
holder removed it finds, once it has the lock, that the path no longer names its file, and tries
again on the new one.

A run directory that cannot be written (read-only file system, no permission) needs no lock:
nobody can write into it, so a command that only reads a finished run (``sample`` of a finished
chain) proceeds, and one that has to write fails at its first write with one line.
"""

from __future__ import annotations

import errno
import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from bayes_dnlr.diskio import storage_error
from bayes_dnlr.errors import BayesDnlrError, RunError

READ_ONLY = {errno.EROFS, errno.EACCES, errno.EPERM}


def _open_locked(path: Path, busy: str, error: type[BayesDnlrError]):
    """The open, locked lock file at ``path`` (None when the folder is read-only)."""
    while True:
        try:
            # O_NOFOLLOW: a link in the lock's place is replaced, never opened (nor its target made)
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_NOFOLLOW, 0o644)
            f = os.fdopen(fd, "a+")
        except OSError as err:
            if err.errno == errno.ELOOP:
                path.unlink(missing_ok=True)
                continue
            if err.errno in READ_ONLY:
                return None
            raise (storage_error(err, path) or err) from None
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.close()
            raise error(busy) from None
        try:
            same = os.stat(path).st_ino == os.fstat(f.fileno()).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return f
        f.close()                 # the holder removed it meanwhile: lock the new file


@contextmanager
def run_lock(run_dir: Path, name: str, busy: str,
             error: type[BayesDnlrError] = RunError) -> Iterator[None]:
    """Hold ``run_dir/name`` exclusively for the block; ``error(busy)`` when another process holds
    it. The lock file is removed at the end."""
    path = Path(run_dir) / name
    f = _open_locked(path, busy, error)
    try:
        yield
    finally:
        if f is not None:
            try:
                path.unlink(missing_ok=True)   # while still holding it (see the module doc)
            except OSError:
                pass
            fcntl.flock(f, fcntl.LOCK_UN)
            f.close()
