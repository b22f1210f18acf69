"""A chains.h5 left "open for write" by a killed `sample`, made readable by plain h5py again.

A SWMR writer marks the file in its superblock (the consistency flags of superblock versions 2 and
3); a killed one leaves the mark and HDF5 refuses a plain ``h5py.File(path, "r")`` ("already open
for write ... h5clear"). ``release_stale_writer`` clears the mark as ``h5clear -s`` does: the flags
byte set to 0 and the superblock's checksum (Jenkins' lookup3, HDF5's metadata checksum) written
anew, nothing else touched, and only while no `sample` holds the run's lock.
"""

from __future__ import annotations

import os
from pathlib import Path

from bayes_dnlr.errors import BayesDnlrError

WRITER_LOCK = "sample.lock"      # the lock `sample` holds on its run directory (runs/sample.py)
_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_FLAGS_AT = 11                   # superblock v2/v3: signature, version, sizes, then the flags byte
_SUPERBLOCK = 48                 # v2/v3 with 8-byte offsets: 44 bytes and their checksum


def _rot(x: int, k: int) -> int:
    return ((x << k) | (x >> (32 - k))) & 0xFFFFFFFF


def _lookup3(data: bytes) -> int:
    """Bob Jenkins' lookup3 ``hashlittle`` (initval 0): HDF5's metadata checksum."""
    m = 0xFFFFFFFF
    a = b = c = (0xDEADBEEF + len(data)) & m
    k, n = 0, len(data)
    while n > 12:
        a = (a + int.from_bytes(data[k:k + 4], "little")) & m
        b = (b + int.from_bytes(data[k + 4:k + 8], "little")) & m
        c = (c + int.from_bytes(data[k + 8:k + 12], "little")) & m
        a = (a - c) & m; a ^= _rot(c, 4); c = (c + b) & m          # noqa: E702 - the mix, as published
        b = (b - a) & m; b ^= _rot(a, 6); a = (a + c) & m          # noqa: E702
        c = (c - b) & m; c ^= _rot(b, 8); b = (b + a) & m          # noqa: E702
        a = (a - c) & m; a ^= _rot(c, 16); c = (c + b) & m         # noqa: E702
        b = (b - a) & m; b ^= _rot(a, 19); a = (a + c) & m         # noqa: E702
        c = (c - b) & m; c ^= _rot(b, 4); b = (b + a) & m          # noqa: E702
        n -= 12
        k += 12
    if n == 0:
        return c
    tail = data[k:] + bytes(12 - n)
    a = (a + int.from_bytes(tail[0:4], "little")) & m
    b = (b + int.from_bytes(tail[4:8], "little")) & m
    c = (c + int.from_bytes(tail[8:12], "little")) & m
    c ^= b; c = (c - _rot(b, 14)) & m                               # noqa: E702 - the final mix
    a ^= c; a = (a - _rot(c, 11)) & m                               # noqa: E702
    b ^= a; b = (b - _rot(a, 25)) & m                               # noqa: E702
    c ^= b; c = (c - _rot(b, 16)) & m                               # noqa: E702
    a ^= c; a = (a - _rot(c, 4)) & m                                # noqa: E702
    b ^= a; b = (b - _rot(a, 14)) & m                               # noqa: E702
    c ^= b; c = (c - _rot(b, 24)) & m                               # noqa: E702
    return c


def _superblock(path: Path) -> bytes | None:
    """The superblock of an HDF5 file with 8-byte offsets, version 2 or 3, checksum verified."""
    try:
        with open(path, "rb") as f:
            head = f.read(_SUPERBLOCK)
    except OSError:
        return None
    if (len(head) < _SUPERBLOCK or head[:8] != _SIGNATURE or head[8] not in (2, 3) or head[9] != 8
            or int.from_bytes(head[44:48], "little") != _lookup3(head[:44])):
        return None
    return head


def write_flags(path: Path | str) -> int:
    """The superblock's consistency flags (0: no writer has the file open; nonzero after a kill)."""
    head = _superblock(Path(path))
    return head[_FLAGS_AT] if head is not None else 0


def _clear_flags(path: Path, head: bytes) -> None:
    block = bytearray(head)
    block[_FLAGS_AT] = 0
    block[44:48] = _lookup3(bytes(block[:44])).to_bytes(4, "little")
    fd = os.open(path, os.O_WRONLY | os.O_NOFOLLOW)
    try:
        os.pwrite(fd, bytes(block[_FLAGS_AT:]), _FLAGS_AT)
        os.fsync(fd)
    finally:
        os.close(fd)


def release_stale_writer(path: Path | str, *, lock_held: bool = False) -> bool:
    """Clear the "open for write" flags a killed writer left in chains.h5, so that plain h5py opens it
    (as ``h5clear -s`` does). Only when no `sample` holds the run's lock (``lock_held``: the caller
    is that `sample`); a live writer's flags, a read-only file and a file that is not ours are left
    alone. True when it cleared them."""
    from bayes_dnlr.runs.lock import run_lock

    path = Path(path)
    if path.is_symlink():
        return False             # written only in the run folder: a linked chain is read, not changed
    head = _superblock(path)
    if head is None or head[_FLAGS_AT] == 0:
        return False
    try:
        if lock_held:
            _clear_flags(path, head)
            return True
        with run_lock(path.parent, WRITER_LOCK, "a writer is running"):
            head = _superblock(path)        # read again under the lock
            if head is None or head[_FLAGS_AT] == 0:
                return False
            _clear_flags(path, head)
            return True
    except (BayesDnlrError, OSError):     # a live writer, a read-only folder or file
        return False
