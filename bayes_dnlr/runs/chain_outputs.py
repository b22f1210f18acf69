"""A sampled chain's outputs: posterior.nc and summary.json from the stored chain (the draws after
burn-in, adjusted where the likelihood asks it; the statistics, the checks and their verdict, E(t),
the agreement of the tests), for ``sample`` (runs/sample.py) and for a finished chain whose outputs
are rebuilt."""

from __future__ import annotations

import json
import sys
from typing import Any

import numpy as np

from bayes_dnlr.config import Config
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.inference.mcmc.ensemble import MOVES
from bayes_dnlr.inference.mcmc.stopping import Convergence, convergence, shortfall
from bayes_dnlr.runs import identity
from bayes_dnlr.runs.chains import StoredRun
from bayes_dnlr.runs.checks import run_checks
from bayes_dnlr.runs.folder import jsonable
from bayes_dnlr.runs.netcdf import PosteriorDraws
from bayes_dnlr.runs.noise_summary import noise_summary, residual_warnings, verdict
from bayes_dnlr.runs.outputs import Posterior, gauss_newton_block, summarize, write_outputs
from bayes_dnlr.runs.records import FitRecord
from bayes_dnlr.runs.reference_posterior import summary_references
from bayes_dnlr.runs.target import build_target


def _standards(test) -> dict[str, float | None] | None:
    try:
        from bayes_dnlr.standards import standard_moduli
    except ImportError:
        return None
    try:
        return standard_moduli(test)
    except Exception as err:  # noqa: BLE001 - a failed standard modulus must not lose a posterior
        print(f"note: standard moduli not computed ({err})", file=sys.stderr)
        return None


def stopping_settings(cfg: Config) -> dict[str, Any]:
    """The settings a finished chain's outputs depend on beyond the chain itself: the stopping rule,
    the times of E(t) and the references (summary.json ``settings``; outputs made with others are
    rebuilt)."""
    s = cfg.sampler
    out = {"burn_in_tau": s.burn_in_tau, "min_tau_multiple": s.min_tau_multiple,
           "target_ess": s.target_ess, "max_steps": s.max_steps,
           "modulus_at": cfg.output.modulus_at}
    if cfg.reference_moduli:      # the references to check: summary.json's predictions and verdict
        out["reference_moduli"] = [r.model_dump(mode="json", exclude_none=True)
                                   for r in cfg.reference_moduli]
    return out


def json_attr(v: Any) -> Any:
    """A chain attribute written as JSON (older chains hold plain strings)."""
    try:
        return json.loads(v)
    except (TypeError, ValueError):
        return v


def chain_layout(run: StoredRun, cfg: Config, plain: bool) -> Layout:
    """The run's layout of a stored chain (a run with several tests stores each test's names)."""
    local = {cfg.test_names[0]: run.names} if plain else json.loads(run.attrs.get("layout", "{}"))
    return Layout.build(local, cfg.per_test_parameters, plain)


def _sigma0_used(run: StoredRun, draws: np.ndarray, layout: Layout) -> dict[str, float]:
    """σ0 (MPa) of each test's likelihood: the fixed value, or the posterior mean when sampled."""
    names = run.names
    stored = layout.expand(json_attr(run.attrs.get("sigma0")))

    def value(name: str, fixed: Any) -> float:
        if name in names:
            return float(draws[:, :, names.index(name)].mean())
        return float("nan") if fixed is None else float(fixed)

    return {t: value(layout.name("sigma0", t), stored.get(t)) for t in layout.tests}


def _threads_in_use() -> int:
    from bayes_dnlr.model.threads import get_threads

    return get_threads()


def package_version() -> str:
    from bayes_dnlr import __version__

    return __version__


def _projection_offsets(cfg: Config, test, fit: dict[str, Any], run: StoredRun,
                        draws: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
    """The chain holds θ* (the projection) and the hyperparameters: each draw of θ becomes
    θ* - c, c the projection offset of the discrepancy (inference/discrepancy/orthogonal.py ``offset_draws``),
    with a seed of its own so that the outputs are reproducible."""
    from bayes_dnlr.inference.discrepancy.gls import columns_for
    from bayes_dnlr.inference.discrepancy.hyper import discrepancy_priors
    from bayes_dnlr.inference.discrepancy.orthogonal import offset_draws

    disc = fit["discrepancy"]
    cols, axis = columns_for(cfg, test, disc["estimate"])
    stored = json_attr(run.attrs.get("discrepancy_priors"))
    priors = discrepancy_priors({"discrepancy": {"priors": stored}}) if stored else discrepancy_priors(fit)
    fixed = {k.removeprefix("disc_"): float(v.value) for k, v in (priors or {}).items() if v.fixed}
    kernel = json_attr(run.attrs.get("discrepancy_kernel")) or disc.get("kernel")
    bounds = {k: cfg.parameters[k].bounds() for k in cols.names}
    flat = draws.reshape(-1, draws.shape[-1])
    new, info = offset_draws(flat, list(run.names), disc["projection"], kernel, cols, axis.values,
                             axis.origin, fixed, bounds, int(cfg.sampler.seed) + 7919)
    return new.reshape(draws.shape), info


def _sandwich_adjustment(cfg: Config, fit: dict[str, Any], run: StoredRun,
                         draws: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
    """The chain is the exp posterior; its draws of θ take the covariance of the generalized
    estimate under the kernels' model of the error (inference/discrepancy/orthogonal.py ``adjust_draws``)."""
    from bayes_dnlr.inference.discrepancy.orthogonal import adjust_draws

    proj = fit["discrepancy"]["projection"]
    names = list(proj["u_names"])
    bounds = {k: cfg.parameters[k].bounds() for k in names}
    flat = draws.reshape(-1, draws.shape[-1])
    new, info = adjust_draws(flat, list(run.names), names, np.asarray(proj["log"], dtype=bool),
                             np.asarray(proj["sampled_covariance_u"], dtype=float),
                             np.asarray(proj["covariance_u"], dtype=float), bounds)
    info["kernel_weights"] = {k: v["weight"] for k, v in proj["kernels"].items()}
    return new.reshape(draws.shape), info


def _spectrum_block(cfg: Config, fit: dict[str, Any], names: list[str],
                    draws: np.ndarray) -> dict[str, Any] | None:
    """The fit's ``spectrum_exponent`` block (how E depends on alpha, eq. 12) and, with alpha sampled,
    what the data said about alpha: its prior and posterior mean and sd, the shift of the mean in
    prior sd and the ratio of the sds (1: the data do not tell alpha), the posterior correlation
    of E and alpha and the slope of E on alpha over the draws."""
    block = fit.get("spectrum_exponent")
    if block is None:
        return None
    block = dict(block)
    if "E" in names and "alpha" in names:
        from bayes_dnlr.inference.posterior.priors import Prior

        e = draws[:, :, names.index("E")].ravel()
        a = draws[:, :, names.index("alpha")].ravel()
        prior = Prior.from_spec("alpha", cfg.parameters["alpha"]).sample(
            np.random.default_rng(0), 20000)
        p_mean, p_sd = float(np.mean(prior)), float(np.std(prior, ddof=1))
        a_mean, a_sd = float(np.mean(a)), float(np.std(a, ddof=1))
        block |= {"prior": {"mean": p_mean, "sd": p_sd}, "posterior": {"mean": a_mean, "sd": a_sd},
                  "shift_in_prior_sd": (a_mean - p_mean) / p_sd, "sd_ratio": a_sd / p_sd,
                  "posterior_correlation_E_alpha": float(np.corrcoef(e, a)[0, 1]),
                  "posterior_slope_E_alpha": float(np.cov(e, a)[0, 1] / np.var(a, ddof=1))}
    return block


def _deborah_posterior(draws: np.ndarray, names: list[str], tau: str, rate: float
                       ) -> dict[str, float] | None:
    """De_max = tau_max · ε̇ (eq. 45) over the posterior draws: its mean and sd (the report's),
    beside ``deborah_max``, the fit's (white least squares); None with tau_max fixed."""
    if tau not in names or not rate > 0:
        return None
    d = draws[..., names.index(tau)].ravel() * rate
    return {"mean": float(np.mean(d)), "sd": float(np.std(d))}


def write_result(cfg: Config, run: StoredRun, fit: dict[str, Any], conv: Convergence | None,
                  reason: str | None, fp: str, test, sigma0_source: str, *, wall_time: float,
                  store_time: float, evals: int, check_time: float | None = None,
                  record: dict[str, Any] | None = None) -> Posterior:
    """posterior.nc and summary.json from the stored chain. ``wall_time``: the sampling loops
    (all sessions), ``store_time`` the checkpoint writes inside them, ``check_time`` the checks of
    the stopping rule in the last session (None: not measured)."""
    sc = cfg.sampler
    names = run.names
    if conv is None:
        conv = convergence(run.chain, sc.burn_in_tau, sc.min_tau_multiple, sc.target_ess)
    burn = conv.burn_in
    draws = run.chain[burn:]
    lp = run.log_prob[burn:]
    layout = chain_layout(run, cfg, test.plain)
    offsets = None
    target = json_attr(run.attrs.get("discrepancy_projection")) if layout.plain else None
    if target and fit.get("discrepancy"):
        view = test.tests[layout.tests[0]]
        draws, offsets = (_projection_offsets(cfg, view, fit, run, draws) if target == "l2"
                          else _sandwich_adjustment(cfg, fit, run, draws))
    sigma0 = _sigma0_used(run, draws, layout)
    singles = fit.get("single_fits") or {}
    sampling = max(wall_time - store_time, 1e-12)
    acc = float(run.accepted[burn:].mean()) if run.accepted.size else float("nan")
    warnings = []
    if reason != "converged":
        warnings.append(f"not converged: stopped at max_steps = {sc.max_steps}: "
                        f"{shortfall(conv, names, sc.target_ess, sc.min_tau_multiple)} "
                        f"(about {conv.needed_steps} steps needed)")
    extra = {
        "sigma0": layout.collapse(sigma0), "n_points": int(test.n_points), "steps": int(run.steps),
        "wall_time_s": wall_time,
        "standards": layout.collapse({t: _standards(d) for t, d in test.tests.items()}),
        "deborah_max": layout.collapse({t: (fit if layout.plain else singles.get(t) or {}).get("deborah_max")
                                        for t in layout.tests}),
        "deborah_max_posterior": layout.collapse(
            {t: _deborah_posterior(draws, names, layout.name("tau_max", t), test.tests[t].strain_rate)
             for t in layout.tests}),
        "name": cfg.name, "stop_reason": reason, "converged": reason == "converged",
        "burn_in": int(burn), "target_ess": sc.target_ess,
        "moves": run.attrs.get("moves_detail") or MOVES.get(sc.moves, sc.moves),
        "seed": sc.seed, "threads": _threads_in_use(), "acceptance_fraction": acc,
        "sigma0_source": sigma0_source,
        "storage_time_s": store_time, "storage_overhead": store_time / sampling,
        "log_prob_evals": int(evals), "log_prob_evals_per_s": evals / sampling,
        "check_time_s": check_time,
        "settings": stopping_settings(cfg), "fingerprint": fp, "data_sha256": test.sha256,
        "identity": record if record is not None else identity.data_record(cfg, test, None),
        "version": package_version(),
    }
    attrs = {"burn_in": int(burn), "stop_reason": reason, "walkers": int(run.chain.shape[1]),
             "steps": int(run.steps), "moves": sc.moves, "seed": sc.seed, "run": cfg.name,
             "sampling_coordinates": json.dumps({k: ("log" if ls else "spectral" if
                                                     k.split("[", 1)[0] == "alpha" else "linear")
                                                 for k, ls in zip(names, run.attrs.get("log_space", []),
                                                                  strict=False)})}
    dt = PosteriorDraws(names, draws, lp, attrs)     # posterior.nc without importing xarray
    summary = summarize(names, draws, fit=fit, tau=conv.tau, extra=extra)
    summary["noise"] = jsonable(noise_summary(cfg, fit, summary, layout, sigma0,
                                              layout.expand(sigma0_source)))
    if offsets is not None:
        summary["noise"]["projection"] = jsonable(offsets)
        summary["noise"]["verdict"] = verdict(summary["noise"])
    priors = build_target(cfg, test, FitRecord.from_dict(fit, cfg.test_names), run).priors
    references, reference_curve = summary_references(cfg, names, draws, layout.plain, fit)
    if references is not None:
        summary["reference_moduli"] = jsonable(references)
    if reference_curve is not None:
        summary["reference_curve"] = jsonable(reference_curve)
    checks, modulus, curve = run_checks(cfg, test, layout, draws, names, priors, fit, summary, sigma0)
    summary["checks"] = jsonable(checks)
    summary["modulus_at"] = jsonable(modulus)
    if curve:
        summary["modulus_curve"] = jsonable(curve)
    if summary["noise"]["model"] == "discrepancy" and fit.get("discrepancy"):
        summary["generalized_least_squares"] = gauss_newton_block(
            {"parameters": fit.get("parameters"), **fit["discrepancy"]})
    if fit.get("identifiability"):
        summary["identifiability"] = jsonable(fit["identifiability"])
    if not layout.plain:
        from bayes_dnlr.runs.consistency import consistency

        agree = consistency(cfg, test, fit)
        if agree is not None:
            summary["consistency"] = jsonable(agree)
    spectrum = _spectrum_block(cfg, fit, names, draws)
    if spectrum is not None:
        summary["spectrum_exponent"] = jsonable(spectrum)
    summary["warnings"] = warnings + [
        f"R-hat of {k} is {summary['posterior'][k]['r_hat']:.4f} > 1.01"
        for k in names if (summary["posterior"][k]["r_hat"] or 0) > 1.01] + residual_warnings(fit)
    if summary["noise"]["model"] == "white" and summary["noise"].get("fit_residuals_white") is False:
        summary["warnings"].append(summary["noise"]["verdict"])
    write_outputs(cfg.run_dir, dt, summary)
    return Posterior(cfg.run_dir, summary)          # its DataTree is read from posterior.nc on use
