"""A run folder's results, read once for the report, compare and batch: the config, fit.json,
summary.json, the posterior draws of posterior.nc and the test data, with what could not be read.

``load_run`` never raises for a missing or broken output: what is missing is None and why is listed
in ``problems``, so that a report can always say what it lacks.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.config import Config, load_config
from bayes_dnlr.errors import DamagedFileError
from bayes_dnlr.inference.layout import Layout, joint_name
from bayes_dnlr.readback import read_json, within_deadline
from bayes_dnlr.runs.folder import find_config
from bayes_dnlr.runs.layout import FIT_FILE, POSTERIOR_FILE, SMOOTHING_CACHE, SUMMARY_FILE
from bayes_dnlr.runs.netcdf import SAMPLE_DIMS
from bayes_dnlr.runs.records import Analysis, FitRecord, TestFit, held_config
from bayes_dnlr.runs.testset import plain_names
from bayes_dnlr.vocabulary import NOISE_NAMES, base_name


@dataclass
class RunResults:
    """What a run directory holds, read once for the report and compare; or one test of a run
    with several, seen as a run with one test (``of_test``)."""

    run_dir: Path
    cfg: Config
    fit: dict | None = None
    summary: dict | None = None
    draws: dict[str, np.ndarray] | None = None   # name -> (chain, draw), physical units
    test: Any = None                             # bayes_dnlr.data.TestData, or None
    data_error: str | None = None
    problems: list[str] = field(default_factory=list)
    stale: list[str] = field(default_factory=list)   # results made from another config or data
    fit_record: FitRecord | None = None          # fit.json, typed (read from ``fit`` on first use)
    run_noise: str | None = None                 # a test's view: the noise model of the run's posterior
    _tests: dict[str, RunResults] = field(default_factory=dict, repr=False)
    _loaded: dict[str, Any] = field(default_factory=dict, repr=False)   # tests' data read already

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
        return [n for n in self.names if base_name(n) not in NOISE_NAMES]

    @property
    def uses_discrepancy(self) -> bool:
        """True when the posterior used the model-discrepancy likelihood (a test's view: that
        test's own likelihood)."""
        return ((self.summary or {}).get("noise") or {}).get("model") == "discrepancy"

    @property
    def record(self) -> FitRecord | None:
        """fit.json as a typed record (None without fit.json)."""
        if self.fit_record is None and self.fit is not None:
            self.fit_record = FitRecord.from_dict(self.fit, self.cfg.test_names)
        return self.fit_record

    def gls(self) -> dict[str, Any] | None:
        """The generalized least-squares analysis (fit.json's discrepancy block), in gn()'s layout."""
        rec = self.record
        return None if rec is None or rec.generalized is None else _layout(rec.generalized, False)

    @property
    def compared_with_gls(self) -> bool:
        """Whether the posterior is compared with the generalized analysis (``linearized``): it used
        the discrepancy and fit.json holds that analysis."""
        run_gls = (self.run_noise or ((self.summary or {}).get("noise") or {}).get("model")) == "discrepancy"
        return run_gls and self.record is not None and self.record.generalized is not None

    def linearized(self) -> dict[str, Any] | None:
        """The linearized analysis the posterior is to be compared with: GLS when the run's
        posterior used the discrepancy, else the paper's white Gauss-Newton analysis."""
        return self.gls() if self.compared_with_gls else self.gn()

    @property
    def truth(self) -> dict[str, float] | None:
        return dict(self.cfg.truth.params) if self.cfg.truth is not None else None

    @property
    def has_posterior(self) -> bool:
        return self.summary is not None and bool(self.summary.get("posterior"))

    def gn(self) -> dict[str, Any] | None:
        """Gauss-Newton results as {estimate, sd (per name), correlation, delta_tilde, covariance,
        err}: fit.json's white analysis, else summary.json's copy of it."""
        rec = self.record
        if rec is not None:
            a = rec.white
        elif self.summary is not None and self.summary.get("gauss_newton"):
            src = self.summary["gauss_newton"]
            a = Analysis.from_dict(src, list(src.get("parameters") or self.model_names))
        else:
            a = None
        return None if a is None else _layout(a, True)

    @property
    def layout(self) -> Layout:
        """The run's names and each test's own (``Layout.plain`` for a run with one test)."""
        rec = self.record
        per_test = (rec.per_test if rec is not None and rec.per_test else self.cfg.per_test_parameters)
        plain = plain_names(self.cfg)
        names = self.names
        local = {}
        for t in self.cfg.test_names:
            own = [*self.cfg.for_test(t).free_parameters, *NOISE_NAMES]
            local[t] = [k for k in own if (k if plain or (k not in per_test and k not in NOISE_NAMES)
                                          else joint_name(k, t)) in names]
        return Layout.build(local, per_test, plain)

    def of_test(self, test: str) -> RunResults:
        """One test of the run seen as a run with one test: the run's draws, posterior and
        analyses under the test's own names (``tau_max[r5e-3]`` -> ``tau_max``), its own noise,
        data and residuals. A run with one test is its own (as ``Config.for_test``)."""
        layout = self.layout
        if layout.plain:
            return self
        if test in self._tests:
            return self._tests[test]
        cfg = self.cfg.for_test(test)
        own = {k: layout.name(k, test) for k in layout.local[test]}
        rec = self.record
        record = None
        if rec is not None:
            record = rec.for_test(test, {k: g for k, g in own.items() if g in rec.names})
        summary = None
        if self.summary is not None:
            s = self.summary
            post = s.get("posterior") or {}

            def per(key: str) -> Any:
                v = s.get(key)
                return v.get(test) if isinstance(v, dict) else None

            summary = {"parameters": [k for k, g in own.items() if g in post],
                       "posterior": {k: post[g] for k, g in own.items() if g in post},
                       "noise": ((s.get("noise") or {}).get("tests") or {}).get(test),
                       "sigma0": per("sigma0"), "standards": per("standards"),
                       "deborah_max": per("deborah_max"),
                       "deborah_max_posterior": per("deborah_max_posterior")}
        draws = None
        if self.draws is not None:
            draws = {k: self.draws[g] for k, g in own.items() if g in self.draws}
        view = RunResults(run_dir=self.run_dir, cfg=cfg, summary=summary, draws=draws, fit_record=record,
                          run_noise=((self.summary or {}).get("noise") or {}).get("model"),
                          _loaded={test: self._loaded[test]} if test in self._loaded else {})
        attach_test(view, cfg)
        self._tests[test] = view
        return view

    @property
    def tests(self) -> dict[str, RunResults]:
        """Each test of the run, seen as a run with one test (``of_test``), in config order."""
        return {t: self.of_test(t) for t in self.cfg.test_names}

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

    def own_fit(self) -> TestFit | None:
        """The test's fit of a run with one test (None for a run with several, or without fit.json)."""
        rec = self.record
        return next(iter(rec.tests.values())) if rec is not None and rec.plain else None

    def strain_rate(self) -> float | None:
        own = self.own_fit()
        if own is not None and own.strain_rate is not None:
            return own.strain_rate
        if self.summary and self.summary.get("strain_rate") is not None:
            return float(self.summary["strain_rate"])
        if self.test is not None:
            return float(self.test.strain_rate)
        if self.cfg.truth is not None:
            return float(self.cfg.truth.strain_rate)
        return self.cfg.data.strain_rate

    def sigma0(self) -> float | None:
        """The noise sd used (MPa): a number from summary or fit (posterior mean when sampled)."""
        s = (self.summary or {}).get("sigma0")
        if isinstance(s, dict):
            s = s.get("mean", s.get("value"))
        try:
            if s is not None:
                return float(s)
        except (TypeError, ValueError):
            pass
        own = self.own_fit()
        if own is not None and own.sigma0 is not None:
            return own.sigma0
        if self.summary and "sigma0" in (self.summary.get("posterior") or {}):
            return float(self.summary["posterior"]["sigma0"]["mean"])
        return None


def _layout(a: Analysis, cov_from_sd: bool) -> dict[str, Any]:
    """An analysis as {names, estimate, sd, correlation, covariance, delta_tilde, err}."""
    names = a.names
    sd = {n: a.sd[n] for n in names if n in a.sd} or None
    cov = a.covariance
    if cov is None and cov_from_sd and a.correlation is not None and sd is not None and len(sd) == len(names):
        s = np.array([sd[n] for n in names])
        cov = a.correlation * np.outer(s, s)
    return {"names": names, "estimate": {n: a.estimate[n] for n in names if n in a.estimate}, "sd": sd,
            "correlation": a.correlation, "covariance": cov, "delta_tilde": a.delta_tilde,
            "err": dict(a.err)}


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
        return read_json(path, path.name)
    except (OSError, DamagedFileError) as err:
        problems.append(f"{path.name} could not be read: {err}")
        return None


def read_draws(path: Path, names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Posterior draws {name: (chain, draw)} from posterior.nc (ArviZ DataTree, any dim order).

    Read with h5py, by netCDF-4's conventions (xarray and pandas cost the report 0.3-0.6 s to
    import, h5netcdf 20 ms a file); a file it cannot read that way (no (chain, draw) variables, a
    scale factor, another format) goes through xarray. Read within a deadline (readback.py): a
    damaged file raises DamagedFileError in seconds."""
    path = Path(path)
    got = within_deadline(lambda emit: emit("draws", _read_draws_any(path, names)), path)
    if got.failure is not None:
        raise DamagedFileError(f"{path}: damaged, its draws cannot be read ({got.failure}); "
                               f"{REWRITE_POSTERIOR}")
    return got["draws"]


# what rebuilds a damaged posterior.nc or summary.json (runs/sample.py, ``_finished_result``)
REWRITE_POSTERIOR = (f"remove it and run `sample` on the run's config: {POSTERIOR_FILE} and "
                     f"{SUMMARY_FILE} are written again from chains.h5")


def _read_draws_any(path: Path, names: Sequence[str] | None) -> dict[str, np.ndarray]:
    try:
        out = _read_draws_h5(path, names)
    except (OSError, KeyError, ValueError, TypeError, ImportError):
        out = None
    return out if out else _read_draws_xarray(path, names)


def _read_draws_h5(path: Path, names: Sequence[str] | None) -> dict[str, np.ndarray]:
    import h5py

    out = {}
    with h5py.File(path, "r") as f:
        g = f["posterior"]
        for k, var in g.items():
            if not isinstance(var, h5py.Dataset) or var.is_scale or (names is not None and k not in names):
                continue
            dims = tuple(_dimension(var, axis) for axis in range(var.ndim))
            packed = set(var.attrs) & {"scale_factor", "add_offset"}
            if packed or dims not in (SAMPLE_DIMS, SAMPLE_DIMS[::-1]):
                return {}
            a = np.asarray(var[...], dtype=float)
            fill = var.attrs.get("_FillValue")
            if fill is not None and np.isfinite(np.asarray(fill, dtype=float)).all():
                a = np.where(a == np.asarray(fill, dtype=float).ravel()[0], np.nan, a)
            out[str(k)] = a if dims == SAMPLE_DIMS else a.T
    return out


def _dimension(var, axis: int) -> str | None:
    """The netCDF dimension of ``var``'s axis: the name of the one dimension scale attached to it
    (netCDF-4 names a dimension's scale after the dimension; None: no scale, or several)."""
    scales = var.dims[axis]
    return scales[0].name.rsplit("/", 1)[-1] if len(scales) == 1 else None


def _read_draws_xarray(path: Path, names: Sequence[str] | None) -> dict[str, np.ndarray]:
    import xarray as xr

    with xr.open_datatree(path) as tree:
        post = tree["posterior"].to_dataset()
        out = {}
        for k in post.data_vars:
            if names is not None and k not in names:
                continue
            da = post[k]
            dims = [d for d in SAMPLE_DIMS if d in da.dims]
            if len(dims) == 2:
                da = da.transpose(*SAMPLE_DIMS, ...)
            elif "draw" in da.dims:
                da = da.expand_dims("chain").transpose("chain", "draw", ...)
            a = np.asarray(da.values, dtype=float)
            if a.ndim == 2:
                out[str(k)] = a
    return out


def load_run(run_dir: Path | str, load_data: bool = True, source: Path | str | None = None,
             tests: Mapping[str, Any] | None = None, provenance: bool = True) -> RunResults:
    """Read a run directory. Missing pieces are None; what went wrong is listed in ``problems``;
    results made from another config or data than the current ones (``source``: the user's config
    when known, see ``runs.provenance``) are listed in ``stale``, unless ``provenance`` is False
    (``sample``, which has just made them). ``tests``: the tests' data by name, when the caller
    has read them already."""
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
    run = RunResults(run_dir=run_dir, cfg=cfg, problems=problems, _loaded=dict(tests or {}))
    run.fit = _read_json(run_dir / FIT_FILE, problems)
    run.summary = _read_json(run_dir / SUMMARY_FILE, problems)
    nc = run_dir / POSTERIOR_FILE
    if nc.is_file():
        try:
            run.draws = read_draws(nc) or None
        except Exception as err:  # noqa: BLE001 - any reader failure becomes a note in the report
            problems.append(f"posterior.nc could not be read: {err}")
    if load_data:
        attach_data(run)
    if provenance:
        from bayes_dnlr.runs.provenance import stale_results

        run.stale = stale_results(run_dir, cfg, run.fit, run.summary, source, problems)
    run.cfg = held_config(cfg, run.fit)       # as the run fitted and sampled it
    return run


def attach_data(run: RunResults) -> None:
    """The data of a run with one test into ``run.test`` (``load_run`` does it unless told not
    to); a run with several tests reads each test's data with its view (``of_test``)."""
    if plain_names(run.cfg) and run.test is None and run.data_error is None:
        attach_test(run, run.cfg)


def attach_test(run: RunResults, cfg: Config) -> None:
    """The run's data into ``run.test``; when it cannot be read, why into ``run.data_error``."""
    if len(run._loaded) == 1 and cfg.test_names == list(run._loaded):
        run.test = next(iter(run._loaded.values()))
        return
    try:
        from bayes_dnlr.data import load_test

        run.test = load_test(cfg, cfg.run_dir / SMOOTHING_CACHE)
    except Exception as err:  # noqa: BLE001 - the report says what is missing and goes on
        run.data_error = f"{type(err).__name__}: {err}"




def stale_notes(run_dir: Path | str, source: Path | str | None = None) -> list[str]:
    """``load_run(run_dir, source=source).stale`` without reading the draws or the data: why the
    folder's results do not belong to the current config and data (empty when they do)."""
    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.runs.provenance import stale_results

    run_dir = Path(run_dir)
    try:
        cfg = load_config(find_config(run_dir))
    except (FileNotFoundError, BayesDnlrError):
        return []              # the report itself says what is wrong with the folder
    problems: list[str] = []
    return stale_results(run_dir, cfg, _read_json(run_dir / FIT_FILE, problems),
                         _read_json(run_dir / SUMMARY_FILE, problems), source)


def verdict_lines(checks: Mapping[str, Any]) -> tuple[str, list[str]]:
    """The checks' verdict (summary.json ``checks``) as its first sentence and one line per check
    (``verdict_points``); the whole verdict and no lines when its points are not recorded (a run of
    an earlier version) or there is only one."""
    words = str(checks.get("verdict") or "")
    points = [str(p) for p in checks.get("verdict_points") or []]
    tail = " ".join(points)
    if len(points) < 2 or not words.endswith(tail):
        return words, []
    return words[: len(words) - len(tail)].strip(), points
