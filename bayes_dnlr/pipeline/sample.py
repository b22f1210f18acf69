"""``sample`` as a run: the posterior of a config, sampled into ``<run_dir>/chains.h5``, then
posterior.nc and summary.json (``python -m bayes_dnlr sample``).

1. Posterior: priors from the config, Gaussian likelihood with σ0 fixed (number, residuals,
   baseline: resolved once, from fit.json) or sampled (``sigma0`` with its prior); see
   inference/likelihood.py.
2. Start: the walkers are drawn from the least-squares estimate and its linearized covariance
   (fit.json, eq. 32; ``fit`` runs first when fit.json is missing or stale).
3. Sampling and stopping: inference/mcmc.py (``run_ensemble``).
4. Storage: chains.h5 (inference/store.py), appended every ``checkpoint_every`` steps; a re-run
   resumes from the last checkpoint and continues the same chain bit-exactly; a changed config or
   data file is refused (RunError) unless ``restart``; a finished, current run is not sampled again.
5. Outputs: posterior.nc, summary.json (inference/posterior.py).
"""

from __future__ import annotations

import json
import math
import sys
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.config import DISCREPANCY_PARAMETERS, Config, ConfigError, ParameterSpec, SampledNoise
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.discrepancy import AMPLITUDE, LENGTH, is_white
from bayes_dnlr.inference.likelihood import LogPosterior, build_log_posterior
from bayes_dnlr.inference.mcmc import (
    MIN_STEPS_FOR_TAU,
    MOVES,
    Convergence,
    StopRule,
    convergence,
    make_moves,
    run_ensemble,
    shortfall,
    start_ensemble,
    stop_reason,
)
from bayes_dnlr.inference.posterior import (
    POSTERIOR_FILE,
    SUMMARY_FILE,
    Posterior,
    build_datatree,
    gauss_newton_block,
    load_posterior,
    read_summary,
    summarize,
    write_outputs,
)
from bayes_dnlr.inference.priors import build_priors, sampled_names
from bayes_dnlr.inference.store import ChainWriter, SamplerState, StoredRun, read_attrs, read_run
from bayes_dnlr.pipeline.noise import noise_block, residual_warnings
from bayes_dnlr.rundir import digest, jsonable, prepare_run_dir, resolved_config_text, section_digests

CHAINS_FILE = "chains.h5"
LOCK_FILE = "sample.lock"
# config sections that change the posterior or the chain; max_steps, target_ess, checkpoint_every,
# burn_in_tau and min_tau_multiple only decide how long to sample and what to keep.
POSTERIOR_SECTIONS = ("data", "model", "parameters", "noise")
SAMPLER_KEYS = ("walkers", "seed", "moves")


# ---------------------------------------------------------------- configuration

def check_sampler(cfg: Config, names: list[str]) -> None:
    """Sampler settings that depend on the number of sampled parameters (before anything runs)."""
    where = str(cfg.source) if cfg.source is not None else "config"
    ndim = len(names)
    if cfg.sampler.walkers < 2 * ndim:
        raise ConfigError(
            f"{where}: sampler.walkers: {cfg.sampler.walkers} walkers for {ndim} sampled parameters "
            f"({', '.join(names)}); the ensemble moves need at least 2 × {ndim} = {2 * ndim} "
            f"(32 is a good choice)")


def fingerprint_parts(cfg: Config, data_sha256: str) -> dict[str, str]:
    """Digests of what the chain depends on: config sections, sampler walkers/seed/moves, data file."""
    parts = section_digests(cfg, POSTERIOR_SECTIONS)
    sampler = cfg.sampler.model_dump(mode="json")
    parts["sampler"] = digest({k: sampler[k] for k in SAMPLER_KEYS})
    parts["data file"] = data_sha256
    return parts


def stale_reason(attrs: dict[str, Any], parts: dict[str, str]) -> str | None:
    """Why a stored chain does not belong to this config and data (None when it does)."""
    try:
        old = json.loads(attrs.get("fingerprint_parts", "{}"))
    except (TypeError, json.JSONDecodeError):
        old = {}
    changed = [k for k, v in parts.items() if old.get(k) != v]
    if not changed:
        return None
    what = []
    sections = [("sampler." + "/".join(SAMPLER_KEYS) if k == "sampler" else k)
                for k in changed if k != "data file"]
    if sections:
        what.append(f"config section(s) {', '.join(sections)} changed")
    if "data file" in changed:
        what.append("the data file changed (sha256 differs)")
    return " and ".join(what)


def discrepancy_priors(fit: dict[str, Any]) -> dict[str, ParameterSpec] | None:
    """The resolved priors of the discrepancy hyperparameters that fit.json records (None when the
    fit had no discrepancy)."""
    block = fit.get("discrepancy")
    if not block:
        return None
    try:
        return {k: ParameterSpec.model_validate(v) for k, v in block["priors"].items()}
    except (KeyError, TypeError, ValueError) as err:
        raise RunError(f"fit.json: unreadable discrepancy priors ({err}); run `fit --force`") from None


def start_point(post: LogPosterior, fit: dict[str, Any],
                sigma0_start: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Where the walkers start: the least-squares estimate and its linearized covariance (eq. 32)
    from fit.json — the generalized (discrepancy) analysis when the likelihood has a discrepancy —,
    in the order of the sampled parameters (physical units). A sampled sigma0 starts at
    ``sigma0_start`` with the sd of a variance estimate from n points; the discrepancy
    hyperparameters at their maximum-likelihood values with the spread of the likelihood's
    curvature."""
    names = post.names
    disc = fit.get("discrepancy") if post.discrepancy is not None else None
    src = disc if disc else fit
    est = src.get("estimate") or {}
    fit_names = list(fit.get("parameters") or [])
    noise = ("sigma0", *DISCREPANCY_PARAMETERS)
    missing = [k for k in names if k not in noise and k not in est]
    if missing:
        raise RunError(f"fit.json has no estimate for {missing}: run `fit --force`")
    hyper = dict((disc or {}).get("hyperparameters") or {})
    rms = float((fit.get("residuals") or {}).get("rms") or 1.0)
    if disc and disc.get("amplitude_is_zero"):
        hyper["amplitude"] = 0.05 * rms          # on the bound: start just inside, spread as much
    start = {"sigma0": sigma0_start, AMPLITUDE: hyper.get("amplitude"), LENGTH: hyper.get("length")}
    x0 = np.array([start[k] if k in noise else est[k] for k in names], dtype=float)
    # strictly inside the support: exp(ln x) may overshoot a bound the estimate sits on by an ulp
    lo = np.array([p.low for p in post.priors.priors])
    hi = np.array([p.high for p in post.priors.priors])
    with np.errstate(invalid="ignore"):           # inf - inf on unbounded sides: left as they are
        x0 = np.clip(x0, np.where(np.isfinite(lo), lo + 1e-9 * np.abs(lo), lo),
                     np.where(np.isfinite(hi), hi - 1e-9 * np.abs(hi), hi))
    model_pos = [j for j, k in enumerate(names) if k not in noise]
    cov = np.zeros((len(names), len(names)))
    try:
        fcov = np.asarray(src.get("covariance"), dtype=float)
        idx = [fit_names.index(names[j]) for j in model_pos]
        cov[np.ix_(model_pos, model_pos)] = fcov[np.ix_(idx, idx)]
    except (TypeError, ValueError, IndexError):
        cov[np.ix_(model_pos, model_pos)] = np.nan
    fit_sigma = fit.get("sigma0")
    if not disc and post.sigma0 is not None and fit_sigma and fit_sigma > 0:
        cov *= (post.sigma0 / fit_sigma) ** 2     # the covariance scales with σ0²
    if "sigma0" in names:
        j = names.index("sigma0")
        cov[j, j] = sigma0_start ** 2 / (2.0 * post.n)
    if disc:
        free = list(disc.get("estimated") or [])
        log_cov = np.asarray(disc.get("hyper_log_covariance") or np.zeros((0, 0)), dtype=float)
        for k in (AMPLITUDE, LENGTH):
            if k not in names:
                continue
            j = names.index(k)
            var_log = log_cov[free.index(k), free.index(k)] if k in free and log_cov.size else 1.0
            if k == AMPLITUDE and disc.get("amplitude_is_zero"):
                var_log = 1.0
            cov[j, j] = min(var_log, 1.0) * x0[j] ** 2
    return x0, cov


# ---------------------------------------------------------------- helpers

def _resolve_sigma0(cfg: Config, fit: dict[str, Any], test) -> tuple[float | None, str, float | None]:
    """(σ0 for the likelihood or None when sampled, its source, a starting value when sampled).

    With a discrepancy, ``residuals`` means the white part of the residuals: the maximum-likelihood
    σ0 that fit.json's discrepancy analysis found beside the amplitude and length."""
    spec = cfg.noise.sigma0
    if isinstance(spec, int | float):
        return float(spec), "config", None
    disc = fit.get("discrepancy") if cfg.noise.has_discrepancy else None
    priors = discrepancy_priors(fit) if disc else None
    if priors is not None and is_white(priors):
        disc = None                          # no evidence of model error: the white likelihood
    ml_sigma = ((disc or {}).get("hyperparameters") or {}).get("sigma0")
    fit_sigma = ml_sigma if disc else fit.get("sigma0")
    if isinstance(spec, SampledNoise):
        start = float(fit_sigma) if fit_sigma else None
        if start is None:
            from bayes_dnlr.inference.noise import resolve_sigma0

            start = resolve_sigma0(cfg, test)[0]
        return None, "sampled", start
    if fit_sigma and math.isfinite(fit_sigma) and fit_sigma > 0:
        source = ("white part of the residuals (maximum likelihood with the discrepancy)"
                  if disc and spec == "residuals" else str(fit.get("sigma0_source") or spec))
        return float(fit_sigma), source, None
    from bayes_dnlr.inference.noise import resolve_sigma0

    value, source = resolve_sigma0(cfg, test)
    return float(value), source, None


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


def _settings(cfg: Config) -> dict[str, Any]:
    s = cfg.sampler
    return {"burn_in_tau": s.burn_in_tau, "min_tau_multiple": s.min_tau_multiple,
            "target_ess": s.target_ess, "max_steps": s.max_steps}


def _remove_outputs(run_dir: Path) -> None:
    for name in (CHAINS_FILE, POSTERIOR_FILE, SUMMARY_FILE):
        p = run_dir / name
        if p.exists():
            p.unlink()


# ---------------------------------------------------------------- sampling

def sample(cfg: Config, *, restart: bool = False, progress: bool = True) -> Posterior:
    """Sample the posterior of ``cfg`` to convergence (or max_steps); resumable. See the module doc."""
    names = sampled_names(cfg)
    check_sampler(cfg, names)
    build_priors(cfg)               # validate the model priors early
    make_moves(cfg.sampler.moves)

    from bayes_dnlr.data import load_test

    test = load_test(cfg)
    with _run_lock(cfg.run_dir):
        return _sample(cfg, test, names, restart=restart, progress=progress)


@contextmanager
def _run_lock(run_dir: Path):
    """One ``sample`` per run directory at a time (an advisory lock, released even on SIGKILL)."""
    import fcntl

    run_dir.mkdir(parents=True, exist_ok=True)
    f = open(run_dir / LOCK_FILE, "a+")  # noqa: SIM115 - held for the whole run
    try:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        f.close()
        raise RunError(f"{run_dir}: another `sample` is running on this run directory; wait for it "
                       "or stop it (its chain is kept and resumes)") from None
    try:
        yield
    finally:
        fcntl.flock(f, fcntl.LOCK_UN)
        f.close()


def _current_fit(cfg: Config, test, *, replace: bool, progress: bool) -> dict[str, Any]:
    """fit.json for this config and data, running the fit when it is missing. A fit.json made from
    another config or data is replaced only when ``replace`` (sample --restart): never silently."""
    from bayes_dnlr.pipeline.fit import fit as run_fit
    from bayes_dnlr.pipeline.fit import fit_is_current, load_fit

    if not fit_is_current(cfg, test.sha256):
        if progress:
            print("fit.json missing or stale: running the least-squares fit first", file=sys.stderr)
        try:
            run_fit(cfg, overwrite=replace, test=test)
        except RunError as err:
            raise RunError(f"{err}; or sample --restart, which also discards this run's chain") from None
    return load_fit(cfg.run_dir)


def _sample(cfg: Config, test, names: list[str], *, restart: bool, progress: bool) -> Posterior:
    run_dir = cfg.run_dir
    chains = run_dir / CHAINS_FILE
    parts = fingerprint_parts(cfg, test.sha256)
    fp = digest(parts)
    sc = cfg.sampler

    stored: StoredRun | None = None
    if chains.exists() and restart:
        _remove_outputs(run_dir)
    elif chains.exists():
        try:
            attrs = read_attrs(chains)
            reason = stale_reason(attrs, parts)
        except OSError as err:
            raise RunError(f"{chains}: cannot read the stored chain ({err}); sample --restart "
                           "(restart=True) discards it and starts again") from None
        if reason is not None:
            raise RunError(f"{chains} was sampled from another config or data: {reason}. Refusing to "
                           "mix chains; sample --restart (restart=True) discards it and starts again, "
                           "or set output.dir to sample into another run directory")
        try:
            stored = read_run(chains)
        except OSError as err:
            raise RunError(f"{chains}: no usable checkpoint ({err}); sample --restart discards it") from None
        done = _finished_result(cfg, test, stored, fp)
        if done is not None:
            return done

    fit = _current_fit(cfg, test, replace=restart, progress=progress)
    prepare_run_dir(cfg)
    sigma0, sigma0_source, sigma0_start = _resolve_sigma0(cfg, fit, test)
    # the resolved discrepancy priors belong to the chain: a resume keeps the chain's own
    disc_priors = discrepancy_priors(fit)
    if stored is not None and stored.attrs.get("discrepancy_priors"):
        disc_priors = discrepancy_priors({"discrepancy": {
            "priors": json.loads(stored.attrs["discrepancy_priors"])}})
    if cfg.noise.has_discrepancy and disc_priors is None:
        raise RunError(f"{cfg.run_dir / 'fit.json'} has no discrepancy analysis for this config "
                       "(made by another version?): run `fit --force`")
    names = sampled_names(cfg, disc_priors)
    check_sampler(cfg, names)
    priors = build_priors(cfg, disc_priors)
    if stored is not None and (stored.names != names or [bool(v) for v in stored.attrs.get(
            "log_space", [])] != [bool(v) for v in priors.log_space]):
        raise RunError(f"{chains} holds parameters {stored.names} sampled in other coordinates "
                       f"(made by bayes_dnlr {stored.attrs.get('version')}); it cannot be continued: "
                       "sample --restart discards it and starts again")
    post = build_log_posterior(cfg, test, sigma0, priors, disc_priors)

    walkers, ndim = sc.walkers, len(names)
    if stored is None:
        x0, cov = start_point(post, fit, sigma0_start)
        coords, lp = start_ensemble(post, priors, x0, cov, walkers, sc.seed)
        state0 = SamplerState(coords, lp, np.random.RandomState(sc.seed).get_state())
        meta = {
            "names": names, "log_space": [bool(v) for v in priors.log_space], "walkers": walkers,
            "ndim": ndim, "config": resolved_config_text(cfg), "fingerprint": fp,
            "fingerprint_parts": json.dumps(parts), "data_sha256": test.sha256,
            "data_file": str(test.path), "version": _version(), "modes": cfg.model.modes,
            "decades": cfg.model.decades, "moves": sc.moves, "seed": sc.seed,
            "sigma0": float("nan") if sigma0 is None else sigma0, "sigma0_source": sigma0_source,
            "created": datetime.now(UTC).isoformat(timespec="seconds"),
        }
        if disc_priors is not None:
            meta["discrepancy_priors"] = json.dumps(
                {k: v.model_dump(mode="json", exclude_none=True) for k, v in disc_priors.items()})
        writer = ChainWriter.create(chains, meta, walkers, ndim, state0, priors.to_physical,
                                    chunk_steps=sc.checkpoint_every, n_evals=0)
        chain0 = np.empty((0, walkers, ndim))
        elapsed0, evals0, state = 0.0, 0, state0
        fresh = True
    else:
        writer = ChainWriter.resume(chains, priors.to_physical)
        chain0 = stored.chain
        elapsed0, evals0, state = stored.elapsed, stored.n_evals, stored.state
        post(state.coords[:1])      # numba: load/compile outside the timed loop
        post.n_evals = 0
        fresh = False

    rule = StopRule(sc.burn_in_tau, sc.min_tau_multiple, sc.target_ess, sc.max_steps,
                    sc.checkpoint_every)
    try:
        out = run_ensemble(post, priors.to_physical, sc.moves, state, chain0, writer, rule,
                           fresh=fresh, elapsed0=elapsed0, evals0=evals0, progress=progress)
    except BaseException:
        steps = writer.steps
        writer.close()
        if progress:
            print(f"\nstopped at step {steps}; the chain is saved in {chains}: run `sample` again "
                  "to continue", file=sys.stderr)
        raise
    conv, reason = out.convergence, out.reason
    elapsed = elapsed0 + out.sampling_time
    store_time = writer.store_time
    writer.finish({"stop_reason": reason, "steps": int(out.chain.shape[0]),
                   "finished": datetime.now(UTC).isoformat(timespec="seconds")})
    run = read_run(chains)
    return _write_result(cfg, run, fit, conv, reason, fp, test, sigma0_source,
                         wall_time=elapsed, store_time=store_time, evals=evals0 + out.evals)


def _version() -> str:
    from bayes_dnlr import __version__

    return __version__


def _finished_result(cfg: Config, test, stored: StoredRun, fp: str) -> Posterior | None:
    """For a finished run whose stopping rule still holds: its Posterior (outputs rewritten only
    when missing or made with other settings). None when sampling must continue."""
    if not stored.finished:
        return None
    sc = cfg.sampler
    n = stored.steps
    conv = (convergence(stored.chain, sc.burn_in_tau, sc.min_tau_multiple, sc.target_ess)
            if n >= MIN_STEPS_FOR_TAU else None)
    reason = stop_reason(conv, n, sc.max_steps)
    if reason is None:
        return None       # e.g. max_steps or target_ess raised: sample on from the last state
    summary = read_summary(cfg.run_dir)
    note = (f"{cfg.run_dir / CHAINS_FILE}: finished earlier ({reason} at step {n}); nothing sampled "
            "(sample --restart to sample again)")
    if (summary is not None and summary.get("fingerprint") == fp and summary.get("steps") == n
            and summary.get("settings") == _settings(cfg)
            and (cfg.run_dir / POSTERIOR_FILE).is_file()):
        return load_posterior(cfg.run_dir, note=note)
    # outputs missing or made with other burn-in/stopping settings: rebuild them from the chain
    fit = _current_fit(cfg, test, replace=False, progress=False)
    post = _write_result(cfg, stored, fit, conv, reason, fp, test,
                         str(stored.attrs.get("sigma0_source", "")), wall_time=stored.elapsed,
                         store_time=stored.store_time, evals=stored.n_evals)
    post.note = note + "; summary.json and posterior.nc rewritten from the chain"
    return post


def _write_result(cfg: Config, run: StoredRun, fit: dict[str, Any], conv: Convergence | None,
                  reason: str | None, fp: str, test, sigma0_source: str, *, wall_time: float,
                  store_time: float, evals: int) -> Posterior:
    """posterior.nc and summary.json from the stored chain."""
    sc = cfg.sampler
    names = run.names
    if conv is None:
        conv = convergence(run.chain, sc.burn_in_tau, sc.min_tau_multiple, sc.target_ess)
    burn = conv.burn_in
    draws = run.chain[burn:]
    lp = run.log_prob[burn:]
    sigma_stored = run.attrs.get("sigma0")
    if "sigma0" in names:
        sigma0 = float(draws[:, :, names.index("sigma0")].mean())
    else:
        sigma0 = float(sigma_stored)
    sampling = max(wall_time - store_time, 1e-12)
    acc = float(run.accepted[burn:].mean()) if run.accepted.size else float("nan")
    warnings = []
    if reason != "converged":
        warnings.append(f"not converged: stopped at max_steps = {sc.max_steps}: "
                        f"{shortfall(conv, names, sc.target_ess, sc.min_tau_multiple)} "
                        f"(about {conv.needed_steps} steps needed)")
    extra = {
        "sigma0": sigma0, "n_points": int(test.n_points), "steps": int(run.steps),
        "wall_time_s": wall_time, "standards": _standards(test), "deborah_max": fit.get("deborah_max"),
        "name": cfg.name, "stop_reason": reason, "converged": reason == "converged",
        "burn_in": int(burn), "target_ess": sc.target_ess, "moves": MOVES.get(sc.moves, sc.moves),
        "seed": sc.seed, "acceptance_fraction": acc, "sigma0_source": sigma0_source,
        "storage_time_s": store_time, "storage_overhead": store_time / sampling,
        "log_prob_evals": int(evals), "log_prob_evals_per_s": evals / sampling,
        "settings": _settings(cfg), "fingerprint": fp, "data_sha256": test.sha256,
        "version": _version(),
    }
    attrs = {"burn_in": int(burn), "stop_reason": reason, "walkers": int(run.chain.shape[1]),
             "steps": int(run.steps), "moves": sc.moves, "seed": sc.seed, "run": cfg.name,
             "sampling_coordinates": json.dumps({k: ("log" if ls else "linear") for k, ls in
                                                 zip(names, run.attrs.get("log_space", []),
                                                     strict=False)})}
    dt = build_datatree(names, draws, lp, attrs)
    summary = summarize(names, draws, fit=fit, tau=conv.tau, extra=extra)
    summary["noise"] = jsonable(noise_block(cfg, fit, summary, sigma0, sigma0_source))
    if summary["noise"]["model"] == "discrepancy":
        summary["generalized_least_squares"] = gauss_newton_block(
            {"parameters": fit.get("parameters"), **fit["discrepancy"]})
    summary["warnings"] = warnings + [
        f"R-hat of {k} is {summary['posterior'][k]['r_hat']:.4f} > 1.01"
        for k in names if (summary["posterior"][k]["r_hat"] or 0) > 1.01] + residual_warnings(fit)
    if summary["noise"]["model"] == "white" and summary["noise"]["fit_residuals_white"] is False:
        summary["warnings"].append(summary["noise"]["verdict"])
    write_outputs(cfg.run_dir, dt, summary)
    return Posterior(cfg.run_dir, summary, dt)
