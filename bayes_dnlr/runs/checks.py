"""The checks of a sampled run, and the verdict they decide: the ``checks`` block of summary.json
(docs/sampling.md, "Checks and verdict").

- ``predictive_coverage``: the share of the data inside the 90 % posterior predictive band, overall
  and per segment, for each test (inference/checks/predictive.py);
- ``bound_limited``: the parameters whose posterior piles against a prior bound, each with the move
  of E when that bound is widened ×10 (a second least-squares fit with the widened bound, the same
  analysis as the run's: generalized under model error);
- ``prior_sensitivity``: the power-scaling sensitivity of each sampled parameter to the prior
  (inference/checks/power_scaling.py); ``prior_sources``: for an E it flags, its sensitivity to
  each prior that is not flat, scaled alone (whose prior shapes E: its own, or alpha's);
- ``plausibility``: σ∞ against a falling hold, the time constants against the test's duration, E
  against the standards' chord (inference/checks/physical.py);
- ``model_form``: the score test of the spectrum's exponent held at ½ (eq. 12; fit.json
  ``discrepancy.alpha_score`` under model error, else ``spectrum_exponent.score``): how far the data
  pull it, in sd, with E's shift per +0.1 of it. Most errors of the model's form that a change of
  the parameters absorbs (a strain toe, a second process, a peaked spectrum) pull it
  (docs/model-form.md);
- ``stress_shift``: a stress-blind test's score test of the Eyring shift (fit.json
  ``stress_score``) and, where it asks for it, E of the fit that admits it against the posterior's,
  in posterior sd (docs/theory.md, "E(t) beyond the linear range");
- ``noise_model``: a posterior of the white likelihood (``noise.discrepancy: none``) on residuals
  that are not white (fit.json ``residuals.white``): its interval ignores the model error;
- ``reference_moduli``: each reference held out (``use: check``) against the posterior's prediction
  at its time scale (runs/reference_moduli.py): one that disagrees withdraws trust in E's interval;
- ``adequate``: the model with its noise model describes the test (coverage and plausibility pass);
  ``trust_interval``: E's interval can be used as it is (adequate, and neither a bound nor the
  prior decides E); ``verdict``: the words, each sentence from one check, a failed one with what
  to do.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.data.conversions import haward_thackray_strain
from bayes_dnlr.inference.checks import bounds, physical, power_scaling, predictive
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.lsq.stress_score import STRESS_Z
from bayes_dnlr.inference.posterior.likelihood import window_rows
from bayes_dnlr.model.shift import log_stress_shift
from bayes_dnlr.runs.bands import Band, column, predictive_bands
from bayes_dnlr.runs.reference_moduli import reference_check
from bayes_dnlr.runs.testset import TestSet
from bayes_dnlr.runs.verdict import SCORE_Z, SHIFT_SD, prior_shaped_e, verdict
from bayes_dnlr.vocabulary import DISCREPANCY_PARAMETERS, PARAMETER_NAMES, base_name


def coverage_check(cfg: Config, tests: TestSet, layout: Layout, draws: np.ndarray, names: list[str],
                   noise: dict[str, dict], sigma0: dict[str, float], seed: int = 0,
                   bands: dict[str, Band] | None = None) -> dict[str, dict]:
    """Each test's predictive coverage, overall and per segment, and weighted by E's information."""
    if bands is None:
        bands = predictive_bands(cfg, tests, layout, draws, names, noise, sigma0, seed)
    out = {}
    for t, b in bands.items():
        out[t] = predictive.coverage(b.inside, predictive.segments(b.time, b.relaxation_start,
                                                                    turns=b.turns))
        if b.X is not None and "E" in b.free:
            out[t]["E_weighted"] = predictive.weighted_share(
                b.inside, predictive.weights(b.X, b.free.index("E")))
    return out


def _median_of(k: str, test: str, view: Config, layout: Layout, draws: np.ndarray,
               names: list[str]) -> float | None:
    d = column(draws, names, layout.name(k, test))
    return float(np.median(d)) if d is not None else view.fixed_values.get(k)


def _log_stress_shift(view: Config, data, rows, test: str, layout: Layout, draws: np.ndarray,
                      names: list[str]) -> np.ndarray | None:
    """ln a_σ at each compared sample of a test, at the posterior median of sigma_s and the data's
    stress as the law's driving stress takes it (the overstress against the relaxed state of the
    medians of G and sigma_inf). None without a stress shift."""
    s = view.model.shift
    sigma_s = _median_of("sigma_s", test, view, layout, draws, names)
    if s.stress == "none" or not sigma_s:
        return None
    stress = np.asarray(data.stress[: data.model_end], dtype=float)[rows]
    time = np.asarray(data.time[: data.model_end], dtype=float)[rows]
    if s.driving == "peak":
        stress = np.maximum.accumulate(np.abs(stress))
    elif s.driving == "overstress":
        strain = np.asarray(data.strain_input[: data.model_end], dtype=float)[rows]
        relaxed = (_median_of("G", test, view, layout, draws, names) or 0.0) * \
            haward_thackray_strain(strain)
        if data.relaxation_start is not None:
            relaxed = np.where(time > data.relaxation_start,
                               _median_of("sigma_inf", test, view, layout, draws, names) or 0.0,
                               relaxed)
        stress = stress - relaxed
    return log_stress_shift(stress, sigma_s)


def plausibility_check(cfg: Config, tests: TestSet, layout: Layout, draws: np.ndarray,
                       names: list[str], standards: dict[str, dict | None],
                       bands: dict[str, Band] | None = None) -> dict[str, dict]:
    """Each test's physical checks (only those that apply to it). A time constant is judged at the
    test's temperature (× a_T) against the test's duration, in reduced time under a stress shift
    (∫ dt / a_σ: the stress speeds the modes up where it flows); E against the chord, allowing for
    the chord's noise (the start check's, in ``bands``)."""
    out = {}
    for t in layout.tests:
        data, checks = tests.tests[t], {}
        rows = window_rows(data)
        time = np.asarray(data.time[: data.model_end], dtype=float)[rows]
        log_a = _log_stress_shift(cfg.for_test(t), data, rows, t, layout, draws, names)
        reduced = None if log_a is None else physical.reduced_duration(time, log_a)
        stress = np.asarray(data.stress[: data.model_end], dtype=float)[rows]
        s_inf = column(draws, names, layout.name("sigma_inf", t))
        if s_inf is not None and data.relaxation_start is not None:
            falling, last = physical.hold_still_falling(time, stress, data.relaxation_start)
            checks["sigma_inf"] = physical.sigma_inf_check(s_inf, last, falling)
        span = float(time[-1] - time[0])
        for k in ("tau_max", "tau_max_R"):
            d = column(draws, names, layout.name(k, t))
            if k == "tau_max_R" and data.relaxation_start is None:
                continue            # a shared tau_max_R is another test's hold's
            if d is not None and span > 0:
                checks[k] = physical.time_constant_check(
                    d * _shift_factor(cfg, t, data, draws, names, layout), span, reduced)
        e = column(draws, names, layout.name("E", t))
        chord = next((v for v in ((standards.get(t) or {}).get(s) for s in ("iso527_1", "astm_d638"))
                      if v), None)
        if e is not None and chord:
            # the chord's noise sd where the start check measured the same chord (bands.py)
            start = (bands or {}).get(t) and bands[t].start
            same = start is not None and math.isclose(start.data, float(chord), rel_tol=1e-9)
            checks["E_chord"] = physical.chord_check(e, float(chord), start.noise_sd if same else 0.0)
        out[t] = checks
    # a time constant the tests share is measured when one of them measures it
    for k in ("tau_max", "tau_max_R"):
        shared = [t for t in out if k in out[t] and layout.name(k, t) == k]
        if len(shared) > 1 and any(out[t][k]["ok"] for t in shared):
            for t in shared:
                if not out[t][k]["ok"]:
                    del out[t][k]
    return out


def _shift_factor(cfg: Config, test: str, data, draws: np.ndarray, names: list[str],
                  layout: Layout) -> np.ndarray | float:
    """a_T of each draw at the test's temperature: its time constants there are the reference
    state's times a_T (1 without a temperature law)."""
    from bayes_dnlr.runs.modulus_block import at_temperature

    at = at_temperature(cfg.for_test(test), data)
    if not at.shifted:
        return 1.0
    law = {k: (c if (c := column(draws, names, layout.name(k, test))) is not None
               else cfg.fixed_values.get(k)) for k in ("Ea", "C1", "C2")}
    return at.factor(law)


def _score_of(fit: dict[str, Any]) -> tuple[dict | None, str]:
    """The score test of alpha in one test's fit.json block, and under which likelihood."""
    disc = fit.get("discrepancy") or {}
    if disc.get("alpha_score") is not None:
        return disc["alpha_score"], "under the discrepancy"
    score = (fit.get("spectrum_exponent") or {}).get("score")
    return score, "white"


def _fit_per_test(fit: dict[str, Any], layout: Layout) -> dict[str, dict[str, Any]]:
    """Each test's own fit.json block: the fit itself for one test, its single fit in a joint run."""
    if layout.plain:
        return {t: fit for t in layout.tests}
    return {t: (fit.get("single_fits") or {}).get(t) or {} for t in layout.tests}


def model_form_check(fit: dict[str, Any], layout: Layout, post_sd: dict[str, float]) -> dict[str, dict]:
    """Each test's score test of the spectrum's exponent held at ½, with E's shift per +0.1 of it
    and the shift of E, in posterior sd, at the exponent the data prefer (one Gauss-Newton step);
    empty for a test whose fit holds none (alpha sampled, or E fixed). It fails when the data pull
    the exponent by more than SCORE_Z sd and that pull moves E by more than SHIFT_SD posterior sd."""
    per_test = _fit_per_test(fit, layout)
    out = {}
    for t, f in per_test.items():
        score, how = _score_of(f)
        if not score or not math.isfinite(float(score.get("z", math.nan))):
            continue
        block = f.get("spectrum_exponent") or {}
        rel = (block.get("relative_per_tenth") or {}).get("E")
        slope = (block.get("derivative") or {}).get("E")
        sd = post_sd.get(layout.name("E", t))
        z, step = float(score["z"]), score.get("step")
        shift = (float(step) * float(slope) / sd if None not in (step, slope, sd) and sd > 0
                 and math.isfinite(float(step)) else None)
        out[t] = {"z": z, "step": step, "likelihood": how, "E_relative_per_tenth": rel,
                  "E_shift_sd": shift,
                  "ok": abs(z) <= SCORE_Z or (shift is not None and abs(shift) <= SHIFT_SD)}
    return out


def stress_shift_check(fit: dict[str, Any], layout: Layout, posterior: dict[str, dict]
                       ) -> dict[str, dict]:
    """Each stress-blind test's score test of the Eyring shift (fit.json ``stress_score``, under
    the discrepancy when the fit has it) and, where it asks for the shift, E of the fit that admits
    it (``stress_refit``) against the posterior's E, in posterior sd. It fails when the score asks
    (one-sided 1 %, as for E(t)) and admitting the shift moves E by more than SHIFT_SD sd: the
    stress-blind model reads yield as relaxation and E, its extrapolation to t → 0, follows."""
    per_test = _fit_per_test(fit, layout)
    out = {}
    for t, f in per_test.items():
        score = ((f.get("discrepancy") or {}).get("stress_score") or f.get("stress_score"))
        if not score or not math.isfinite(float(score.get("z", math.nan))):
            continue
        z = float(score["z"])
        refit = ((f.get("stress_refit") or {}).get("estimate") or {})
        post = posterior.get(layout.name("E", t)) or {}
        shift = None
        if "E" in refit and post.get("sd"):
            shift = (float(refit["E"]) - float(post["mean"])) / float(post["sd"])
        out[t] = {"z": z, "sigma_s": refit.get("sigma_s"), "E_shifted": refit.get("E"),
                  "E_shift_sd": shift,
                  "ok": not z > STRESS_Z or shift is None or abs(shift) <= SHIFT_SD}
    return out


def noise_model_check(cfg: Config, noise: dict[str, dict]) -> dict[str, dict]:
    """Each test's likelihood against its residuals: the white likelihood chosen by the config
    (``noise.discrepancy: none``) on residuals that are not white is not ok. A white posterior that
    the discrepancy analysis chose (no evidence of model error) is ok: its likelihood-ratio test
    already weighed the residuals."""
    out = {}
    for t, block in noise.items():
        white_resid = (block or {}).get("fit_residuals_white")
        chosen_white = not cfg.for_test(t).noise.has_discrepancy
        out[t] = {"likelihood": (block or {}).get("model"), "residuals_white": white_resid,
                  "ok": not (chosen_white and white_resid is False)}
    return out


def _by_walker(draws: np.ndarray) -> np.ndarray:
    """(steps, walkers, ndim) draws as (walkers × steps, ndim), each walker's steps in a row: the
    order in which the draws' autocorrelation (the tail ESS of Pareto smoothing) is that of the
    chains, as arviz_stats.psense reads a (chain, draw) posterior."""
    return np.swapaxes(draws, 0, 1).reshape(-1, draws.shape[-1]) if draws.ndim == 3 else \
        draws.reshape(-1, draws.shape[-1])


def _log_prior_terms(flat: np.ndarray, priors) -> np.ndarray:
    """(draws, priors): each prior's log density at the draws ``flat`` (draws, ndim), in the
    parameters' own units: the prior as the config gives it (a log-uniform tau_max is 1/tau_max),
    never the sampler's coordinates, whose Jacobian is not the user's prior and whose round trip can
    put a draw on a bound one ulp outside it (a non-finite term then made every sensitivity 0)."""
    return np.column_stack([p.logpdf(flat[:, j]) for j, p in enumerate(priors.priors)])


def _scaled(per: dict[str, np.ndarray], component: np.ndarray) -> dict[str, float]:
    """Power-scaling sensitivity to ``component`` over the draws where it is finite (a draw outside a
    prior's support has no density to scale; the sampler keeps none, an adjusted draw may)."""
    ok = np.isfinite(component)
    if np.ptp(component[ok]) == 0:
        return dict.fromkeys(per, 0.0)        # a flat prior: power-scaling changes nothing
    return power_scaling.sensitivity({k: v[ok] for k, v in per.items()}, component[ok])


def prior_sensitivity_check(draws: np.ndarray, names: list[str], priors) -> dict[str, float]:
    """Power-scaling sensitivity of every sampled parameter to the run's prior (Kallioinen et al.
    2024: the prior p(θ) of the parameters as given, raised to a power)."""
    flat = _by_walker(draws)
    per = {k: flat[:, j] for j, k in enumerate(names)}
    return _scaled(per, _log_prior_terms(flat, priors).sum(axis=1))


def prior_sources(draws: np.ndarray, names: list[str], priors, flagged: list[str]
                  ) -> dict[str, dict[str, float]]:
    """Which priors shape the parameters in ``flagged``: the sensitivity of each to power-scaling one
    prior alone, for every prior that is not flat at the draws (a flat one changes nothing)."""
    if not flagged:
        return {}
    flat = _by_walker(draws)
    terms = _log_prior_terms(flat, priors)
    per = {k: flat[:, names.index(k)] for k in flagged}
    out: dict[str, dict[str, float]] = {k: {} for k in flagged}
    for j, p in enumerate(priors.priors):
        component = terms[:, j]
        ok = np.isfinite(component)
        if not ok.any() or np.ptp(component[ok]) == 0:
            continue
        for k, v in _scaled(per, component).items():
            out[k][p.name] = v
    return out


def bound_check(cfg: Config, tests: TestSet, draws: np.ndarray, names: list[str], priors,
                fit: dict[str, Any], uses_discrepancy: bool, post_sd: dict[str, float]) -> list[dict]:
    """The parameters piled against a prior bound, with the move of E when it is widened ×10."""
    out = []
    for p in priors.priors:
        k = base_name(p.name)
        if k not in PARAMETER_NAMES:
            if k in DISCREPANCY_PARAMETERS or k == "sigma0":
                side = bounds.piled_side(draws[..., names.index(p.name)], p.low, p.high, p.log_space)
                if side is not None:
                    out.append({"parameter": p.name, "side": side,
                                "bound": p.low if side == "low" else p.high, "widened": None,
                                "E_shift_sd": None, "note": "a noise hyperparameter of the fit's "
                                                            "resolved priors"})
            continue
        side = bounds.piled_side(draws[..., names.index(p.name)], p.low, p.high, p.log_space)
        if side is None:
            continue
        bound = p.low if side == "low" else p.high
        entry = {"parameter": p.name, "side": side, "bound": bound}
        if bounds.physical_limit(side, bound):
            entry.update(widened=None, E_shift_sd=None, note="a physical limit (not widened)")
        else:
            lo, hi = bounds.widened(p.low, p.high, side, p.log_space)
            entry["widened"] = [lo, hi]
            entry["identified"] = identified(fit, p.name, p.low, p.high, p.log_space, uses_discrepancy)
            refit = _refit_widened(cfg, tests, k, lo, hi, fit, uses_discrepancy)
            entry["E_shift_sd"] = _shift_of_e(refit, post_sd)
            if refit is not None:
                entry["estimates"] = {"before": refit[0], "after": refit[1]}
        out.append(entry)
    return out


def identified(fit: dict[str, Any], name: str, low: float, high: float, log_space: bool,
               uses_discrepancy: bool) -> bool:
    """Whether the window identifies a parameter, by the paper's analysis (fit.json): its
    normalised sensitivity is at least NEGLIGIBLE_SENSITIVITY of the largest (eq. 37, 4.2), and its
    linearized sd (eq. 32; the generalized one under model error) is narrower than its prior box,
    in the coordinates it is sampled in. Only for such a parameter does widening its bound help."""
    from bayes_dnlr.inference.lsq.sensitivity import NEGLIGIBLE_SENSITIVITY

    sens = fit.get("normalised_sensitivity_max") or {}
    if name in sens and sens and max(sens.values()) > 0:
        if sens[name] < NEGLIGIBLE_SENSITIVITY * max(sens.values()):
            return False
    src = (fit.get("discrepancy") or {}) if uses_discrepancy else {}
    sd = (src.get("sd") or fit.get("sd") or {}).get(name)
    est = (src.get("estimate") or fit.get("estimate") or {}).get(name)
    if sd is None or est is None or not math.isfinite(float(sd)):
        return not (sd is not None and not math.isfinite(float(sd)))
    if log_space:
        return est > 0 and float(sd) / float(est) <= math.log(high / low)
    return float(sd) <= high - low


def _refit_widened(cfg: Config, tests: TestSet, name: str, low: float, high: float,
                   fit: dict[str, Any], uses_discrepancy: bool
                   ) -> tuple[dict[str, float], dict[str, float]] | None:
    """The run's least-squares estimates (the analysis the run samples from: generalized under
    model error) before and after ``name``'s bound is widened to [low, high]."""
    from bayes_dnlr.errors import BayesDnlrError
    from bayes_dnlr.inference.lsq.run_fit import fit_run
    from bayes_dnlr.runs.records import FitRecord

    spec = cfg.parameters[name].model_copy(update={"low": low, "high": high})
    wide = cfg.model_copy(update={"parameters": {**cfg.parameters, name: spec}})
    try:
        again = FitRecord.from_dict(fit_run(wide, tests.tests, tests.plain).to_dict(), cfg.test_names)
    except BayesDnlrError:
        return None
    before = FitRecord.from_dict(fit, cfg.test_names).start_analysis(uses_discrepancy)
    after = again.start_analysis(uses_discrepancy)
    if before is None or after is None:
        return None
    return dict(before.estimate), dict(after.estimate)


def _shift_of_e(refit: tuple[dict[str, float], dict[str, float]] | None,
                post_sd: dict[str, float]) -> dict[str, float] | None:
    """How far E (each E of the run) moves, in posterior sd, when a bound is widened."""
    if refit is None:
        return None
    before, after = refit
    shifts = {}
    for k, sd in post_sd.items():
        if base_name(k) == "E" and k in before and k in after and sd > 0:
            shifts[k] = (after[k] - before[k]) / sd
    return shifts or None


def run_checks(cfg: Config, tests: TestSet, layout: Layout, draws: np.ndarray, names: list[str],
               priors, fit: dict[str, Any], summary: dict[str, Any],
               sigma0: dict[str, float]) -> tuple[dict[str, Any], list | dict, dict | None]:
    """The ``checks`` block of summary.json for a sampled run (``draws`` (steps, walkers, ndim) kept),
    its ``modulus_at`` (E(t) with its own trust, runs/modulus_block.py) and ``modulus_curve``."""
    from bayes_dnlr.runs.modulus_block import posterior_block

    noise = layout.expand(summary.get("noise")) if layout.plain else (summary.get("noise") or {}).get(
        "tests") or {}
    standards = layout.expand(summary.get("standards"))
    post_sd = {k: v["sd"] for k, v in (summary.get("posterior") or {}).items()}
    uses_disc = any((n or {}).get("model") == "discrepancy" for n in noise.values())
    bands = predictive_bands(cfg, tests, layout, draws, names, noise, sigma0)
    checks: dict[str, Any] = {
        "predictive_coverage": coverage_check(cfg, tests, layout, draws, names, noise, sigma0,
                                              bands=bands),
        "bound_limited": bound_check(cfg, tests, draws, names, priors, fit, uses_disc, post_sd),
        "prior_sensitivity": prior_sensitivity_check(draws, names, priors),
        "plausibility": plausibility_check(cfg, tests, layout, draws, names, standards, bands),
        "model_form": model_form_check(fit, layout, post_sd),
        "stress_shift": stress_shift_check(fit, layout, summary.get("posterior") or {}),
        "noise_model": noise_model_check(cfg, noise),
    }
    checks["prior_sources"] = prior_sources(draws, names, priors,
                                            list(prior_shaped_e(checks["prior_sensitivity"])))
    if fit.get("shift_law"):
        checks["shift_law"] = fit["shift_law"]
    references = reference_check(summary.get("reference_moduli"))
    if references is not None:
        checks["reference_moduli"] = references
    adequate, trust, head, points = verdict(checks, bool(summary.get("converged")), not layout.plain)
    log_prior = _log_prior(draws, priors)
    modulus, curve = posterior_block(cfg, tests, layout, draws, names, bands, checks, log_prior,
                                     bool(summary.get("converged")), fit)
    if not layout.plain:
        reference = _master_curve(cfg, tests, layout, draws, names, bands, checks, log_prior,
                                  bool(summary.get("converged")), fit)
        if reference is not None:
            modulus["reference"] = reference
    if layout.plain:
        for k in ("predictive_coverage", "plausibility", "noise_model"):
            checks[k] = layout.collapse(checks[k])
        checks["model_form"] = checks["model_form"].get(layout.tests[0])      # None: no score test
        checks["stress_shift"] = checks["stress_shift"].get(layout.tests[0])
    checks.update(adequate=adequate, trust_interval=trust, verdict=" ".join([head, *points]),
                  verdict_points=points)
    return checks, modulus, curve


def _master_curve(cfg: Config, tests: TestSet, layout: Layout, draws: np.ndarray, names: list[str],
                  bands: dict[str, Band], checks: dict[str, Any], log_prior: np.ndarray,
                  converged: bool, fit: dict[str, Any]) -> dict[str, Any] | None:
    """E(t) at the reference temperature of tests made at several (runs/master_curve.py)."""
    from bayes_dnlr.runs.master_curve import master_curve
    from bayes_dnlr.runs.modulus_block import posterior_refits, posterior_sources

    sources = posterior_sources(cfg, layout, draws, names, checks, log_prior, converged)
    singles = fit.get("single_fits") or {}
    refits = {t: posterior_refits(checks.get("bound_limited") or [], layout, t, cfg.for_test(t))
              for t in sources}
    noise_ok = {t: ((checks.get("noise_model") or {}).get(t) or {}).get("ok", True) for t in sources}
    return master_curve(cfg, tests, sources, bands, singles, refits, noise_ok, fit.get("shift_law"))


def _log_prior(draws: np.ndarray, priors) -> np.ndarray:
    """The log prior of every kept draw in the coordinates the sampler draws in (ln of a time
    constant), in the order of ``draws.reshape(-1, ndim)``, for E(t)'s own prior check: there a
    uniform or log-uniform prior is flat and says nothing, an informative one (a normal prior on
    alpha or E) is what power-scaling asks about. Non-finite where a draw sits a rounding error
    outside a bound (E(t)'s prior check leaves those out)."""
    flat = draws.reshape(-1, draws.shape[-1])
    z = priors.from_physical(flat)
    with np.errstate(all="ignore"):
        return np.column_stack([p.logpdf_sampling(z[:, j]) for j, p in enumerate(priors.priors)]
                               ).sum(axis=1)
