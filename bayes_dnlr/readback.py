"""Reading back the package's own files (chains.h5, posterior.nc, fit.json, summary.json, the
caches): within a deadline, and a damaged file named.

HDF5 can hang on a damaged file and no Python signal handler reaches it: its SWMR reader retries a
metadata block whose checksum fails 100 times with a sleep that doubles each time (the process
sleeps at zero CPU for hours), and a damaged global heap (where h5py keeps string attributes, which
carry no checksum) can spin at full CPU. So an HDF5 read runs in a child forked for it
(``within_deadline``): the child sends what it read, piece by piece, through a pipe; the parent
waits at most ``deadline(path)`` seconds, then kills it. The pieces that arrived say what can still
be read. Ctrl-C stops the wait (the child is killed with it).

Where this process runs other Python threads (a Dask worker, a figure worker's pool) a fork could
copy a lock another thread holds, so the read runs here, without the deadline.
"""

from __future__ import annotations

import faulthandler
import json
import os
import pickle
import select
import signal
import struct
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from bayes_dnlr.errors import DamagedFileError

DEADLINE_ENV = "BAYES_DNLR_READ_SECONDS"
BASE_SECONDS = 4.0           # a few MB of ours are read in 10-50 ms: the base is a wide margin
BYTES_PER_SECOND = 50e6      # and a large chain gets time in proportion (gzip inflates >100 MB/s)
_HEADER = struct.Struct("<Q")

Emit = Callable[[str, Any], None]


def deadline(path: Path) -> float:
    """Seconds a read of ``path`` may take: BASE_SECONDS plus its size at BYTES_PER_SECOND, or
    the seconds in BAYES_DNLR_READ_SECONDS (a slow network file system)."""
    env = os.environ.get(DEADLINE_ENV, "").strip()
    if env:
        try:
            return max(float(env), 0.1)
        except ValueError:
            pass
    try:
        size = os.stat(path).st_size
    except OSError:
        size = 0
    return BASE_SECONDS + size / BYTES_PER_SECOND


def single_threaded() -> bool:
    """No other Python thread in this process (one could hold a lock a forked child needs)."""
    return threading.active_count() == 1


def _can_fork() -> bool:
    return hasattr(os, "fork") and sys.platform != "win32" and single_threaded()


class Broken:
    """A piece that could not be read: why (sent in its place)."""

    def __init__(self, why: str) -> None:
        self.why = why

    def __repr__(self) -> str:
        return f"Broken({self.why!r})"


def piece(emit: Emit, name: str, read: Callable[[], Any]) -> None:
    """``emit(name, read())``, or ``emit(name, Broken(why))`` when ``read`` fails: a damaged piece
    does not keep the next ones from being read."""
    try:
        value = read()
    except Exception as err:  # noqa: BLE001 - any failure of a read is the file's damage
        value = Broken(_describe(err))
    emit(name, value)


class Pieces(dict):
    """What a read sent back, by name; ``failure`` says why it stopped early (None: it ended)."""

    failure: str | None = None


def within_deadline(read: Callable[[Emit], None], path: Path) -> Pieces:
    """Run ``read(emit)``, which calls ``emit(name, value)`` for each piece it read, in a child
    process with a deadline (in this process where forking is not safe, see the module doc). An
    exception raised by ``read`` ends it: its text becomes ``failure``, the pieces sent before it
    are kept. A child past its deadline, or killed (a crash of the HDF5 library), ends it too."""
    path = Path(path)
    if not _can_fork():
        return _here(read)
    seconds = deadline(path)
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:                                  # pragma: no cover - the child (coverage cannot see it)
        os.close(r)
        _child(read, w, seconds)
    os.close(w)
    try:
        out, ended = _collect(r, seconds)
    finally:
        os.close(r)
        code = _reap(pid)
    if not ended:
        sig = -code if code is not None and code < 0 else None
        out.failure = (f"reading it crashed the HDF5 library (signal {signal.Signals(sig).name})"
                       if sig else "the reading process ended without a result")
    return out


def _here(read: Callable[[Emit], None]) -> Pieces:
    out = Pieces()
    try:
        read(out.__setitem__)
    except Exception as err:  # noqa: BLE001 - any failure of a read is the file's damage
        out.failure = _describe(err)
    return out


def _describe(err: BaseException) -> str:
    text = str(err.args[0] if isinstance(err, KeyError) and err.args else err).strip()
    text = text or type(err).__name__
    return text.splitlines()[0][:300]


def _child(read: Callable[[Emit], None], w: int, seconds: float) -> None:  # pragma: no cover
    """The forked reader: killed by its own alarm if the parent is gone or stuck; never returns."""
    status = 0
    try:
        faulthandler.disable()        # a crash of HDF5 in it is the parent's one-line failure
        signal.signal(signal.SIGINT, signal.SIG_DFL)     # Ctrl-C ends it at once, even inside HDF5
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.alarm(int(seconds) + 2)

        def emit(name: str, value: Any) -> None:
            _send(w, ("piece", name, value))

        try:
            read(emit)
        except Exception as err:  # noqa: BLE001 - sent to the parent as the failure
            _send(w, ("failure", _describe(err), None))
        else:
            _send(w, ("end", None, None))
    except BaseException:
        status = 1
    finally:
        os._exit(status)


def _send(w: int, message: tuple) -> None:  # pragma: no cover - runs in the child
    data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    view = memoryview(_HEADER.pack(len(data)) + data)
    while view:
        view = view[os.write(w, view):]


def _collect(r: int, seconds: float) -> tuple[Pieces, bool]:
    """The pieces the child sends, and whether it ended (with a result or a failure)."""
    out = Pieces()
    try:
        for kind, name, value in _messages(r, time.monotonic() + seconds):
            if kind == "piece":
                out[name] = value
                continue
            if kind == "failure":
                out.failure = name
            return out, True
    except TimeoutError:
        out.failure = (f"reading it did not end within {seconds:.0f} s and was stopped (the reader "
                       "retries or loops on damaged metadata)")
        return out, True
    return out, False             # the pipe closed without an end: the child died


def _messages(r: int, ends: float) -> Iterator[tuple]:
    buf = bytearray()
    while True:
        need = _HEADER.size
        if len(buf) >= need:
            size = _HEADER.unpack_from(buf)[0]
            if len(buf) >= need + size:
                yield pickle.loads(bytes(buf[need:need + size]))
                del buf[:need + size]
                continue
        left = ends - time.monotonic()
        if left <= 0:
            raise TimeoutError
        ready, _, _ = select.select([r], [], [], left)
        if not ready:
            raise TimeoutError
        chunk = os.read(r, 1 << 20)
        if not chunk:
            return
        buf += chunk


def _reap(pid: int) -> int | None:
    """Kill the child if it still runs and collect it; its exit code (negative: the signal)."""
    try:
        done, status = os.waitpid(pid, os.WNOHANG)
        if not done:
            os.kill(pid, signal.SIGKILL)
            done, status = os.waitpid(pid, 0)
    except ChildProcessError:
        return None
    return os.waitstatus_to_exitcode(status)


# ---------------------------------------------------------------- caches and JSON files

def read_npz(path: Path) -> dict[str, Any] | None:
    """Every array of the .npz cache ``path``, or None when it is missing or damaged (a cache that
    cannot be read is computed again: zip's CRC-32 tells a changed byte, its directory a cut)."""
    import numpy as np

    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except Exception:  # noqa: BLE001 - BadZipFile, zlib.error, EOFError, OSError, ValueError...
        return None


# ---------------------------------------------------------------- JSON files of a run folder

def read_json(path: Path, what: str = "") -> dict[str, Any]:
    """A JSON object the package wrote (fit.json, summary.json, ...); DamagedFileError naming the
    file and what is wrong when it is not one (cut, bytes changed, another file put there)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as err:
        if not path.exists():
            raise
        raise DamagedFileError(f"{path}: cannot be read ({err.strerror or err})") from None
    try:
        value = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as err:
        raise DamagedFileError(f"{path}: damaged, not the JSON {what or 'file'} the package wrote "
                               f"({_describe(err)})") from None
    if not isinstance(value, dict):
        raise DamagedFileError(f"{path}: damaged, not the JSON {what or 'file'} the package wrote "
                               f"(a {type(value).__name__}, not an object)")
    return value
