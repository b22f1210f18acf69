"""The least-squares fit of a run, one test or several, and its stochastic analysis.

1. Each test alone (``fit_test`` on its single-test view): its estimate, its σ0 and, with the model
   discrepancy, its maximum-likelihood hyperparameters and the evidence of model error.
2. The joint white fit: Σ_tests |y_t - f_t(θ)|² / σ0_t², from the pooled single-test estimates.
   Δ = (XᵀWX)⁻¹ with W = diag(1/σ0_t²): every test counts by its own noise.
3. With the discrepancy (where a test shows model error): the joint generalized least squares,
   each such test whitened by its own K_t (hyperparameters held at the single-test ML values),
   Δ = (Σ X_tᵀ K_t⁻¹ X_t)⁻¹.

A run with one test (plain names, ``Layout.plain``) stops after step 1: its test's fit is the run's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.digests import jsonable
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference.discrepancy.axis import test_axis
from bayes_dnlr.inference.discrepancy.hyper import Hyper, discrepancy_priors, is_white, whitener
from bayes_dnlr.inference.layout import Layout, test_of
from bayes_dnlr.inference.lsq.identify import FitResult, fit_test
from bayes_dnlr.inference.lsq.optimize import run_minimiser
from bayes_dnlr.inference.lsq.problem import LsqProblem
from bayes_dnlr.inference.lsq.run_problem import RunProblem
from bayes_dnlr.inference.lsq.sensitivity import StochasticAnalysis, analyse, identifiability_warnings
from bayes_dnlr.inference.lsq.temperature_start import alone, joint_start
from bayes_dnlr.inference.lsq.whiteness import residual_diagnostics
from bayes_dnlr.numbers import err_pct, fmt, fmt_at, fmt_sd, pm
from bayes_dnlr.vocabulary import TIME_CONSTANTS, base_name, fixing, unit


@dataclass
class RunFit:
    """The fit of a run: estimates of its parameter vector, Δ̃, and each test's own fit (for a run
    with one test, that test's fit is the run's: ``only``)."""

    name: str
    names: list[str]
    estimate: dict[str, float]
    sd: dict[str, float]
    err: dict[str, float]
    covariance: np.ndarray
    correlation: np.ndarray
    delta_tilde: np.ndarray
    tests: dict[str, dict[str, Any]]       # per test: n_points, sigma0, residuals at the joint estimate
    singles: dict[str, FitResult]          # each test fitted alone
    criterion: float
    converged: bool
    message: str
    iterations: int
    condition_number: float
    warnings: list[str]
    discrepancy: dict[str, Any] | None = None   # the joint GLS analysis
    per_test: list[str] = field(default_factory=list)
    config_digest: str = ""
    config_sections: dict[str, str] = field(default_factory=dict)
    data_sha256: str = ""
    wall_time_s: float = 0.0
    plain: bool = False                    # one test, plain names: fit.json is that test's fit
    identifiability: dict[str, Any] | None = None   # parameters held: no test identifies them
    modulus_reference: dict[str, Any] | None = None  # E(t) at T_ref (runs/master_curve.py)
    shift_law: dict[str, Any] | None = None          # its held-out check (runs/shift_law.py)
    references: dict[str, Any] | None = None        # fit.json's reference_moduli and reference_data
    reference_lines: list[str] = field(default_factory=list)   # their lines of the console table

    @classmethod
    def of_one_test(cls, fit: FitResult) -> RunFit:
        """The run fit of a run with one test: that test's fit."""
        return cls(name=fit.name, names=fit.names, estimate=fit.estimate, sd=fit.sd, err=fit.err,
                   covariance=fit.covariance, correlation=fit.correlation,
                   delta_tilde=fit.delta_tilde, tests={}, singles={fit.name: fit},
                   criterion=fit.criterion, converged=fit.converged, message=fit.message,
                   iterations=fit.iterations, condition_number=fit.condition_number,
                   warnings=fit.warnings, discrepancy=fit.discrepancy, plain=True)

    @property
    def only(self) -> FitResult:
        """The test's fit of a run with one test."""
        if len(self.singles) != 1:
            raise ValueError(f"the run has {len(self.singles)} tests: use .singles[name]")
        return next(iter(self.singles.values()))

    @property
    def n_points(self) -> int:
        return int(sum(r.n_points for r in self.singles.values()))

    def to_dict(self) -> dict[str, Any]:
        """JSON-able content of fit.json: a run with one test writes its test's fit."""
        from bayes_dnlr import __version__

        if self.plain:
            single = self.only
            single.config_digest, single.config_sections = self.config_digest, self.config_sections
            single.data_sha256, single.wall_time_s = self.data_sha256, self.wall_time_s
            return {**single.to_dict(), **jsonable(self.references or {})}
        return jsonable({
            **(self.references or {}), "name": self.name, "joint": True, "parameters": self.names,
            "per_test": self.per_test,
            "estimate": self.estimate, "sd": self.sd, "err": self.err,
            "units": {k: unit(k) for k in self.names},
            "covariance": self.covariance, "correlation": self.correlation,
            "delta_tilde": self.delta_tilde, "n_points": self.n_points,
            "tests": self.tests,
            "single_fits": {t: {k: v for k, v in r.to_dict().items()
                                if k in ("estimate", "sd", "err", "sigma0", "sigma0_source", "residuals",
                                         "warnings", "discrepancy", "strain_rate", "deborah_max",
                                         "n_points", "relaxation_start", "data_notes", "spectrum_exponent",
                                         "modulus_at", "identifiability", "parameters", "converged", "fixed",
                                         "stress_score", "stress_refit",
                                         "covariance")}
                            for t, r in self.singles.items()},
            "criterion": self.criterion, "converged": self.converged, "message": self.message,
            "iterations": self.iterations, "condition_number": self.condition_number,
            "warnings": self.warnings, "discrepancy": self.discrepancy,
            "config_digest": self.config_digest, "config_sections": self.config_sections,
            "data_sha256": self.data_sha256, "version": __version__, "wall_time_s": self.wall_time_s,
            "identifiability": self.identifiability,
            **({"modulus_reference": self.modulus_reference} if self.modulus_reference else {}),
            **({"shift_law": self.shift_law} if self.shift_law else {}),
        })

    def table(self) -> str:
        """The console table of the fit."""
        return "\n".join([self._table(), *self.reference_lines])

    def _table(self) -> str:
        if self.plain:
            return self.only.table()
        d = self.discrepancy
        lines = [f"joint fit {self.name}: {len(self.tests)} tests, {self.n_points} points, "
                 f"{'converged' if self.converged else 'NOT converged'}"]
        for t, info in self.tests.items():
            lines.append(f"  {t}: {info['n_points']} points, sigma0 {fmt(info['sigma0'], 3)} MPa, rate "
                         f"{fmt(info['strain_rate'], 3)} 1/s, residuals "
                         f"{'white' if info['residuals']['white'] else 'NOT white'}"
                         + (f", discrepancy ({info['discrepancy']})" if info.get("discrepancy") else ""))
        w = max(len(k) for k in self.names) + 2
        head = f"{'parameter':<{w}}{'estimate':>14}{'sd':>12}{'Err %':>9}"
        if d:
            head += f"  {'GLS estimate':>14}{'sd':>12}{'Err %':>9}"
        lines += ["", head + "  unit"]
        for k in self.names:
            sd = self.sd[k]
            row = f"{k:<{w}}{fmt_at(self.estimate[k], sd):>14}{fmt_sd(sd):>12}{err_pct(self.err[k]):>9}"
            if d:
                gs = d["sd"][k]
                row += f"  {fmt_at(d['estimate'][k], gs):>14}{fmt_sd(gs):>12}{err_pct(d['err'][k]):>9}"
            lines.append(row + f"  {unit(k)}")
        lines += ["", "single-test estimates (each test alone):"]
        for t, r in self.singles.items():
            src = r.discrepancy if (r.discrepancy and t in (d or {}).get("tests", [])) else None
            est = (src or {}).get("estimate", r.estimate)
            sds = (src or {}).get("sd", r.sd)
            lines.append(f"  {t}: " + ", ".join(f"{k} {pm(est[k], sds.get(k))}"
                                                 for k in r.names))
        if self.warnings:
            lines += ["warnings:"] + [f"  - {m}" for m in self.warnings]
        return "\n".join(lines)


def _analyse(problem: RunProblem, params: dict[str, float]) -> StochasticAnalysis:
    X = problem.jacobian(params)
    names = problem.names
    zero = [k for k, c in zip(names, np.linalg.norm(X, axis=0), strict=True) if c == 0]
    if zero:
        raise BayesDnlrError(
            f"parameters {zero} have no effect on any test's window: no test can identify them; fix "
            f"them ({'; '.join(fixing(k, params[k]) for k in zero)}: any value does the same here) or "
            "give them a test that can")
    try:
        return analyse(X, names, problem.vector(params), 1.0)
    except np.linalg.LinAlgError as err:
        raise BayesDnlrError(f"the joint sensitivity matrix is singular at the optimum ({err}): the "
                             f"parameters {names} cannot all be identified by these tests") from None


def _joint_identifiability(sa: StochasticAnalysis) -> list[str]:
    """The identifiability warnings of the joint vector, the strongly correlated pairs in one line:
    a shared E ties every test's tau_max to it and so to each other."""
    from bayes_dnlr.inference.lsq.sensitivity import RHO_WARN

    out = identifiability_warnings(sa)
    pairs = [w for w in out if w.startswith("|ρ(")]
    if len(pairs) < 2:
        return out
    import re

    found = [re.match(r"\|ρ\((.+?), (.+?)\)\| = ([0-9.]+)", w) for w in pairs]
    names = "; ".join(f"{m[1]}–{m[2]} {m[3]}" for m in found if m)
    merged = (f"strongly correlated pairs (|ρ| > {RHO_WARN}, the joint white least squares): {names}. "
              "A shared parameter ties "
              "each test's own parameters to it and so to each other. The paper finds ρ(E, tau_max) "
              "≈ -0.9988 on one whole curve and still identifies both (Err ≈ 1.4 %); check Err")
    return [w for w in out if w not in pairs] + [merged]


def _blocks(views: dict[str, Config], tests: dict[str, Any]) -> dict[str, LsqProblem]:
    return {t: LsqProblem.for_config(cfg, tests[t]) for t, cfg in views.items()}


def _fit_single(i: int, view: Config, test: Any) -> FitResult:
    """One test alone; its errors name the test (``tests[i] (name): ...``): a parameter its data
    cannot identify is a config error of that test (fix it, give it ``per: test``, or widen the
    window)."""
    try:
        return fit_test(view, test)
    except BayesDnlrError as err:
        raise type(err)(f"tests[{i}] ({view.name}): {err}") from None


def joint_white_problem(cfg: Config, tests: dict[str, Any], singles: Mapping[str, FitResult],
                        identifiability: Mapping[str, Any] | None) -> tuple[RunProblem, Config]:
    """The joint white least-squares problem of several tests (each weighted by 1/σ0 of its own fit)
    and the config it is of: with the parameters every test's fit held (``identifiability``)
    fixed."""
    if identifiability is not None:
        cfg = cfg.with_holds({k: v["value"] for k, v in identifiability["held"].items()})
    views = {t: cfg.for_test(t) for t in cfg.test_names}
    layout = Layout.build({t: views[t].free_parameters for t in views}, cfg.per_test_parameters)
    bounds = {g: cfg.parameters[base_name(g)].bounds() for g in layout.names}
    return RunProblem(_blocks(views, tests), layout, bounds,
                      {t: 1.0 / singles[t].sigma0 for t in views}), cfg


def fit_run(cfg: Config, tests: dict[str, Any], plain: bool) -> RunFit:
    """The fit of a run (``tests``: name -> TestData; ``plain``: one test under plain names);
    writes nothing."""
    t0 = time.perf_counter()
    if plain:
        (t, test), = tests.items()
        return RunFit.of_one_test(fit_test(cfg, test))
    views = {t: cfg.for_test(t) for t in cfg.test_names}
    singles = {t: _fit_single(i, alone(views[t], tests[t]), tests[t]) for i, t in enumerate(views)}
    identifiability = _held_by_every_test(singles)
    problem, cfg = joint_white_problem(cfg, tests, singles, identifiability)
    layout, views = problem.layout, {t: cfg.for_test(t) for t in cfg.test_names}
    sigma0 = {t: singles[t].sigma0 for t in views}
    start = joint_start(cfg, pooled_start({t: r.estimate for t, r in singles.items()},
                                          {t: r.sd for t, r in singles.items()}, layout),
                        singles, tests)
    beta0 = np.clip(problem.vector(start), problem.lower, problem.upper)
    opt = run_minimiser(problem, cfg.fit.method, beta0, cfg.fit.max_iterations)
    params = problem.params(opt.beta)
    sa = _analyse(problem, params)
    warnings = [f"{t}: {w}" for t, r in singles.items() for w in r.warnings
                if "residuals are not white" in w]
    warnings += _joint_identifiability(sa)
    raw = problem.raw_residuals(params)
    info = {}
    for t, r in singles.items():
        diag = residual_diagnostics(raw[t], sigma0[t], r.sigma0_source)
        info[t] = {"n_points": int(raw[t].size), "sigma0": sigma0[t], "sigma0_source": r.sigma0_source,
                   "strain_rate": r.strain_rate, "residuals": diag,
                   "rms_single_fit": r.diagnostics["rms"], "rms_joint_fit": diag["rms"]}
        if r.diagnostics["white"] and not diag["white"]:
            warnings.append(f"{t}: its residuals are white alone but not in the joint fit: the shared "
                            "parameters do not fit this test as well as its own would (see the "
                            "single-test estimates)")
    disc = _joint_gls(cfg, problem, params, singles, tests, info, warnings)
    return RunFit(
        name=cfg.name, names=layout.names, estimate=params,
        sd=dict(zip(layout.names, map(float, sa.sd), strict=True)),
        err=dict(zip(layout.names, map(float, sa.err), strict=True)),
        covariance=sa.covariance, correlation=sa.correlation, delta_tilde=sa.delta_tilde,
        tests=info, singles=singles, criterion=float(opt.criterion), converged=bool(opt.converged),
        message=opt.message, iterations=int(opt.iterations), condition_number=sa.condition_number,
        warnings=warnings, discrepancy=disc, per_test=cfg.per_test_parameters,
        wall_time_s=time.perf_counter() - t0, identifiability=identifiability)


def _held_by_every_test(singles: Mapping[str, FitResult]) -> dict[str, Any] | None:
    """The parameters every test's own fit held (no test's window identifies them), to hold in the
    joint fit too; each with the tests' sensitivities. None when there are none: a parameter one
    test identifies stays free, that test places it."""
    held = [set((r.identifiability or {}).get("held") or {}) for r in singles.values()]
    common = set.intersection(*held) if held else set()
    if not common:
        return None
    out = {k: {"value": next(iter(singles.values())).identifiability["held"][k]["value"],
               "sensitivity": {t: r.identifiability["held"][k]["sensitivity"]
                               for t, r in singles.items()}} for k in sorted(common)}
    words = "; ".join(f"{k} held at {v['value']:g}: no test's window identifies it" for k, v in out.items())
    return {"held": out, "words": words}


def _joint_gls(cfg: Config, problem: RunProblem, white: dict[str, float],
               singles: dict[str, FitResult], tests: dict[str, Any], info: dict[str, dict],
               warnings: list[str]) -> dict[str, Any] | None:
    """The joint generalized least squares, each test with model error whitened by its own K."""
    used = {}
    for t, r in singles.items():
        d = r.discrepancy
        if not d:
            continue
        priors = discrepancy_priors(r.to_dict())
        if priors is None or is_white(priors):
            continue
        view = cfg.for_test(t)
        axis = test_axis(view.noise.discrepancy, tests[t], problem.blocks[t].mask)
        h = d["hyperparameters"]
        used[t] = whitener(axis, Hyper(h["sigma0"], h["amplitude"], h["length"]), d["kernel"])
        info[t]["discrepancy"] = (f"{d['kernel']}, amplitude {fmt(h['amplitude'], 3)} MPa, length "
                                  f"{fmt(h['length'], 3)} {d.get('axis_unit', 's')}")
    if not used:
        return None
    weights = dict(problem.weights)
    problem.weights = {t: (1.0 if t in used else w) for t, w in weights.items()}
    problem.set_whiteners(used)
    try:
        opt = run_minimiser(problem, cfg.fit.method, problem.vector(white), cfg.fit.max_iterations)
        params = problem.params(opt.beta)
        try:
            sa = _analyse(problem, params)
        except BayesDnlrError as err:
            warnings.append(f"the joint generalized least-squares analysis has no covariance: {err}")
            sa = None
    finally:
        problem.set_whiteners(dict.fromkeys(used))
        problem.weights = weights
    names = problem.names
    nan = np.full((len(names), len(names)), math.nan)
    sd = sa.sd if sa is not None else np.full(len(names), math.nan)
    return {
        "tests": sorted(used), "estimate": params,
        "sd": dict(zip(names, map(float, sd), strict=True)),
        "err": {k: float(s) / abs(params[k]) if params[k] else math.nan
                for k, s in zip(names, sd, strict=True)},
        "covariance": nan if sa is None else sa.covariance,
        "correlation": nan if sa is None else sa.correlation,
        "delta_tilde": nan if sa is None else sa.delta_tilde,
        "criterion": float(opt.criterion), "converged": bool(opt.converged), "message": opt.message,
    }


def pooled_start(estimates: Mapping[str, Mapping[str, float]], sds: Mapping[str, Mapping[str, float]],
                 layout: Layout) -> dict[str, float]:
    """A start for the joint fit from the single-test fits: a shared parameter at the
    inverse-variance mean of the tests' estimates (the geometric one for time constants), a
    per-test parameter at its test's own estimate."""
    out: dict[str, float] = {}
    for name in layout.names:
        t = test_of(name)
        k = base_name(name)
        if t is not None:
            out[name] = float(estimates[t][k])
            continue
        vals, wts = [], []
        for test in layout.tests:
            if k in estimates[test]:
                v, s = float(estimates[test][k]), float(sds[test].get(k, math.nan))
                vals.append(math.log(v) if k in TIME_CONSTANTS else v)
                rel = s / v if k in TIME_CONSTANTS and v > 0 else s
                wts.append(1.0 / rel**2 if math.isfinite(rel) and rel > 0 else 1.0)
        m = float(np.average(vals, weights=wts))
        out[name] = math.exp(m) if k in TIME_CONSTANTS else m
    return out
