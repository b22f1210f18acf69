"""The sampled posterior as a result: ArviZ DataTree (posterior.nc), summary.json, console table.

Statistics of the kept draws (after burn-in), in physical units:
- mean, sd, median, 90 % highest-density interval (ArviZ's "nearest" ``hdi``);
- ``ess_bulk`` and ``ess_tail`` (ArviZ's estimators, every walker taken as a chain; tail = min of
  the 5 % and 95 % quantile ESS, Vehtari et al. 2021);
- ``r_hat``: rank-normalised split R-hat (ArviZ's) with the walkers split into 4 groups, each group
  one "chain" whose draws run step by step (so the split halves compare early and late steps, and
  the groups compare disjoint sets of walkers);

ESS, R-hat and HDI are computed by inference/mcmc/ess.py (numpy, the same estimators as ArviZ, tested
against it): importing ArviZ costs seconds (scipy.stats, matplotlib) that ``sample`` does not need.
The DataTree is built and read with arviz_base only.
- emcee's integrated autocorrelation time τ and the ESS it implies, (kept steps × walkers) / τ.

summary.json's keys are a contract, documented in docs/sampling.md.
"""

from __future__ import annotations

import json
import math
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.errors import DamagedFileError
from bayes_dnlr.inference.mcmc import ess
from bayes_dnlr.inference.mcmc.ess import diagnostics
from bayes_dnlr.numbers import interval, pm
from bayes_dnlr.readback import read_json
from bayes_dnlr.runs.folder import jsonable, write_atomic, write_json
from bayes_dnlr.runs.layout import CHAINS_FILE, POSTERIOR_FILE, SUMMARY_FILE
from bayes_dnlr.runs.results import verdict_lines
from bayes_dnlr.vocabulary import UNITS

HDI_PROB = 0.9


def build_datatree(names: list[str], draws: np.ndarray, log_prob: np.ndarray,
                   attrs: dict[str, Any] | None = None):
    """DataTree with groups posterior (one variable per parameter) and sample_stats (lp).

    draws: (steps, walkers, ndim) physical units; every walker is a chain: dims (chain, draw).
    """
    from arviz_base import from_dict

    post = {k: np.ascontiguousarray(draws[:, :, j].T) for j, k in enumerate(names)}
    stats = {"lp": np.ascontiguousarray(log_prob.T)}
    flat_attrs = {k: (json.dumps(v) if isinstance(v, dict | list) else v)
                  for k, v in (attrs or {}).items() if v is not None}
    # 32 walkers may outnumber the draws of a short run: that is not a naming mistake
    dt = from_dict({"posterior": post, "sample_stats": stats},
                   attrs={"posterior": flat_attrs}, check_conventions=False)
    for k in names:
        dt["posterior"][k].attrs["units"] = UNITS.get(k.split("[", 1)[0], "")
    return dt


def parameter_stats(draws: np.ndarray) -> dict[str, float | list[float]]:
    """Summary statistics of one parameter's kept draws (steps, walkers)."""
    flat = draws.ravel()
    lo, hi = ess.hdi(flat, HDI_PROB)
    return {
        "mean": float(flat.mean()),
        "sd": float(flat.std(ddof=1)),
        "median": float(np.median(flat)),
        "hdi_90": [lo, hi],
        **diagnostics(draws),
    }


def correlation(draws: np.ndarray) -> np.ndarray:
    """Posterior correlation matrix of (steps, walkers, ndim) draws."""
    flat = draws.reshape(-1, draws.shape[-1])
    if flat.shape[1] == 1:
        return np.ones((1, 1))
    return np.corrcoef(flat, rowvar=False)


def gauss_newton_block(fit: dict[str, Any]) -> dict[str, Any]:
    """The linearized (Gauss-Newton) results of fit.json, in summary.json's layout."""
    names = list(fit.get("parameters") or fit.get("names") or [])
    return {
        "parameters": names,
        "estimate": {k: fit["estimate"][k] for k in names if k in fit.get("estimate", {})},
        "sd": {k: fit["sd"][k] for k in names if k in fit.get("sd", {})},
        "correlation": fit.get("correlation"),
        "delta_tilde": fit.get("delta_tilde"),
    }


def summarize(names: list[str], draws: np.ndarray, *, fit: dict[str, Any], tau: np.ndarray,
              extra: dict[str, Any]) -> dict[str, Any]:
    """summary.json content. ``extra`` carries the run facts (sigma0, n_points, walkers, steps, ...)."""
    n, w, _ = draws.shape
    post = {k: parameter_stats(draws[:, :, j]) for j, k in enumerate(names)}
    summary: dict[str, Any] = {
        "parameters": list(names),
        "posterior": post,
        "posterior_correlation": correlation(draws),
        "gauss_newton": gauss_newton_block(fit),
        "sigma0": extra.pop("sigma0"),
        "n_points": extra.pop("n_points"),
        "walkers": int(w),
        "steps": extra.pop("steps"),
        "autocorr_time": {k: float(t) for k, t in zip(names, tau, strict=True)},
        "wall_time_s": extra.pop("wall_time_s"),
        "standards": extra.pop("standards"),
        "deborah_max": extra.pop("deborah_max"),
        "ess_autocorr": {k: float(n * w / t) if t > 0 else None for k, t in zip(names, tau, strict=True)},
        "kept_steps": int(n),
        "draws": int(n * w),
    }
    summary.update(extra)
    return jsonable(summary)


def _netcdf_bytes(datatree) -> bytes:
    """posterior.nc in memory. Inside a Dask worker xarray would take a *distributed* write lock
    named after the target, which for an in-memory file is unknown to the scheduler: the write is
    local, so it runs under Dask's synchronous scheduler (a plain thread lock). Without
    dask.distributed in the process no distributed scheduler can run: xarray's question "which
    scheduler?" is answered "none" without importing distributed (0.2-0.5 s); the data are numpy
    arrays, nothing is chunked."""
    if "distributed" not in sys.modules:
        with _no_dask_scheduler():
            return datatree.to_netcdf(engine="h5netcdf")
    import dask

    with dask.config.set(scheduler="synchronous"):
        return datatree.to_netcdf(engine="h5netcdf")


@contextmanager
def _no_dask_scheduler():
    """xarray's ``get_dask_scheduler`` returns None (no scheduler) for the duration."""
    from xarray.backends import locks, writers

    patched = [(m, m.get_dask_scheduler) for m in (locks, writers)
               if hasattr(m, "get_dask_scheduler")]
    for m, _ in patched:
        m.get_dask_scheduler = _none
    try:
        yield
    finally:
        for m, f in patched:
            m.get_dask_scheduler = f


def _none(*args: Any, **kwargs: Any) -> None:
    return None


def write_outputs(run_dir: Path, datatree, summary: dict[str, Any]) -> None:
    """posterior.nc and summary.json, each replaced atomically (rundir.write_atomic).

    ``datatree``: an xarray DataTree (``build_datatree``), or the draws themselves
    (``netcdf.PosteriorDraws``: the same file without importing xarray and ArviZ, what ``sample``
    uses). posterior.nc is serialised in memory first: HDF5 never writes to the disk itself, so a
    full disk is met by a plain file write (a one-line DiskFullError, the temporary removed) and
    never inside HDF5 (whose failed writes can crash the process when it exits)."""
    from bayes_dnlr.runs.netcdf import PosteriorDraws

    run_dir = Path(run_dir)
    data = datatree.to_netcdf() if isinstance(datatree, PosteriorDraws) else _netcdf_bytes(datatree)
    write_atomic(run_dir / POSTERIOR_FILE, data)
    write_json(run_dir / SUMMARY_FILE, summary)


def read_summary(run_dir: Path) -> dict[str, Any] | None:
    """summary.json of a run directory, or None when missing or unreadable."""
    path = Path(run_dir) / SUMMARY_FILE
    try:
        return read_json(path, SUMMARY_FILE)
    except (OSError, DamagedFileError):
        return None


def _g(v: float | None) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{v:.4g}"


def _sigma0_text(v: Any) -> str:
    if isinstance(v, dict):
        return ", ".join(f"{_g(x)} ({t})" for t, x in v.items())
    return _g(v)


@dataclass
class Posterior:
    """What ``sample`` returns: the DataTree of kept draws, the run directory and summary.json."""

    run_dir: Path
    summary: dict[str, Any]
    _datatree: Any = None
    note: str = ""
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def datatree(self):
        """ArviZ DataTree of the kept draws (loaded from posterior.nc when needed)."""
        if self._datatree is None:
            from xarray import open_datatree  # what arviz.from_netcdf is

            dt = open_datatree(self.run_dir / POSTERIOR_FILE)
            self._datatree = dt.load()
            dt.close()
        return self._datatree

    @property
    def parameters(self) -> list[str]:
        return list(self.summary["parameters"])

    def table(self) -> str:
        """Console table: posterior mean ± sd, 90 % HDI, Gauss-Newton estimate ± sd, ESS, R-hat, τ."""
        s = self.summary
        gls = s.get("generalized_least_squares")
        gn = gls or s.get("gauss_newton") or {}
        head = ["parameter", "unit", "posterior mean ± sd", "90 % HDI",
                "least squares ± sd (GLS)" if gls else "Gauss-Newton ± sd",
                "ESS bulk", "ESS tail", "R-hat", "tau"]
        rows = []
        for k in s["parameters"]:
            p = s["posterior"][k]
            est, sd = (gn.get("estimate") or {}).get(k), (gn.get("sd") or {}).get(k)
            unit = UNITS.get(k.split("[", 1)[0], "")
            rows.append([k, unit, pm(p['mean'], p['sd']), interval(*p['hdi_90'], p['sd']),
                         "-" if est is None else pm(est, sd),
                         f"{p['ess_bulk']:.0f}" if p.get("ess_bulk") else "-",
                         f"{p['ess_tail']:.0f}" if p.get("ess_tail") else "-",
                         f"{p['r_hat']:.4f}" if p.get("r_hat") else "-",
                         _g((s.get("autocorr_time") or {}).get(k))])
        widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
        line = "  ".join(f"{{:<{w}}}" if i < 2 else f"{{:>{w}}}" for i, w in enumerate(widths))
        lines = []
        if self.note:
            lines.append(self.note)
        reason = {"converged": f"converged (every ESS >= {_g(s.get('target_ess'))})",
                  "max_steps": "stopped at max_steps: NOT converged"}.get(s.get("stop_reason", ""),
                                                                            s.get("stop_reason", ""))
        lines.append(f"{s.get('name', self.run_dir.name)}: {s['walkers']} walkers x {s['steps']} steps "
                     f"(burn-in {s.get('burn_in', '-')}, {s.get('draws', '-')} draws kept), "
                     f"moves {s.get('moves', '-')}, {reason}, sigma0 = {_sigma0_text(s.get('sigma0'))} MPa, "
                     f"{_g(s.get('wall_time_s'))} s")
        lines.append(line.format(*head))
        lines.append(line.format(*("-" * w for w in widths)))
        lines += [line.format(*r) for r in rows]
        noise = s.get("noise") or {}
        if noise.get("verdict"):
            lines.append(f"noise: {noise['model']} likelihood. {noise['verdict']}")
        checks = s.get("checks") or {}
        if checks.get("verdict"):
            head, points = verdict_lines(checks)
            lines += [f"verdict: {head}", *(f"  - {p}" for p in points)]
        from bayes_dnlr.runs.modulus_view import console_lines

        lines += console_lines(s)
        from bayes_dnlr.runs.reference_moduli import summary_lines

        lines += summary_lines(s.get("reference_moduli"))
        warn = s.get("warnings") or []
        lines += [f"warning: {w}" for w in warn]
        lines.append(f"outputs: {self.run_dir}/{{{CHAINS_FILE}, {POSTERIOR_FILE}, {SUMMARY_FILE}}}")
        return "\n".join(lines)


def load_posterior(run_dir: Path, note: str = "") -> Posterior:
    """The Posterior of a finished run from its summary.json (DataTree loaded lazily)."""
    summary = read_summary(run_dir)
    if summary is None:
        raise FileNotFoundError(f"{run_dir}: no readable {SUMMARY_FILE}")
    return Posterior(Path(run_dir), summary, note=note)
