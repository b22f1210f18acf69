"""chains.h5: the chain, written in checkpoints, readable while it grows, resumable bit-exactly, and
readable after a SIGKILL or a full disk at any instant.

Plain h5py in SWMR mode (single writer, multiple readers; HDF5 ``libver='latest'``). Layout:

    /chain             (steps, walkers, ndim) float64  positions in physical units
    /log_prob          (steps, walkers) float64        log-posterior in sampling coordinates
    /accepted          (steps, walkers) uint8          1 where the walker moved in that step
    /checkpoints/step  (k,) int64                      steps done at checkpoint i (the commit mark)
    /checkpoints/coords, log_prob                      the ensemble state there (sampling coordinates)
    /checkpoints/rng_key, rng_pos, rng_has_gauss, rng_gauss
                                                       the numpy RandomState emcee draws from
    /checkpoints/elapsed, store_time, n_evals          cumulative sampling wall time, time spent
                                                       writing, model evaluations
    /finish            (0 or 1,) JSON bytes            the finish record (status finished,
                                                       stop_reason, steps, ...): written last
    attrs: names, log_space, walkers, config (resolved YAML), fingerprint, data_sha256, version,
           modes, decades, moves, seed, status (running), stop_reason, ...

Every piece of the file carries a checksum, so that damage on disk is an error, never a wrong
number: HDF5's metadata its own, the chain rows zlib's (gzip), the checkpoints and the finish record
Fletcher-32 (files of earlier versions have none there). A read runs within a deadline and names
what is damaged and what can still be read (``read_run``; docs/sampling.md, "A damaged chain").

Chain rows are appended in blocks (chunked, gzip + shuffle), then the checkpoint row, whose
``step`` entry is written last, then the file is flushed: a reader, or a resume after Ctrl-C or
SIGKILL, trusts only steps covered by a complete checkpoint. Checkpoint 0 is the starting state.

Safe at every instant (docs/sampling.md, "Storage"): HDF5 marks a file opened for writing in its
superblock, and a file whose writer died before switching to SWMR mode opens in no mode at all.
So chains.h5 itself is never opened for writing. Each session (create, resume) writes a new
*generation* into ``chains.h5.tmp``, switches it to SWMR mode, flushes and fsyncs it, and only then
renames it onto chains.h5; it appends to that open file, in SWMR mode, until it finishes. Finishing
appends the finish record (no reopening, attributes are never modified after the rename). So the
file named chains.h5 is at every instant either cleanly closed or in SWMR mode, and both open with
a SWMR reader (``read_run``); a kill before the rename leaves the previous generation untouched.
A write that fails (disk full) abandons the writer as a kill would: HDF5's later flushes are sent
to an anonymous in-memory copy, and a DiskFullError (one line) is raised.

``KILL_POINTS`` name the instants tests/runs/test_chains_crash.py kills the writer at.

**Plain h5py after a kill.** A SWMR writer marks the file "open for write" in its superblock (the
consistency flags); a killed one leaves the mark, and HDF5 then refuses a plain
``h5py.File(path, "r")`` ("already open for write ... h5clear"). ``release_stale_writer`` clears the
mark, as ``h5clear -s`` does, when no `sample` holds the run's lock: the package's readers
(``read_run``, ``read_attrs``), `sample` and the commands that take a run folder call it first.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from bayes_dnlr.diskio import ensure_free, fsync_dir, kill_point, storage_error
from bayes_dnlr.errors import DamagedFileError
from bayes_dnlr.inference.mcmc.state import SamplerState
from bayes_dnlr.readback import Broken, Emit, Pieces, piece, within_deadline
from bayes_dnlr.runs.chain_flags import release_stale_writer, write_flags
from bayes_dnlr.runs.swmr_reader import open_swmr

__all__ = ["ChainWriter", "SamplerState", "StoredRun", "read_attrs", "read_run", "release_stale_writer",
           "write_flags"]

FORMAT = "bayes_dnlr-chains/2"
READABLE_FORMATS = ("bayes_dnlr-chains/1", FORMAT)   # /1: finished state in attrs, no /finish
_CK = "checkpoints"
_FINISH = "finish"
_FINISH_BYTES = 4096
_MARGIN = 1 << 20        # bytes of HDF5 metadata a commit may add, beyond the raw data
# attributes that describe a finished generation (format /1 kept them in attrs)
_FINISH_ATTRS = ("status", "stop_reason", "steps", "finished")

# every instant at which tests/runs/test_chains_crash.py kills the writer (diskio.kill_point)
KILL_POINTS = (
    "create.open",         # chains.h5.tmp just opened for writing (no SWMR yet)
    "create.checkpoint",   # checkpoint 0 written but for its step (the commit mark)
    "create.written",      # checkpoint 0 complete, file not yet in SWMR mode
    "resume.open",         # chains.h5.tmp just opened for writing (no SWMR yet)
    "resume.chain",        # committed steps copied, checkpoints not yet
    "resume.written",      # copy complete, file not yet in SWMR mode
    "publish.swmr",        # new generation in SWMR mode, not flushed
    "publish.synced",      # flushed and fsynced, not yet renamed onto chains.h5
    "publish.renamed",     # renamed onto chains.h5 (the directory not yet fsynced)
    "append.data",         # a block's rows in the file, no checkpoint for them yet
    "append.checkpoint",   # its checkpoint written but for the step (the commit mark)
    "append.step",         # commit mark written, not flushed
    "append.flushed",      # the commit flushed
    "finish.record",       # finish record written, not flushed
    "finish.flushed",      # finish record flushed, file not closed
    "finish.closed",       # file closed
)


@dataclass
class StoredRun:
    """The committed content of a chains.h5 file."""

    path: Path
    attrs: dict[str, Any]
    chain: np.ndarray               # (steps, walkers, ndim) physical units
    log_prob: np.ndarray            # (steps, walkers)
    accepted: np.ndarray            # (steps, walkers) bool
    checkpoint_steps: np.ndarray    # (k,) steps at each committed checkpoint
    state: SamplerState             # the state at the last checkpoint
    elapsed: float                  # sampling wall time so far, s
    store_time: float               # time spent writing checkpoints, s
    n_evals: int

    @property
    def steps(self) -> int:
        return int(self.chain.shape[0])

    @property
    def names(self) -> list[str]:
        return list(self.attrs["names"])

    @property
    def finished(self) -> bool:
        return self.attrs.get("status") == "finished"


# ---------------------------------------------------------------- reading

def _attr(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray):
        return [_attr(x) for x in v.tolist()]
    if isinstance(v, list):
        return [_attr(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def _open_reader(path: Path) -> h5py.File:
    """A SWMR reader whose metadata retries are bounded (runs/swmr_reader.py): many only while a
    live `sample` has the file open for write."""
    return open_swmr(path, live_writer=bool(write_flags(path)))


def _committed(f: h5py.File) -> int:
    """Index of the last complete checkpoint."""
    ck = f[_CK]
    steps = ck["step"][:]
    n_chain = f["chain"].shape[0]
    last = -1
    prev = -1
    for i, s in enumerate(steps):
        if s < 0 or (i > 0 and s <= prev) or s > n_chain:
            break
        if s > 0 and not np.isfinite(f["chain"][s - 1]).all():
            break      # a checkpoint whose steps did not reach the file
        last, prev = i, s
    if last < 0:
        raise OSError("no complete checkpoint (the file was cut before its first one)")
    return last


def _finish_record(f: h5py.File, steps: int) -> dict[str, Any] | None:
    """The finish record, when complete and written at ``steps`` committed steps."""
    if _FINISH not in f or f[_FINISH].shape[0] == 0:
        return None
    try:
        record = json.loads(bytes(f[_FINISH][-1]).decode())
    except (UnicodeDecodeError, ValueError):
        return None          # written but not flushed: the fill value
    if not isinstance(record, dict) or record.get("step") != steps:
        return None
    record.pop("step")
    return record


_ARRAYS = ("chain", "log_prob", "accepted")


def _read_pieces(path: Path, emit: Emit, arrays: bool) -> None:
    """Send the file's pieces (runs in the reading child, readback.py): the committed checkpoint,
    the finish record, (``arrays``) the committed steps and every checkpoint, and the attributes
    last (h5py keeps strings in HDF5's global heap, which has no checksum: the likeliest to hang)."""
    with _open_reader(path) as f:
        kn: tuple[int, int] | None = None

        def committed() -> tuple[int, int]:
            nonlocal kn
            k = _committed(f)
            kn = (k, int(f[_CK]["step"][k]))
            return kn

        piece(emit, "committed", committed)
        piece(emit, "layout", lambda: (tuple(f["chain"].shape), f["chain"].chunks))
        reads: dict[str, Callable[[int, int], Any]] = {"finish": lambda k, n: _finish_record(f, n)}
        if arrays:
            reads["checkpoints"] = lambda k, n: {name: ds[: k + 1] for name, ds in f[_CK].items()}
            for name in _ARRAYS:
                reads[name] = lambda k, n, name=name: f[name][:n]
        if kn is None:                # no committed step: what the arrays still hold, to say so
            reads = {name: (lambda k, n, name=name: f[name][:]) for name in _ARRAYS}
        for name, read in reads.items():
            piece(emit, name, lambda read=read: read(*(kn or (-1, -1))))
        piece(emit, "attrs", lambda: dict(f.attrs.items()))


def _stored(path: Path, arrays: bool) -> Pieces:
    """The pieces of chains.h5, read within a deadline; DamagedFileError (naming what is damaged
    and what can still be read) unless every piece was read and the file is a chain of ours."""
    release_stale_writer(path)
    got = within_deadline(lambda emit: _read_pieces(path, emit, arrays), path)
    broken = {name: v.why for name, v in got.items() if isinstance(v, Broken)}
    attrs = got.get("attrs")
    if isinstance(attrs, dict) and _attr(attrs.get("format")) not in READABLE_FORMATS:
        raise DamagedFileError(f"{path}: not a bayes_dnlr chain file (format "
                               f"{_attr(attrs.get('format'))!r}): another program's file, or one "
                               f"this version cannot read. {_REMEDY}")
    if got.failure is None and not broken and isinstance(attrs, dict):
        return got
    raise DamagedFileError(damage_report(path, got, broken))


_REMEDY = ("`sample --restart` discards it and samples again; docs/sampling.md (\"A damaged chain\") "
           "shows how to copy out what can still be read")
_WHAT = {"committed": "its checkpoints (which steps are complete)", "layout": "the chain's shape",
         "finish": "the finish record", "checkpoints": "the checkpoints (the sampler's state)",
         "chain": "the chain's positions", "log_prob": "the log-posterior of the steps",
         "accepted": "the acceptance of the steps", "attrs": "its attributes (names, config, identity)"}


def damage_report(path: Path, got: Pieces, broken: dict[str, str]) -> str:
    """What is damaged in chains.h5 and what can still be read, in one paragraph."""
    damaged = [f"{_WHAT.get(name, name)} ({why})" for name, why in broken.items()]
    if got.failure is not None:
        unread = [_WHAT[name] for name in _WHAT if name not in got]
        if not got:
            damaged.append(f"the file cannot be opened as HDF5 ({got.failure})")
        else:
            damaged.append(f"{', '.join(unread) or 'the rest'} ({got.failure})")
    readable = []
    kn, layout = got.get("committed"), got.get("layout")
    if isinstance(kn, tuple):
        readable.append(f"the checkpoints up to step {kn[1]}")
    chain = got.get("chain")
    if isinstance(chain, np.ndarray):
        readable.append(f"{chain.shape[0]} steps of the chain ({chain.shape[1]} walkers x "
                        f"{chain.shape[2]} parameters)")
    elif isinstance(layout, tuple):
        readable.append(f"the chain's shape ({layout[0][0]} steps x {layout[0][1]} walkers x "
                        f"{layout[0][2]} parameters)")
    readable += [_WHAT[name] for name in ("log_prob", "accepted", "attrs")
                 if name in got and not isinstance(got[name], Broken)]
    still = ("Still readable: " + "; ".join(readable) + "." if readable
             else "Nothing in it can be read.")
    return f"{path} is damaged: {'; '.join(damaged)}. {still} {_REMEDY}"


def _attributes(got: Pieces) -> tuple[dict[str, Any], int, int]:
    """The attributes with the finish record applied, the last complete checkpoint and its step."""
    attrs = {k: _attr(v) for k, v in got["attrs"].items()}
    k, n = got["committed"]
    if got.get("finish") is not None:
        attrs.update(got["finish"])
    return attrs, k, n


def read_run(path: Path | str) -> StoredRun:
    """Read the committed chain and the last checkpoint's state (works while a writer appends, and
    after a writer was killed at any instant). A damaged file: DamagedFileError, within seconds."""
    return _run_of(Path(path), _stored(Path(path), arrays=True))


def _run_of(path: Path, got: Pieces) -> StoredRun:
    attrs, k, n = _attributes(got)
    ck = {name: a[k] for name, a in got["checkpoints"].items()}
    state = SamplerState(
        coords=ck["coords"], log_prob=ck["log_prob"],
        rng=SamplerState.rng_tuple(ck["rng_key"], ck["rng_pos"], ck["rng_has_gauss"], ck["rng_gauss"]))
    return StoredRun(
        path=path, attrs=attrs, chain=got["chain"], log_prob=got["log_prob"],
        accepted=got["accepted"].astype(bool), checkpoint_steps=got["checkpoints"]["step"],
        state=state, elapsed=float(ck["elapsed"]), store_time=float(ck["store_time"]),
        n_evals=int(ck["n_evals"]))


def read_attrs(path: Path | str) -> dict[str, Any]:
    """The file's metadata only (cheap). A damaged file: DamagedFileError, within seconds."""
    return _attributes(_stored(Path(path), arrays=False))[0]


# ---------------------------------------------------------------- failed writes

def _anonymous_file() -> int:
    if hasattr(os, "memfd_create"):
        return os.memfd_create("bayes_dnlr-abandoned")
    return os.dup(tempfile.TemporaryFile().fileno())


def _abandon(f: h5py.File) -> None:
    """Leave the disk file as it is, as a SIGKILL at this instant would, and close ``f``.

    After a failed write (disk full) HDF5 holds dirty data it cannot write; closing the file, or
    the interpreter's exit, retries and fails, and can crash the process. So the file descriptor
    is pointed at an anonymous in-memory copy of the file first: HDF5 completes its flushes and
    closes there, and the disk file stays what the design makes safe at every instant."""
    if not f.id.valid:
        return
    try:
        fd = f.id.get_vfd_handle()
        mem = _anonymous_file()
    except (OSError, ValueError, RuntimeError):
        fd = None
    if fd is not None:
        try:
            size, done = os.fstat(fd).st_size, 0
            while done < size:           # the copy HDF5 may read from while closing
                sent = os.sendfile(mem, fd, done, size - done)
                if sent <= 0:
                    break
                done += sent
        except OSError:
            pass
        os.dup2(mem, fd)
        os.close(mem)
    try:
        f.close()
    except Exception:  # noqa: BLE001 - whatever HDF5 still fails at, the disk file is left alone
        pass


# ---------------------------------------------------------------- writing

class ChainWriter:
    """Appends blocks of steps and checkpoints to chains.h5 (the only writer of the file)."""

    def __init__(self, f: h5py.File, to_physical, path: Path | None = None) -> None:
        self._f = f
        self._path = Path(path if path is not None else f.filename)   # f may be a renamed .tmp
        self._to_physical = to_physical
        ck = f[_CK]
        k = ck["step"].shape[0]
        self.store_time = float(ck["store_time"][-1]) if k else 0.0
        self._steps = int(ck["step"][-1]) if k else 0
        walkers, ndim = f["chain"].shape[1:]
        self._row_bytes = walkers * (8 * ndim + 8 + 1)
        self._chunk_rows = f["chain"].chunks[0]

    # ---- creation
    @classmethod
    def create(cls, path: Path, attrs: dict[str, Any], walkers: int, ndim: int, state: SamplerState,
               to_physical, chunk_steps: int = 100, n_evals: int = 0) -> ChainWriter:
        """A new file holding checkpoint 0 (the starting state); sampling appends from there."""
        t0 = time.perf_counter()

        def fill(f: h5py.File) -> None:
            _layout(f, attrs, walkers, ndim, chunk_steps)
            _append_checkpoint(f, 0, state, elapsed=0.0, n_evals=n_evals,
                               commit_point="create.checkpoint")
            kill_point("create.written")

        path = Path(path)
        f = _publish(path, fill, "create", need=_MARGIN)
        writer = cls(f, to_physical, path)
        writer.store_time += time.perf_counter() - t0
        return writer

    @classmethod
    def resume(cls, path: Path, to_physical) -> ChainWriter:
        """Continue an existing file: its committed steps become a new generation that appending
        continues (whatever the old file's state: finished, or left by a killed writer)."""
        t0 = time.perf_counter()
        path = Path(path)
        got = _stored(path, arrays=True)
        run = _run_of(path, got)
        (_, walkers, ndim), chunks = got["layout"]
        chunk_rows = chunks[0]
        ck = got["checkpoints"]
        attrs = {key: v for key, v in got["attrs"].items() if key not in (*_FINISH_ATTRS, "format")}

        def fill(g: h5py.File) -> None:
            _layout(g, {}, walkers, ndim, chunk_rows)
            for key, v in attrs.items():
                g.attrs[key] = v
            n = run.steps
            for name, data in (("chain", run.chain), ("log_prob", run.log_prob),
                               ("accepted", run.accepted.astype(np.uint8))):
                g[name].resize(n, axis=0)
                g[name][:] = data
            kill_point("resume.chain")
            for name, data in ck.items():
                g[_CK][name].resize(data.shape[0], axis=0)
                g[_CK][name][:] = data
            kill_point("resume.written")

        f = _publish(path, fill, "resume", need=1.25 * path.stat().st_size + _MARGIN)
        writer = cls(f, to_physical, path)
        writer.store_time += time.perf_counter() - t0
        return writer

    # ---- appending
    def append(self, coords: np.ndarray, log_prob: np.ndarray, accepted: np.ndarray,
               state: SamplerState, elapsed: float, n_evals: int) -> float:
        """Append a block of steps (coords (m, walkers, ndim) in sampling coordinates) and commit it
        with a checkpoint holding ``state`` (the state after the block's last step).

        Returns the seconds this write took (also accumulated in ``store_time``). A full disk
        raises DiskFullError and leaves the committed steps as they were."""
        t0 = time.perf_counter()
        f = self._f
        m = coords.shape[0]
        n = self._steps
        # at most two chunks of raw data per dataset (a shared chunk rewritten, gzip's worst case)
        ensure_free(self._path, 2 * max(m, self._chunk_rows) * self._row_bytes + _MARGIN,
                    self._kept())
        try:
            if m:
                for name, data in (("chain", self._to_physical(coords)), ("log_prob", log_prob),
                                   ("accepted", np.asarray(accepted, dtype=np.uint8))):
                    ds = f[name]
                    ds.resize(n + m, axis=0)
                    ds[n:] = data
                    ds.flush()     # the steps reach the file before the checkpoint that commits them
            kill_point("append.data")
            _append_checkpoint(f, n + m, state, elapsed, n_evals,
                               self.store_time + time.perf_counter() - t0, "append.checkpoint")
            kill_point("append.step")
            f.flush()
        except Exception as err:       # a failed write (h5py: OSError or RuntimeError)
            raise self._failed(err) from None
        self._steps = n + m
        kill_point("append.flushed")
        dt = time.perf_counter() - t0
        self.store_time += dt
        return dt

    @property
    def steps(self) -> int:
        """Committed steps."""
        return self._steps

    def close(self) -> None:
        if self._f.id.valid:
            try:
                self._f.close()
            except Exception:    # a flush that cannot be written: leave the file as committed
                _abandon(self._f)

    def finish(self, attrs: dict[str, Any]) -> None:
        """Mark the run finished (status, stop_reason, ...) and close the file.

        The finish record is appended within the SWMR session; the file is never reopened."""
        record = {"status": "finished",
                  **{k: (json.dumps(v) if isinstance(v, dict) else v) for k, v in attrs.items()},
                  "step": self._steps}
        blob = json.dumps(record).encode()
        if len(blob) > _FINISH_BYTES:
            raise ValueError(f"finish record of {len(blob)} bytes > {_FINISH_BYTES}")
        try:
            ensure_free(self._path, _MARGIN, self._kept())
        except BaseException:
            self.close()
            raise
        try:
            ds = self._f[_FINISH]
            ds.resize(ds.shape[0] + 1, axis=0)
            ds[-1] = blob
            kill_point("finish.record")
            self._f.flush()
            kill_point("finish.flushed")
            self._f.close()
        except Exception as err:
            raise self._failed(err) from None
        kill_point("finish.closed")

    def _kept(self) -> str:
        return (f"the committed chain ({self._steps} steps) is kept in {self._path}: free some space "
                "and run `sample` again to continue it")

    def _failed(self, err: Exception) -> Exception:
        """After a failed write: abandon the file as a kill would, and the error to raise."""
        _abandon(self._f)
        return storage_error(err, self._path, self._kept()) or err


def _layout(f: h5py.File, attrs: dict[str, Any], walkers: int, ndim: int, chunk_steps: int) -> None:
    """The datasets and attributes of an empty chain file."""
    rows = int(min(max(chunk_steps, 16), 1024))
    comp = {"compression": "gzip", "compression_opts": 4, "shuffle": True}
    f.create_dataset("chain", shape=(0, walkers, ndim), maxshape=(None, walkers, ndim),
                     chunks=(rows, walkers, ndim), dtype="f8", fillvalue=np.nan, **comp)
    f.create_dataset("log_prob", shape=(0, walkers), maxshape=(None, walkers),
                     chunks=(rows, walkers), dtype="f8", fillvalue=np.nan, **comp)
    f.create_dataset("accepted", shape=(0, walkers), maxshape=(None, walkers),
                     chunks=(rows, walkers), dtype="u1", **comp)
    ck = f.create_group(_CK)
    specs = {"step": ((), "i8", -1), "coords": ((walkers, ndim), "f8", np.nan),
             "log_prob": ((walkers,), "f8", np.nan), "rng_key": ((624,), "u4", 0),
             "rng_pos": ((), "i8", 0), "rng_has_gauss": ((), "i8", 0), "rng_gauss": ((), "f8", 0.0),
             "elapsed": ((), "f8", 0.0), "store_time": ((), "f8", 0.0), "n_evals": ((), "i8", 0)}
    for name, (shape, dtype, fill) in specs.items():
        ck.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), chunks=(16, *shape),
                          dtype=dtype, fillvalue=fill, fletcher32=True)
    f.create_dataset(_FINISH, shape=(0,), maxshape=(None,), chunks=(1,), dtype=f"S{_FINISH_BYTES}",
                     fletcher32=True)
    f.attrs["format"] = FORMAT
    f.attrs["status"] = "running"
    f.attrs["stop_reason"] = ""
    for k, v in attrs.items():
        f.attrs[k] = json.dumps(v) if isinstance(v, dict) else v


def _append_checkpoint(f: h5py.File, step: int, state: SamplerState, elapsed: float, n_evals: int,
                       store_time: float = 0.0, commit_point: str = "") -> None:
    ck = f[_CK]
    k = ck["step"].shape[0]
    for ds in ck.values():
        ds.resize(k + 1, axis=0)
    name, key, pos, has_gauss, gauss = state.rng[:5]
    if name != "MT19937":
        raise ValueError(f"unsupported random state {name!r}")
    ck["coords"][k] = state.coords
    ck["log_prob"][k] = state.log_prob
    ck["rng_key"][k] = key
    ck["rng_pos"][k] = pos
    ck["rng_has_gauss"][k] = has_gauss
    ck["rng_gauss"][k] = gauss
    ck["elapsed"][k] = elapsed
    ck["n_evals"][k] = n_evals
    ck["store_time"][k] = store_time
    kill_point(commit_point)
    ck["step"][k] = step          # the commit mark, written last


def _publish(path: Path, fill: Callable[[h5py.File], None], kind: str, need: float) -> h5py.File:
    """Write a new generation of ``path`` and make it the file: ``fill`` it in ``path``.tmp, switch
    it to SWMR mode, flush and fsync it, rename it onto ``path``. Returns the open SWMR writer.

    ``path`` is never opened for writing: a kill before the rename leaves it as it was, one after
    leaves a file in SWMR mode that readers open. On a failure the temporary is removed."""
    tmp = path.with_name(path.name + ".tmp")
    keep = ("the chain in it is unchanged: free some space and run `sample` again" if path.exists()
            else "nothing was sampled yet: free some space and run `sample` again")
    ensure_free(path, need, keep)
    tmp.unlink(missing_ok=True)        # left by a writer killed before its rename
    f = None
    renamed = False
    try:
        f = h5py.File(tmp, "w", libver="latest")
        kill_point(f"{kind}.open")
        fill(f)
        f.swmr_mode = True             # from here on readers may open the file while we append
        kill_point("publish.swmr")
        f.flush()
        os.fsync(f.id.get_vfd_handle())
        kill_point("publish.synced")
        os.replace(tmp, path)
        renamed = True
        kill_point("publish.renamed")
        fsync_dir(path.parent)
        return f
    except BaseException as err:
        if f is not None:
            _abandon(f) if isinstance(err, Exception) else f.close()
        if not renamed:
            tmp.unlink(missing_ok=True)
        clean = storage_error(err, tmp if not renamed else path, keep)
        if clean is not None:
            raise clean from None
        raise
