"""The posterior draws of a finished run, for the commands that start from one (``design`` with
``from_run``, ``export``).

A finished run is a run directory with ``summary.json`` and ``posterior.nc`` (written together by
``sample``). The draws are read with h5py straight from posterior.nc (an HDF5/netCDF-4 file with one
dataset per sampled quantity in the ``posterior`` group, dims (chain, draw)), which avoids importing
ArviZ (seconds) for a few arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.errors import DamagedFileError, RunError
from bayes_dnlr.readback import read_json, within_deadline
from bayes_dnlr.runs.layout import FIT_FILE, POSTERIOR_FILE, SUMMARY_FILE
from bayes_dnlr.runs.results import REWRITE_POSTERIOR


@dataclass(frozen=True)
class RunDraws:
    """The kept posterior draws of a run: ``values[k]`` is a flat array (chains × draws) per
    sampled quantity (model parameters, and sigma0 / disc_amplitude / disc_length when sampled)."""

    run_dir: Path
    parameters: list[str]                  # the model parameters of summary.json, in order
    values: dict[str, np.ndarray]          # name -> flat draws (same length for every name)
    summary: dict[str, Any]
    fit: dict[str, Any] = field(default_factory=dict)

    @property
    def n_draws(self) -> int:
        return int(next(iter(self.values.values())).size)

    def matrix(self, names: list[str]) -> np.ndarray:
        """(n_draws, len(names)) array of the named quantities."""
        return np.column_stack([self.values[k] for k in names])


def _read_json(path: Path, what: str) -> dict[str, Any]:
    try:
        return read_json(path, what)
    except OSError as err:
        raise RunError(f"{path}: not a readable {what} ({err.strerror or err})") from None


def _flat_draws(nc_path: Path) -> dict[str, np.ndarray]:
    """Every (chain, draw) variable of posterior.nc's ``posterior`` group, flattened."""
    import h5py

    values = {}
    with h5py.File(nc_path, "r") as f:
        group = f["posterior"]
        for k in group:
            if k in ("chain", "draw"):
                continue
            a = np.asarray(group[k][...], dtype=float)
            if a.ndim == 2:
                values[k] = a.reshape(-1)
    return values


def load_run_draws(run_dir: str | Path, key: str = "run directory") -> RunDraws:
    """The draws of the finished run in ``run_dir``; RunError naming ``key`` and what is missing."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RunError(f"{key}: {run_dir} is not a directory (expected a run directory with "
                       f"{SUMMARY_FILE} and {POSTERIOR_FILE})")
    summary_path, nc_path = run_dir / SUMMARY_FILE, run_dir / POSTERIOR_FILE
    missing = [p.name for p in (summary_path, nc_path) if not p.is_file()]
    if missing:
        hint = (" (fit.json is there: run `sample` on its config to finish the run)"
                if (run_dir / FIT_FILE).is_file() else " (run `fit` and `sample` on its config first)")
        raise RunError(f"{key}: {run_dir} is not a finished run: {', '.join(missing)} missing{hint}")
    summary = _read_json(summary_path, SUMMARY_FILE)
    names = list(summary.get("parameters") or [])
    if not names:
        raise RunError(f"{summary_path}: no 'parameters' list; re-run `sample`")
    got = within_deadline(lambda emit: emit("values", _flat_draws(nc_path)), nc_path)
    if got.failure is not None:
        raise DamagedFileError(f"{nc_path}: not a readable posterior ({got.failure}); "
                               f"{REWRITE_POSTERIOR}") from None
    values: dict[str, np.ndarray] = got["values"]
    absent = [k for k in names if k not in values]
    if absent:
        raise RunError(f"{nc_path}: the draws of {absent} are missing; re-run `sample`")
    fit = _read_json(run_dir / FIT_FILE, FIT_FILE) if (run_dir / FIT_FILE).is_file() else {}
    return RunDraws(run_dir, names, values, summary, fit)
