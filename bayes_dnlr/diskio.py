"""Writing files that survive a full disk and a SIGKILL: free-space checks, clean errors, fsync of a
directory, temporaries of killed writers, and the kill points of the crash tests.

Used by rundir.write_atomic (every JSON/YAML/netCDF output), runs/chains.py (chains.h5) and the
.npz caches of the run folder (smoothed strains, the report's curves); ``own_dir``, the folders the
package makes inside an output folder, never a symbolic link out of it.
"""

from __future__ import annotations

import errno
import io
import os
import re
import signal
from collections import Counter
from pathlib import Path

import numpy as np

from bayes_dnlr.errors import DiskFullError, StorageError

DISK_FULL = {errno.ENOSPC, errno.EDQUOT}
# write errors the user must fix in the environment (not bugs): reported as one line
ENVIRONMENT = DISK_FULL | {errno.EIO, errno.EFBIG, errno.EROFS, errno.EACCES, errno.EPERM}
KILL_ENV = "BAYES_DNLR_KILL_AT"


def megabytes(n: float) -> str:
    return f"{n / 1e6:.1f} MB"


def error_code(err: BaseException) -> int | None:
    """The errno of a failed write: OSError's, or the one HDF5 names in its message (h5py raises
    some failed writes, e.g. a dataset flush, as RuntimeError with "errno = 28" in the text)."""
    if isinstance(err, OSError) and err.errno is not None:
        return err.errno
    if isinstance(err, OSError | RuntimeError):
        found = re.search(r"errno = (\d+)", str(err))
        if found:
            return int(found.group(1))
    return None


def storage_error(err: BaseException, path: Path, consequence: str = "") -> StorageError | None:
    """The one-line error for a failed write of ``path`` (None when ``err`` is not a write error of
    the environment, e.g. a bug: it is then re-raised as it is)."""
    code = error_code(err)
    if code not in ENVIRONMENT:
        return None
    tail = f"; {consequence}" if consequence else ""
    if code in DISK_FULL:
        return DiskFullError(f"disk full: cannot write {path} ({os.strerror(code)}; "
                             f"{megabytes(free_bytes(path))} free there){tail}")
    return StorageError(f"cannot write {path} ({os.strerror(code)}){tail}")


def free_bytes(path: Path) -> float:
    """Bytes an unprivileged user may still write on the file system of ``path`` (its folder);
    inf when unknown."""
    folder = Path(path).parent
    try:
        st = os.statvfs(folder)
    except OSError:
        return float("inf")
    return float(st.f_bavail) * st.f_frsize


def ensure_free(path: Path, need: float, consequence: str = "") -> None:
    """Raise DiskFullError before writing about ``need`` bytes to ``path`` when they do not fit."""
    free = free_bytes(path)
    if free < need:
        tail = f"; {consequence}" if consequence else ""
        raise DiskFullError(f"disk full: {megabytes(free)} free in {Path(path).parent}, and writing "
                            f"{Path(path).name} needs about {megabytes(need)}{tail}")


def fsync_dir(folder: Path) -> None:
    """Make a rename in ``folder`` durable (a no-op where directories cannot be opened)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def own_dir(path: Path, make: bool = True) -> Path:
    """The folder ``path``, one the package makes inside an output folder (a run's figures/,
    export/, .cache/, a batch's figures/): made when missing, and when a symbolic link stands in
    its place, the link is removed (its target is left untouched) and a real folder made. So no
    output is written through a link out of the folder the user named (docs/cli.md, "Symbolic
    links"). A file in its place raises FileExistsError. ``make=False``: only the link is removed
    (the caller makes the folder when it writes)."""
    path = Path(path)
    if path.is_symlink():
        path.unlink()
    if make:
        path.mkdir(exist_ok=True)
    return path


def temp_path(path: Path) -> Path:
    """The temporary a writer of ``path`` in this process uses: ``.<name>.<pid>.tmp`` beside it."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def keep_cache_arrays(path: Path, **arrays) -> bool:
    """Write ``arrays`` as the .npz file ``path`` in one step (a temporary, then a rename); False
    when it cannot be written, which is no error for a cache: the next command computes them again."""
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    tmp = temp_path(path)
    try:
        own_dir(path.parent)
        tmp.unlink(missing_ok=True)
        with open(tmp, "xb") as f:          # "x": a link planted at the temporary is not followed
            f.write(buf.getvalue())
        os.replace(tmp, path)
    except OSError:
        tmp.unlink(missing_ok=True)
        return False
    return True


def process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def sweep_stale_temps(path: Path) -> None:
    """Remove ``.<name>.<pid>.tmp`` temporaries of ``path`` whose writer process is gone (killed
    while writing): retries do not pile them up. A live writer's temporary is left alone."""
    prefix = f".{path.name}."
    try:
        entries = list(path.parent.iterdir())
    except OSError:
        return
    for p in entries:
        name = p.name
        if not (name.startswith(prefix) and name.endswith(".tmp")):
            continue
        pid = name[len(prefix):-len(".tmp")]
        if pid.isdigit() and int(pid) != os.getpid() and not process_alive(int(pid)):
            p.unlink(missing_ok=True)


# ---------------------------------------------------------------- kill points (crash tests)

def _kill_spec(text: str) -> dict[str, int]:
    """``name[@n],name[@n]`` -> {name: n}: SIGKILL at the n-th time (from 1) ``name`` is reached."""
    spec = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        name, _, n = item.partition("@")
        spec[name] = int(n) if n else 1
    return spec


_KILL_AT = _kill_spec(os.environ.get(KILL_ENV, ""))
_reached: Counter[str] = Counter()


def kill_point(name: str) -> None:
    """A named instant of a write. With BAYES_DNLR_KILL_AT=name[@n] in the environment, the process
    kills itself with SIGKILL there (tests/runs/test_chains_crash.py); otherwise nothing happens."""
    if _KILL_AT:
        _reached[name] += 1
        if _KILL_AT.get(name) == _reached[name]:
            os.kill(os.getpid(), signal.SIGKILL)
