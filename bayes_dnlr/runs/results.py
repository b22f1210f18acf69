"""A run folder's results, read once for the report, compare and batch: the config, fit.json,
summary.json, the posterior draws of posterior.nc and the test data, with what could not be read.

``load_run`` never raises for a missing or broken output: what is missing is None and why is listed
in ``problems``, so that a report can always say what it lacks.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.config import Config, load_config
from bayes_dnlr.runs.folder import find_config
from bayes_dnlr.runs.layout import FIT_FILE, POSTERIOR_FILE, SUMMARY_FILE
from bayes_dnlr.runs.testset import plain_names
from bayes_dnlr.vocabulary import NOISE_NAMES


@dataclass
class RunResults:
    """What a run directory holds, read once for the report and compare."""

    run_dir: Path
    cfg: Config
    fit: dict | None = None
    summary: dict | None = None
    draws: dict[str, np.ndarray] | None = None   # name -> (chain, draw), physical units
    test: Any = None                             # bayes_dnlr.data.TestData, or None
    data_error: str | None = None
    problems: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return self.cfg.name

    @property
    def names(self) -> list[str]:
        """The free parameters, in the order of the results."""
        for src in (self.summary, self.fit):
            if src and src.get("parameters"):
                return list(src["parameters"])
        return list(self.cfg.free_parameters)

    @property
    def model_names(self) -> list[str]:
        """The free model parameters (without a sampled sigma0 and discrepancy hyperparameters)."""
        return [n for n in self.names if n not in NOISE_NAMES]

    @property
    def uses_discrepancy(self) -> bool:
        """True when the posterior used the model-discrepancy likelihood."""
        return ((self.summary or {}).get("noise") or {}).get("model") == "discrepancy"

    def gls(self) -> dict[str, Any] | None:
        """The generalized least-squares analysis (fit.json's discrepancy block), in gn()'s layout."""
        d = (self.fit or {}).get("discrepancy")
        if not d or d.get("estimate") is None:
            return None
        names = list((self.fit or {}).get("parameters") or self.model_names)
        return {"names": names, "estimate": per_name(d["estimate"], names),
                "sd": per_name(d.get("sd"), names), "correlation": matrix(d.get("correlation"), len(names)),
                "covariance": matrix(d.get("covariance"), len(names)),
                "delta_tilde": matrix(d.get("delta_tilde"), len(names))}

    def linearized(self) -> dict[str, Any] | None:
        """The linearized analysis the posterior is to be compared with: GLS when the posterior used
        the discrepancy, else the paper's white Gauss-Newton analysis."""
        return (self.gls() if self.uses_discrepancy else None) or self.gn()

    @property
    def truth(self) -> dict[str, float] | None:
        return dict(self.cfg.truth.params) if self.cfg.truth is not None else None

    @property
    def has_posterior(self) -> bool:
        return self.summary is not None and bool(self.summary.get("posterior"))

    def gn(self) -> dict[str, Any] | None:
        """Gauss-Newton results as {estimate, sd (per name), correlation, delta_tilde, covariance}."""
        src = None
        if self.fit is not None:
            src = self.fit
        elif self.summary is not None and self.summary.get("gauss_newton"):
            src = self.summary["gauss_newton"]
        if src is None or src.get("estimate") is None:
            return None
        names = list(src.get("parameters") or self.model_names)
        est = per_name(src["estimate"], names)
        sd = per_name(src.get("sd"), names)
        corr = matrix(src.get("correlation"), len(names))
        cov = matrix(src.get("covariance"), len(names))
        if cov is None and corr is not None and sd is not None:
            s = np.array([sd[n] for n in names])
            cov = corr * np.outer(s, s)
        dt = matrix(src.get("delta_tilde"), len(names))
        return {"names": names, "estimate": est, "sd": sd, "correlation": corr, "covariance": cov,
                "delta_tilde": dt}

    def point(self) -> dict[str, float]:
        """All model parameters at the best point: the least-squares estimate (generalized when the
        posterior used the discrepancy), else the posterior median; fixed values."""
        out = dict(self.cfg.fixed_values)
        gn = self.linearized()
        if gn is not None:
            out.update(gn["estimate"])
        elif self.has_posterior:
            out.update({k: v["median"] for k, v in self.summary["posterior"].items() if k != "sigma0"})
        return out

    def strain_rate(self) -> float | None:
        for src in (self.fit, self.summary):
            if src and src.get("strain_rate") is not None:
                return float(src["strain_rate"])
        if self.test is not None:
            return float(self.test.strain_rate)
        if self.cfg.truth is not None:
            return float(self.cfg.truth.strain_rate)
        return self.cfg.data.strain_rate

    def sigma0(self) -> float | None:
        """The noise sd used (MPa): a number from summary or fit (posterior mean when sampled)."""
        for src in (self.summary, self.fit):
            if src and src.get("sigma0") is not None:
                s = src["sigma0"]
                if isinstance(s, dict):
                    s = s.get("mean", s.get("value"))
                try:
                    return float(s)
                except (TypeError, ValueError):
                    continue
        if self.summary and "sigma0" in (self.summary.get("posterior") or {}):
            return float(self.summary["posterior"]["sigma0"]["mean"])
        return None


def per_name(obj: Any, names: Sequence[str]) -> dict[str, float] | None:
    """{name: value} from a mapping or from a list in the order ``names``."""
    if obj is None:
        return None
    if isinstance(obj, dict):
        return {n: float(obj[n]) for n in names if n in obj}
    return {n: float(v) for n, v in zip(names, obj, strict=False)}


def matrix(obj: Any, p: int) -> np.ndarray | None:
    if obj is None:
        return None
    if isinstance(obj, dict):       # {"names": [...], "matrix": [[...]]} or {"values": ...}
        obj = obj.get("matrix", obj.get("values"))
    a = np.asarray(obj, dtype=float)
    return a if a.shape == (p, p) else None


def _read_json(path: Path, problems: list[str]) -> dict | None:
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        problems.append(f"{path.name} could not be read: {err}")
        return None


def read_draws(path: Path, names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Posterior draws {name: (chain, draw)} from posterior.nc (ArviZ DataTree, any dim order).

    Read with h5netcdf (xarray and pandas cost the report 0.3-0.6 s to import); a file it cannot
    read that way (no (chain, draw) variables, a scale factor, another format) goes through
    xarray."""
    try:
        out = _read_draws_h5(path, names)
    except (OSError, KeyError, ValueError, TypeError, ImportError):
        out = None
    return out if out else _read_draws_xarray(path, names)


def _read_draws_h5(path: Path, names: Sequence[str] | None) -> dict[str, np.ndarray]:
    import h5netcdf

    out = {}
    with h5netcdf.File(path, "r") as f:
        g = f.groups["posterior"]
        for k, var in g.variables.items():
            if (names is not None and k not in names) or k in g.dimensions:
                continue
            dims = tuple(var.dimensions)
            if set(var.attrs) & {"scale_factor", "add_offset"} or sorted(dims) != ["chain", "draw"]:
                return {}
            a = np.asarray(var[...], dtype=float)
            fill = var.attrs.get("_FillValue")
            if fill is not None and np.isfinite(np.asarray(fill, dtype=float)).all():
                a = np.where(a == np.asarray(fill, dtype=float).ravel()[0], np.nan, a)
            out[str(k)] = a if dims == ("chain", "draw") else a.T
    return out


def _read_draws_xarray(path: Path, names: Sequence[str] | None) -> dict[str, np.ndarray]:
    import xarray as xr

    with xr.open_datatree(path) as tree:
        post = tree["posterior"].to_dataset()
        out = {}
        for k in post.data_vars:
            if names is not None and k not in names:
                continue
            da = post[k]
            dims = [d for d in ("chain", "draw") if d in da.dims]
            if len(dims) == 2:
                da = da.transpose("chain", "draw", ...)
            elif "draw" in da.dims:
                da = da.expand_dims("chain").transpose("chain", "draw", ...)
            a = np.asarray(da.values, dtype=float)
            if a.ndim == 2:
                out[str(k)] = a
    return out


def load_run(run_dir: Path | str, load_data: bool = True) -> RunResults:
    """Read a run directory. Missing pieces are None; what went wrong is listed in ``problems``."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        from bayes_dnlr.errors import RunError

        raise RunError(f"{run_dir}: no such run directory")
    try:
        cfg_path = find_config(run_dir)
    except FileNotFoundError as err:
        from bayes_dnlr.errors import RunError

        raise RunError(f"{err} (run `python -m bayes_dnlr fit <config.yaml>` first)") from None
    cfg = load_config(cfg_path)
    problems: list[str] = []
    run = RunResults(run_dir=run_dir, cfg=cfg, problems=problems)
    run.fit = _read_json(run_dir / FIT_FILE, problems)
    run.summary = _read_json(run_dir / SUMMARY_FILE, problems)
    nc = run_dir / POSTERIOR_FILE
    if nc.is_file():
        try:
            run.draws = read_draws(nc) or None
        except Exception as err:  # noqa: BLE001 - any reader failure becomes a note in the report
            problems.append(f"posterior.nc could not be read: {err}")
    if load_data and plain_names(cfg):     # a run with several tests: each by its view
        attach_test(run, cfg)
    return run


def attach_test(run: RunResults, cfg: Config) -> None:
    """The run's data into ``run.test``; when it cannot be read, why into ``run.data_error``."""
    try:
        from bayes_dnlr.data import load_test

        run.test = load_test(cfg)
    except Exception as err:  # noqa: BLE001 - the report says what is missing and goes on
        run.data_error = f"{type(err).__name__}: {err}"


