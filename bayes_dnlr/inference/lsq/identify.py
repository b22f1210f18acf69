"""Least-squares identification and the paper's stochastic analysis: ``fit`` (sections 3.2, 4, 5).

``fit_test(cfg, test)`` fits the free parameters on the window from a physics-based start (paper
4.1), checks the optimum from ``cfg.fit.multistart`` starts spread over the prior box, and computes
the sensitivities X (eq. 22), Δ (eq. 32), Err (eq. 33), ρ (eq. 34), Δ̃ (eq. 35), the residual
diagnostics and identifiability warnings. It writes nothing: ``bayes_dnlr.runs.fit`` writes
``<run_dir>/fit.json``.

Methods (``cfg.fit.method``):
- ``lm``: variable projection (the model is linear in E, G, sigma_inf: they are solved by linear least
  squares for each set of time constants, and the time constants by bounded trust-region least
  squares), then a joint trust-region polish of all free parameters.
- ``gauss-newton``: the paper's iteration (eq. 29) on all free parameters, with step control.
"""

from __future__ import annotations

import contextlib
import math
import time as _time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.digests import jsonable
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference.discrepancy.gls import discrepancy_analysis
from bayes_dnlr.inference.lsq import optimize
from bayes_dnlr.inference.lsq.plausibility import plausibility_warnings, singular_message
from bayes_dnlr.inference.lsq.problem import LsqProblem
from bayes_dnlr.inference.lsq.sensitivity import (
    HOLD_AT,
    NEGLIGIBLE_SENSITIVITY,
    StochasticAnalysis,
    alpha_dependence,
    analyse,
    analyse_holding,
    bound_side,
    bound_warning,
    hold_words,
    identifiability_warnings,
    score_test,
    unidentified,
)
from bayes_dnlr.inference.lsq.sigma0 import resolve_sigma0
from bayes_dnlr.inference.lsq.start import (
    SPECTRUM_START,
    clip_to,
    fallback,
    physics_start,
    spread_starts,
)
from bayes_dnlr.inference.lsq.stress_score import stress_score
from bayes_dnlr.inference.lsq.whiteness import residual_diagnostics
from bayes_dnlr.numbers import err_pct, fmt, fmt_at, fmt_sd
from bayes_dnlr.vocabulary import UNITS, UNIVERSAL_EXPONENT, fixing

SAME_OPTIMUM_SD = 0.01      # multi-start end points within this many sd of the best: same optimum
SAME_OPTIMUM_REL = 1.0e-6   # ... or within this relative distance (noise-free data: sd -> 0)


@dataclass
class FitResult:
    """Outcome of ``fit``: estimates, the stochastic analysis (eq. 32-35) and diagnostics."""

    name: str
    names: list[str]                 # free parameters, canonical order
    estimate: dict[str, float]       # all parameters, fixed ones included
    sd: dict[str, float]             # free parameters, linearized (eq. 32)
    covariance: np.ndarray           # Δ (eq. 32), p x p
    correlation: np.ndarray          # ρ (eq. 34)
    delta_tilde: np.ndarray          # Δ̃ (eq. 35): Err (fraction) on the diagonal, ρ off it
    err: dict[str, float]            # Err (eq. 33), fraction
    sigma0: float
    sigma0_source: str
    n_points: int
    residuals: np.ndarray            # y^m - y on the window (eq. 19)
    fitted: np.ndarray               # model stress on the window
    time: np.ndarray                 # window samples: time (s)
    strain: np.ndarray               # window samples: measured Hencky strain
    diagnostics: dict[str, Any]      # residual statistics and verdict
    method: str
    iterations: int
    evaluations: int
    criterion: float                 # SSR (eq. 20)
    converged: bool
    message: str
    multistart: dict[str, Any]
    condition_number: float          # of the normalised X̃ᵀX̃ (eq. 37)
    normalised_sensitivity_max: dict[str, float]   # max |X̃_j| on the window, MPa
    warnings: list[str]
    deborah_max: float | None        # tau_max · strain rate (eq. 45)
    strain_rate: float
    relaxation_start: float | None
    window: dict[str, Any]
    start: dict[str, float]          # the physics-based start actually used
    start_notes: dict[str, str]
    fixed: dict[str, float]
    config_digest: str = ""
    config_sections: dict[str, str] = field(default_factory=dict)
    data_sha256: str = ""
    wall_time_s: float = 0.0
    data_notes: list[str] = field(default_factory=list)   # from the data layer (e.g. a detected hold)
    discrepancy: dict[str, Any] | None = None   # the model-discrepancy (GLS) analysis, or None (white)
    spectrum_exponent: dict[str, Any] | None = None   # how the estimate depends on alpha (eq. 12)
    modulus_at: Any = None   # E(t) of this fit (runs/modulus_block.py fills it in: fit.json)
    stress_score: dict[str, Any] | None = None   # the stress shift held off, its score test
    stress_refit: dict[str, Any] | None = None   # the fit with it, when the score asks for it
    #                                              (runs/modulus_block.py fills it in: fit.json)
    identifiability: dict[str, Any] | None = None   # parameters held where the window cannot identify them

    def to_dict(self) -> dict[str, Any]:
        """JSON-able content of fit.json."""
        from bayes_dnlr import __version__

        names = self.names
        d = {
            "name": self.name,
            "parameters": names,
            "estimate": self.estimate,
            "sd": self.sd,
            "err": self.err,
            "units": {k: UNITS[k] for k in self.estimate},
            "fixed": self.fixed,
            "covariance": self.covariance.tolist(),
            "correlation": self.correlation.tolist(),
            "delta_tilde": self.delta_tilde.tolist(),
            "sigma0": self.sigma0,
            "sigma0_source": self.sigma0_source,
            "n_points": self.n_points,
            "window": self.window,
            "residuals": self.diagnostics,
            "method": self.method,
            "iterations": self.iterations,
            "evaluations": self.evaluations,
            "criterion": self.criterion,
            "converged": self.converged,
            "message": self.message,
            "multistart": self.multistart,
            "start": self.start,
            "start_notes": self.start_notes,
            "condition_number": self.condition_number,
            "normalised_sensitivity_max": self.normalised_sensitivity_max,
            "warnings": self.warnings,
            "deborah_max": self.deborah_max,
            "strain_rate": self.strain_rate,
            "relaxation_start": self.relaxation_start,
            "data_notes": self.data_notes,
            "config_digest": self.config_digest,
            "config_sections": self.config_sections,
            "data_sha256": self.data_sha256,
            "version": __version__,
            "wall_time_s": self.wall_time_s,
            "discrepancy": self.discrepancy,
            "spectrum_exponent": self.spectrum_exponent,
            "stress_score": self.stress_score,
            "stress_refit": self.stress_refit,
            "modulus_at": self.modulus_at,
            "identifiability": self.identifiability,
        }
        return jsonable(d)

    def table(self) -> str:
        """Short console table: estimates, sd, Err %, Δ̃, residual verdict, warnings."""
        lines = [f"fit {self.name}: {self.method}, {self.iterations} iterations, "
                 f"{'converged' if self.converged else 'NOT converged'}; SSR = {self.criterion:.6g} "
                 f"on {self.n_points} points; sigma0 = {self.sigma0:.4g} MPa ({self.sigma0_source})"]
        lines += [f"data: {note}" for note in self.data_notes]
        w = max(len(k) for k in self.estimate) + 2
        d = self.discrepancy
        head = f"{'parameter':<{w}}{'estimate':>14}{'sd':>12}{'Err %':>9}"
        if d:
            lines.append(f"{'':<{w}}{'white noise (paper, eq. 32-35)':^35}  "
                         f"{'under model error (projection θ*)':^35}")
            head += f"  {'estimate':>14}{'sd':>12}{'Err %':>9}"
        lines.append(head + "  unit")
        for k, v in self.estimate.items():
            if k not in self.sd:
                row = f"{k:<{w}}{fmt(v, 6):>14}{'fixed':>12}{'':>9}"
                if d:
                    row += f"  {fmt(v, 6):>14}{'fixed':>12}{'':>9}"
                lines.append(f"{row}  {UNITS[k]}")
                continue
            row = f"{k:<{w}}{fmt_at(v, self.sd[k]):>14}{fmt_sd(self.sd[k]):>12}{err_pct(self.err[k]):>9}"
            if d:
                gv, gs = d["estimate"][k], d["sd"][k]
                row += f"  {fmt_at(gv, gs):>14}{fmt_sd(gs):>12}{err_pct(d['err'][k]):>9}"
            lines.append(row + f"  {UNITS[k]}")
        lines.append("")
        lines += _delta_tilde_lines("Δ̃ (eq. 35), white noise: Err % on the diagonal, ρ off it",
                                    self.names, self.delta_tilde, w)
        if d:
            lines += _delta_tilde_lines("Δ̃ under model error (Var θ* + projection offset S(h))",
                                        self.names, np.asarray(d["delta_tilde"]), w)
        lines.append(f"condition number of X̃ᵀX̃: {self.condition_number:.4g}")
        lines.append("")
        dg = self.diagnostics
        lines.append(f"residuals: rms {dg['rms']:.4g} MPa; {dg['verdict']}")
        if d:
            lines += _discrepancy_lines(d, self.sd)
        ms = self.multistart
        if ms["starts"]:
            same = "all at the same optimum" if ms["same_optimum"] else "NOT all at the same optimum"
            lines.append(f"multi-start: {ms['converged']}/{ms['starts']} converged, {same}")
        if self.deborah_max is not None:
            lines.append(f"De_max = tau_max · rate = {self.deborah_max:.4g} (eq. 45, white least squares)")
        if self.spectrum_exponent is not None:
            lines.append(spectrum_line(self.spectrum_exponent, self.estimate))
        if self.warnings:
            lines.append("warnings:")
            lines.extend(f"  - {m}" for m in self.warnings)
        return "\n".join(lines)


def spectrum_line(dep: dict[str, Any], estimate: dict[str, float]) -> str:
    """One line: how far E moves per 0.1 of the spectrum's exponent (eq. 12 assumes ½)."""
    a = dep["alpha"]
    dE = dep["per_tenth"].get("E")
    if dE is None:
        return f"spectrum exponent alpha = {a:.3g}"
    how = ("white least squares; sampled by `sample`, E moves along its posterior" if dep["sampled"]
           else "fixed; E moves when it is held elsewhere")
    line = (f"spectrum exponent alpha = {a:.3g} ({how}): {dE:+.4g} MPa "
            f"({100 * dE / estimate['E']:+.2g} %) per +0.1 of alpha (eq. 12 has ½)")
    score = dep.get("score")
    if score is not None and math.isfinite(score["z"]):
        line += (f"; the data pull alpha away from {'½' if a == UNIVERSAL_EXPONENT else f'{a:.3g}'} by "
                 f"{score['z']:+.1f} sd (score test, white noise)")
        to = a + score["step"]
        if 0.0 < to < 1.0:      # a step past the exponent's range says nothing of where it would go
            line += f", one linearized step towards alpha ≈ {to:.2g}"
    return line


def _delta_tilde_lines(title: str, names: list[str], dt: np.ndarray, w: int) -> list[str]:
    lines = [title, " " * w + "".join(f"{k:>12}" for k in names)]
    for r, name in enumerate(names):
        cells = [f"{100 * dt[r, c]:>10.3f} %" if r == c else f"{dt[r, c]:>12.4f}"
                 for c in range(len(names))]
        lines.append(f"{name:<{w}}" + "".join(cells))
    return lines


def _discrepancy_lines(d: dict[str, Any], white_sd: dict[str, float]) -> list[str]:
    h = d["hyperparameters"]
    unit = d.get("axis_unit", "s")
    amp = "0 (no model error detected)" if d.get("amplitude_is_zero") else f"{fmt(h['amplitude'], 3)} MPa"
    proj = d.get("projection") or {}
    target = d.get("target", "generalized")
    metric = (f"the estimate and the sampler in the {d['kernel']} kernel's metric (target {target})"
              if target == "generalized" else
              f"the estimate the L2 projection (target {target}), the sampler with the {d['kernel']} kernel")
    lines = [f"discrepancy on the {d['axis']} axis: {metric}; its maximum likelihood: sigma0 = "
             f"{fmt(h['sigma0'], 3)} MPa (noise floor {fmt(proj.get('sigma0_floor'), 3)}), amplitude "
             f"{amp}, length {fmt(h['length'], 3)} {unit}"]
    ratios = {k: s / white_sd[k] for k, s in (d.get("sd") or {}).items()
              if white_sd.get(k) and math.isfinite(s / white_sd[k])}
    if d.get("evidence") and ratios:
        lines.append("  the estimate: " + str(proj.get("estimate", "")).split(" (")[0]
                     + "; its sd under the kernels' model of the error, against the white one: "
                     + ", ".join(f"{k} {v:.2f}x" for k, v in ratios.items()))
    lines.append(f"  whitened residuals: {d['whitened_residuals']['verdict']}")
    choice = d.get("kernel_choice")
    if choice and len(choice.get("weights") or {}) > 1:
        lines.append(f"  kernel auto: {choice['reason']}")
    return lines


# ---------------------------------------------------------------- the fit itself (no files)

def _window_info(cfg: Config, test, problem: LsqProblem) -> dict[str, Any]:
    end = problem.mask.size
    t = np.asarray(test.time)[:end][problem.mask]
    e = np.asarray(test.strain)[:end][problem.mask]
    return {"bounds": cfg.data.window.model_dump(mode="json", exclude_none=True),
            "time": [float(t[0]), float(t[-1])], "strain": [float(e.min()), float(e.max())],
            "n_points": int(t.size), "first_index": int(np.flatnonzero(problem.mask)[0]),
            "model_end": int(end)}


def _same(b: np.ndarray, ref: np.ndarray, sd: np.ndarray) -> bool:
    tol = np.maximum(SAME_OPTIMUM_SD * np.nan_to_num(sd, nan=0.0, posinf=0.0),
                     SAME_OPTIMUM_REL * np.abs(ref))
    return bool(np.all(np.abs(b - ref) <= tol))


def fit_test(cfg: Config, test) -> FitResult:
    """The fit of ``test`` (a ``bayes_dnlr.data.TestData``) as configured by ``cfg``; writes nothing."""
    t_start = _time.perf_counter()
    names = cfg.free_parameters
    specs = cfg.parameters
    problem = LsqProblem.for_config(cfg, test)
    if problem.n_points <= len(names):
        raise BayesDnlrError(f"the window holds {problem.n_points} samples for {len(names)} free "
                             "parameters: widen data.window")
    method = cfg.fit.method
    max_it = cfg.fit.max_iterations

    # physics-based start (paper 4.1)
    end = problem.mask.size
    guess, notes = physics_start(test.time[:end], test.strain_input[:end], test.stress[:end],
                                 problem.model.relaxation_start if problem.model.has_relaxation else None,
                                 test.strain_rate, cfg.model.modes, cfg.model.decades)
    beta0 = np.empty(len(names))
    for k, (value, why) in SPECTRUM_START.items():
        if k in names:
            guess[k], notes[k] = value, why
    for j, k in enumerate(names):
        if k in guess and math.isfinite(guess[k]):
            beta0[j] = clip_to(specs[k], guess[k])
        else:
            beta0[j] = fallback(specs[k], k)
            notes[k] = "centre of the prior box (no physics guess)"
    start = dict(zip(names, (float(b) for b in beta0), strict=True))
    best = optimize.run_minimiser(problem, method, beta0, max_it)
    main = best

    # multi-start over the prior box
    n_ms = cfg.fit.multistart
    ms_runs: list[tuple[np.ndarray, optimize.Optimum]] = []
    if n_ms:
        tm = problem.model.time
        span = (float(np.median(np.diff(tm))), float(tm[-1] - tm[0]))
        for s in spread_starts(specs, names, n_ms, seed=0, time_span=span):
            ms_runs.append((s, optimize.run_minimiser(problem, method, s, max_it)))
        # a meaningfully lower criterion (not rounding) replaces the physics-start optimum
        margin = 1e-9 * best.criterion + 1e-20 * float(problem.y @ problem.y)
        cands = [o for _, o in ms_runs if o.converged and o.criterion < best.criterion - margin]
        if cands:
            best = min(cands, key=lambda o: o.criterion)

    params = problem.params(best.beta)
    residuals = problem.raw_residuals(params)
    fitted = problem.y - residuals
    sigma0, source = resolve_sigma0(cfg, test, residuals)
    X = problem.jacobian(params)
    values = problem.vector(params)
    zero = [k for k, c in zip(names, np.linalg.norm(X, axis=0), strict=True) if c == 0]
    if zero:
        raise BayesDnlrError(f"parameter(s) {zero} have no effect on the model over the window: fix "
                             f"them ({'; '.join(fixing(k, params[k]) for k in zero)}: any value "
                             "does the same here) or widen data.window")
    bounds = {k: specs[k].bounds() for k in names}
    on_bound = {k: side for k, v in zip(names, values, strict=True)
                if (side := bound_side(float(v), *bounds[k])) is not None}
    held: list[str] = []
    try:
        sa = analyse(X, names, values, sigma0)
    except np.linalg.LinAlgError:
        sa = None
        if on_bound:     # parameters on a bound: the analysis of the others, those held there
            held = list(on_bound)
            with contextlib.suppress(np.linalg.LinAlgError):
                sa = analyse_holding(X, names, values, sigma0, held)
        if sa is None:
            raise BayesDnlrError(singular_message(X, names, values, on_bound, bounds)) from None

    reference = {k: _top_of_prior(specs[k], params[k], sa.sd[j]) for j, k in enumerate(names)
                 if k in HOLD_AT}
    width = {k: specs[k].bounds()[1] - specs[k].bounds()[0] for k in reference}
    if cfg.fit.hold_unidentified and (hold := unidentified(sa, reference, width)):
        return _refit_holding(cfg, test, hold, params, reference,
                              {k: float(sa.sd[names.index(k)]) for k in hold}, t_start)
    warnings: list[str] = []
    if not main.converged:
        warnings.append(f"the fit from the physics start did not converge ({main.message}); "
                        f"raise fit.max_iterations (now {max_it})")
    if best is not main:
        warnings.append("a multi-start found a lower criterion than the physics start "
                        f"(SSR {best.criterion:.6g} < {main.criterion:.6g}): the estimate is that optimum")
    multistart = _multistart_summary(ms_runs, best, names, sa.sd, main)
    if n_ms and not multistart["same_optimum"]:
        warnings.append(f"multi-start of the white least squares: {multistart['converged']}/{n_ms} "
                        "converged, and not all to the same optimum: the criterion has several minima or "
                        "flat directions in the prior box")
    warnings += [bound_warning(k, float(params[k]), *bounds[k], side, k in held)
                 for k, side in on_bound.items()]
    warnings.extend(identifiability_warnings(sa, held=held))
    warnings.extend(plausibility_warnings(params))
    diag = residual_diagnostics(residuals, sigma0, source)
    disc = None
    if cfg.noise.has_discrepancy:
        disc = discrepancy_analysis(cfg, test, problem, best.beta, residuals)
        warnings.extend(disc.pop("warnings"))
    if not diag["white"]:
        warnings.append("residuals are not white (model bias, see the residuals' diagnosis): the white-noise "
                        "sd "
                        "are a lower bound" + ("; the discrepancy analysis accounts for the bias"
                                               if disc is not None else
                                               "; noise.discrepancy (on by default) accounts for it"))

    rate = float(test.strain_rate)
    tau = params.get("tau_max")
    spectrum = _spectrum_dependence(problem, params, names, X, values, residuals, sigma0)
    return FitResult(
        name=cfg.name, names=names, estimate=params,
        sd=dict(zip(names, (float(x) for x in sa.sd), strict=True)),
        covariance=sa.covariance, correlation=sa.correlation, delta_tilde=sa.delta_tilde,
        err=dict(zip(names, (float(x) for x in sa.err), strict=True)),
        sigma0=float(sigma0), sigma0_source=source, n_points=problem.n_points,
        residuals=residuals, fitted=fitted,
        time=np.asarray(test.time)[:end][problem.mask], strain=np.asarray(test.strain)[:end][problem.mask],
        diagnostics=diag, method=method, iterations=main.iterations if best is main else best.iterations,
        evaluations=problem.evaluations, criterion=float(best.criterion), converged=bool(best.converged),
        message=best.message, multistart=multistart, condition_number=sa.condition_number,
        normalised_sensitivity_max=dict(zip(names, (float(x) for x in sa.max_normalised), strict=True)),
        warnings=warnings, deborah_max=float(tau * rate) if tau is not None else None,
        strain_rate=rate, relaxation_start=test.relaxation_start, window=_window_info(cfg, test, problem),
        start=start, start_notes=notes, fixed=dict(cfg.fixed_values),
        wall_time_s=_time.perf_counter() - t_start, data_notes=list(test.notes), discrepancy=disc,
        spectrum_exponent=spectrum,
        stress_score=stress_score(cfg, test, params, X, residuals, sigma0, problem.mask)
        if "E" in names else None)


def _top_of_prior(spec, estimate: float, sd: float) -> float:
    """The largest value a parameter's prior allows: its upper bound, else its estimate + 3 sd."""
    high = spec.bounds()[1]
    if math.isfinite(high):
        return float(high)
    return float(abs(estimate) + 3 * sd) if math.isfinite(sd) else math.nan


def _refit_holding(cfg: Config, test, hold: Mapping[str, float], free: Mapping[str, float],
                   reference: Mapping[str, float], sd: Mapping[str, float],
                   t_start: float) -> FitResult:
    """The fit again with the parameters of ``hold`` (name -> its normalised sensitivity) held at
    their ``HOLD_AT`` values; its ``identifiability`` block says what was held, why, and where the
    fit with them free had put them and E."""
    again = fit_test(cfg.with_holds({k: HOLD_AT[k] for k in hold}), test)
    held = {k: {"value": HOLD_AT[k], "sensitivity": float(s), "reference": float(reference[k]),
                "sd": sd[k],
                "threshold": NEGLIGIBLE_SENSITIVITY,
                "free_estimate": float(free[k]), "E_free": float(free["E"]) if "E" in free else None}
            for k, s in hold.items()}
    again.identifiability = {"held": held, "words": hold_words(held)}
    again.warnings.insert(0, hold_words(held))
    again.wall_time_s = _time.perf_counter() - t_start
    return again


def _spectrum_dependence(problem: LsqProblem, params: Mapping[str, float], names: list[str],
                         X: np.ndarray, values: np.ndarray, residuals: np.ndarray,
                         sigma0: float) -> dict[str, Any] | None:
    """``alpha_dependence`` at the white estimate (None when E is not free) and, with alpha
    fixed, the score test of its value (``alpha_score``)."""
    if "E" not in names:
        return None
    other = [j for j, k in enumerate(names) if k != "alpha"]
    alpha = params.get("alpha", UNIVERSAL_EXPONENT)
    x_alpha = problem.column(params, "alpha")
    out = alpha_dependence(X[:, other], [names[j] for j in other], values[other], x_alpha,
                           alpha, "alpha" in names)
    if "alpha" not in names:
        out["score"] = score_test(X, x_alpha, residuals, sigma0)
    return out


def stochastic_analysis(cfg: Config, test, params: Mapping[str, float],
                        sigma0: float) -> StochasticAnalysis:
    """X (eq. 22), X̃ (eq. 37), Δ, Err, ρ, Δ̃ (eq. 32-35) of the free parameters at ``params``, on the
    window of ``test``, for a given sigma0: the paper's a-priori analysis (Table 2, Fig. 11-12).

    ``params`` holds at least the free parameters; fixed ones come from the config. The rows of X are
    the window samples (``test.time[test.window]``).
    """
    names = cfg.free_parameters
    problem = LsqProblem.for_config(cfg, test)
    full = problem.params([params[k] for k in names])
    return analyse(problem.jacobian(full), names, problem.vector(full), sigma0)


def _multistart_summary(runs: list[tuple[np.ndarray, optimize.Optimum]], best: optimize.Optimum,
                        names: list[str], sd: np.ndarray, main: optimize.Optimum) -> dict[str, Any]:
    """starts, converged, same_optimum, and the spread of the end points per parameter."""
    physics = {"end": dict(zip(names, map(float, main.beta), strict=True)), "criterion": main.criterion,
               "iterations": main.iterations, "converged": main.converged,
               "same_optimum": bool(main.converged and _same(main.beta, best.beta, sd))}
    if not runs:
        return {"starts": 0, "converged": 0, "same_optimum": None, "spread": {}, "runs": [],
                "physics_start": physics}
    ends = np.array([o.beta for _, o in runs])
    conv = [o.converged for _, o in runs]
    same = [o.converged and _same(o.beta, best.beta, sd) for _, o in runs]
    spread = {}
    for j, k in enumerate(names):
        lo, hi = float(ends[:, j].min()), float(ends[:, j].max())
        spread[k] = {"min": lo, "max": hi,
                     "range_in_sd": (hi - lo) / sd[j] if sd[j] > 0 else (0.0 if hi == lo else math.inf)}
    return {
        "starts": len(runs), "converged": int(sum(conv)),
        "same_optimum": bool(all(same) and physics["same_optimum"]),
        "spread": spread,
        "runs": [{"start": dict(zip(names, map(float, s), strict=True)),
                  "end": dict(zip(names, map(float, o.beta), strict=True)),
                  "criterion": o.criterion, "iterations": o.iterations, "converged": o.converged,
                  "same_optimum": sm} for (s, o), sm in zip(runs, same, strict=True)],
        "physics_start": physics,
    }
