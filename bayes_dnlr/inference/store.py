"""chains.h5: the chain, written in checkpoints, readable while it grows, resumable bit-exactly.

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
    attrs: names, log_space, walkers, config (resolved YAML), fingerprint, data_sha256, version,
           modes, decades, moves, seed, status (running | finished), stop_reason, ...

Chain rows are appended in blocks (chunked, gzip + shuffle), then the checkpoint row, whose
``step`` entry is written last, then the file is flushed: a reader, or a resume after Ctrl-C or
SIGKILL, trusts only steps covered by a complete checkpoint. Checkpoint 0 is the starting state.

A file left by a killed writer cannot be reopened for writing (HDF5 keeps its "open for SWMR
write" flag); ``ChainWriter.resume`` therefore reads the committed part with a SWMR reader,
writes it to a fresh file and atomically replaces the old one.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

FORMAT = "bayes_dnlr-chains/1"
_CK = "checkpoints"


@dataclass
class SamplerState:
    """The ensemble state emcee needs to continue exactly: positions, log-probs, RNG state."""

    coords: np.ndarray              # (walkers, ndim) sampling coordinates
    log_prob: np.ndarray            # (walkers,)
    rng: tuple                      # numpy RandomState.get_state(): ('MT19937', key, pos, has_gauss, g)

    @staticmethod
    def rng_tuple(key: np.ndarray, pos: int, has_gauss: int, gauss: float) -> tuple:
        return ("MT19937", np.asarray(key, dtype=np.uint32), int(pos), int(has_gauss), float(gauss))


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
    return h5py.File(path, "r", libver="latest", swmr=True)


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
        raise OSError(f"{f.filename}: no complete checkpoint (the file was cut before its first one)")
    return last


def read_run(path: Path | str) -> StoredRun:
    """Read the committed chain and the last checkpoint's state (works while a writer appends)."""
    path = Path(path)
    with _open_reader(path) as f:
        attrs = {k: _attr(v) for k, v in f.attrs.items()}
        if attrs.get("format") != FORMAT:
            raise OSError(f"{path}: not a bayes_dnlr chain file (format {attrs.get('format')!r})")
        k = _committed(f)
        ck = f[_CK]
        n = int(ck["step"][k])
        state = SamplerState(
            coords=ck["coords"][k], log_prob=ck["log_prob"][k],
            rng=SamplerState.rng_tuple(ck["rng_key"][k], ck["rng_pos"][k], ck["rng_has_gauss"][k],
                                       ck["rng_gauss"][k]))
        return StoredRun(
            path=path, attrs=attrs, chain=f["chain"][:n], log_prob=f["log_prob"][:n],
            accepted=f["accepted"][:n].astype(bool), checkpoint_steps=ck["step"][: k + 1],
            state=state, elapsed=float(ck["elapsed"][k]), store_time=float(ck["store_time"][k]),
            n_evals=int(ck["n_evals"][k]))


def read_attrs(path: Path | str) -> dict[str, Any]:
    """The file's metadata only (cheap)."""
    with _open_reader(Path(path)) as f:
        return {k: _attr(v) for k, v in f.attrs.items()}


class ChainWriter:
    """Appends blocks of steps and checkpoints to chains.h5 (the only writer of the file)."""

    def __init__(self, f: h5py.File, to_physical) -> None:
        self._f = f
        self._to_physical = to_physical
        self.store_time = float(f[_CK]["store_time"][-1]) if f[_CK]["step"].shape[0] else 0.0

    # ---- creation
    @classmethod
    def create(cls, path: Path, attrs: dict[str, Any], walkers: int, ndim: int, state: SamplerState,
               to_physical, chunk_steps: int = 100, n_evals: int = 0) -> ChainWriter:
        """A new file holding checkpoint 0 (the starting state); sampling appends from there."""
        path = Path(path)
        tmp = path.with_name(path.name + ".tmp")
        f = cls._new_file(tmp, attrs, walkers, ndim, chunk_steps)
        cls(f, to_physical)._append_checkpoint(0, state, elapsed=0.0, n_evals=n_evals)
        f.close()
        os.replace(tmp, path)
        return cls._open_for_append(path, to_physical)

    @staticmethod
    def _new_file(path: Path, attrs: dict[str, Any], walkers: int, ndim: int,
                  chunk_steps: int) -> h5py.File:
        f = h5py.File(path, "w", libver="latest")
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
                              dtype=dtype, fillvalue=fill)
        f.attrs["format"] = FORMAT
        f.attrs["status"] = "running"
        f.attrs["stop_reason"] = ""
        for k, v in attrs.items():
            f.attrs[k] = json.dumps(v) if isinstance(v, dict) else v
        return f

    @classmethod
    def _open_for_append(cls, path: Path, to_physical) -> ChainWriter:
        f = h5py.File(path, "r+", libver="latest")
        if f.attrs.get("status") != "running":
            f.attrs["status"] = "running"
            f.attrs["stop_reason"] = ""
        f.swmr_mode = True   # from here on readers may open the file while we append
        return cls(f, to_physical)

    @classmethod
    def resume(cls, path: Path, to_physical) -> ChainWriter:
        """Reopen an existing file for appending, keeping only its committed steps.

        The committed content is copied into a fresh file that replaces the old one atomically:
        this also recovers a file whose writer was killed (still flagged open for SWMR write).
        """
        path = Path(path)
        run = read_run(path)
        k = run.checkpoint_steps.size
        with _open_reader(path) as src:
            raw_attrs = dict(src.attrs.items())
            walkers, ndim = src["chain"].shape[1:]
            chunk_rows = src["chain"].chunks[0]
            ck = {name: src[_CK][name][:k] for name in src[_CK]}
        tmp = path.with_name(path.name + ".tmp")
        g = cls._new_file(tmp, {}, walkers, ndim, chunk_rows)
        try:
            for key, v in raw_attrs.items():
                g.attrs[key] = v
            n = run.steps
            for name, data in (("chain", run.chain), ("log_prob", run.log_prob),
                               ("accepted", run.accepted.astype(np.uint8))):
                g[name].resize(n, axis=0)
                g[name][:] = data
            for name, data in ck.items():
                g[_CK][name].resize(data.shape[0], axis=0)
                g[_CK][name][:] = data
        finally:
            g.close()
        os.replace(tmp, path)
        return cls._open_for_append(path, to_physical)

    # ---- appending
    def append(self, coords: np.ndarray, log_prob: np.ndarray, accepted: np.ndarray,
               state: SamplerState, elapsed: float, n_evals: int) -> float:
        """Append a block of steps (coords (m, walkers, ndim) in sampling coordinates) and commit it
        with a checkpoint holding ``state`` (the state after the block's last step).

        Returns the seconds this write took (also accumulated in ``store_time``)."""
        t0 = time.perf_counter()
        f = self._f
        m = coords.shape[0]
        n = f["chain"].shape[0]
        if m:
            for name, data in (("chain", self._to_physical(coords)), ("log_prob", log_prob),
                               ("accepted", np.asarray(accepted, dtype=np.uint8))):
                ds = f[name]
                ds.resize(n + m, axis=0)
                ds[n:] = data
                if f.swmr_mode:
                    ds.flush()    # the steps reach the file before the checkpoint that commits them
        self._append_checkpoint(n + m, state, elapsed, n_evals,
                                self.store_time + time.perf_counter() - t0)
        f.flush()
        dt = time.perf_counter() - t0
        self.store_time += dt
        return dt

    def _append_checkpoint(self, step: int, state: SamplerState, elapsed: float, n_evals: int,
                           store_time: float = 0.0) -> None:
        ck = self._f[_CK]
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
        ck["step"][k] = step          # the commit mark, written last

    @property
    def steps(self) -> int:
        return int(self._f["chain"].shape[0])

    def close(self) -> None:
        if self._f.id.valid:
            self._f.close()

    def finish(self, attrs: dict[str, Any]) -> None:
        """Close the SWMR session and mark the run finished (status, stop_reason, ...)."""
        path = Path(self._f.filename)
        self.close()
        with h5py.File(path, "r+", libver="latest") as f:
            f.attrs["status"] = "finished"
            for k, v in attrs.items():
                f.attrs[k] = json.dumps(v) if isinstance(v, dict) else v
