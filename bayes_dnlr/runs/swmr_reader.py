"""chains.h5 opened for reading in SWMR mode, with HDF5's metadata retries bounded.

A SWMR reader is what reads chains.h5 at every instant: while a `sample` appends to it, and after a
killed one left it (the superblock's end of file is then behind the data, which only a SWMR reader
accepts). HDF5 lets such a reader retry a metadata block whose checksum fails, as a writer may be
halfway through it: 100 times by default, with a sleep that doubles each time, so a block damaged
on disk holds the reader asleep for hours. ``open_swmr`` sets the number of attempts
(``H5Pset_metadata_read_attempts``, which h5py does not expose, called in the HDF5 library h5py
loaded): ``LIVE_WRITER_ATTEMPTS`` (about 1 s of retries) while a writer has the file open, 1
otherwise, when no block can be halfway written. Where the library cannot be found the reader has
HDF5's default, and the read's deadline (readback.py) ends it.
"""

from __future__ import annotations

import ctypes
import functools
from pathlib import Path

import h5py

LIVE_WRITER_ATTEMPTS = 30     # sleeps of 1 ns doubling: 2**30 ns, about 1 s, in all


@functools.cache
def _set_attempts():
    """``H5Pset_metadata_read_attempts`` of the HDF5 library h5py uses, or None."""
    try:
        with open("/proc/self/maps") as maps:
            libs = {line.split()[-1] for line in maps if "libhdf5" in line and ".so" in line}
        path = next(p for p in sorted(libs) if not Path(p).name.startswith("libhdf5_hl"))
        fn = ctypes.CDLL(path).H5Pset_metadata_read_attempts
    except (OSError, StopIteration, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int64, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


def open_swmr(path: Path, live_writer: bool) -> h5py.File:
    """``path`` opened read-only in SWMR mode (HDF5 ``libver='latest'``), its metadata read at most
    ``LIVE_WRITER_ATTEMPTS`` times when ``live_writer``, else once."""
    set_attempts = _set_attempts()
    if set_attempts is None:
        return h5py.File(path, "r", libver="latest", swmr=True)
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_libver_bounds(h5py.h5f.LIBVER_LATEST, h5py.h5f.LIBVER_LATEST)
    if set_attempts(fapl.id, LIVE_WRITER_ATTEMPTS if live_writer else 1) < 0:
        return h5py.File(path, "r", libver="latest", swmr=True)
    fid = h5py.h5f.open(str(path).encode(), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ, fapl=fapl)
    return h5py.File(fid)
