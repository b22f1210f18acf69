"""``sample`` as a run: the posterior of a config, sampled into ``<run_dir>/chains.h5``, then
posterior.nc and summary.json (``python -m bayes_dnlr sample``).

1. Posterior: priors from the config, Gaussian likelihood with σ0 fixed (number, residuals,
   baseline: resolved once, from fit.json) or sampled (``sigma0`` with its prior); see
   inference/posterior/likelihood.py.
2. Start: the walkers are drawn from the least-squares estimate and its linearized covariance
   (fit.json, eq. 32; ``fit`` runs first when fit.json is missing or stale).
3. Sampling and stopping: inference/mcmc/ensemble.py (``run_ensemble``).
4. Storage: chains.h5 (runs/chains.py), appended every ``checkpoint_every`` steps; a re-run
   resumes from the last checkpoint and continues the same chain bit-exactly; a changed config or
   data file is refused (RunError) unless ``restart``; a finished, current run is not sampled again.
5. Outputs: posterior.nc, summary.json (runs/outputs.py).
"""

from __future__ import annotations

import json
import sys
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.config import Config, ConfigError
from bayes_dnlr.digests import digest
from bayes_dnlr.errors import BayesDnlrError, DamagedFileError, StaleRunError
from bayes_dnlr.inference.mcmc.ensemble import (
    COMPLEMENT,
    CONDITIONAL,
    LAPLACE,
    MOVES,
    clear_of_bounds,
    complement_fits,
    linearized_root,
    make_moves,
    run_ensemble,
    start_ensemble,
)
from bayes_dnlr.inference.mcmc.state import SamplerState
from bayes_dnlr.inference.mcmc.stopping import (
    MIN_STEPS_FOR_TAU,
    StopRule,
    convergence,
    stop_reason,
)
from bayes_dnlr.inference.posterior.priors import build_priors
from bayes_dnlr.interrupt import Interrupted
from bayes_dnlr.runs import identity
from bayes_dnlr.runs.chain_outputs import json_attr, package_version, stopping_settings, write_result
from bayes_dnlr.runs.chains import ChainWriter, StoredRun, read_attrs, read_run, release_stale_writer
from bayes_dnlr.runs.folder import (
    check_output_dir,
    discard_if_empty,
    make_dir,
    prepare_run_dir,
    resolved_config_text,
)
from bayes_dnlr.runs.layout import CHAINS_FILE, FIT_FILE, POSTERIOR_FILE, SAMPLE_LOCK, SUMMARY_FILE
from bayes_dnlr.runs.lock import run_lock
from bayes_dnlr.runs.outputs import (
    Posterior,
    load_posterior,
    read_summary,
)
from bayes_dnlr.runs.records import FitRecord, held_config, held_parameters
from bayes_dnlr.runs.target import Target, build_target
from bayes_dnlr.runs.testset import TestSet, load_tests
from bayes_dnlr.vocabulary import base_name

# config sections that change the posterior or the chain; max_steps, target_ess, checkpoint_every,
# burn_in_tau and min_tau_multiple only decide how long to sample and what to keep.
POSTERIOR_SECTIONS = identity.CHAIN_SECTIONS
SAMPLER_KEYS = identity.SAMPLER_KEYS


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
    """Digests of what the chain depends on: config sections, sampler walkers/seed/moves, data file
    (runs/identity.py)."""
    return identity.chain_parts(cfg, data_sha256)


# ---------------------------------------------------------------- helpers

def _remove_outputs(run_dir: Path) -> None:
    for name in (CHAINS_FILE, POSTERIOR_FILE, SUMMARY_FILE):
        p = run_dir / name
        if p.exists():
            p.unlink()


# ---------------------------------------------------------------- sampling

def sample(cfg: Config, *, restart: bool = False, progress: bool = True,
           threads: int | None = None, report_curves: bool = True) -> Posterior:
    """Sample the posterior of ``cfg`` to convergence (or max_steps); resumable. See the module doc.

    ``threads``: threads of the compiled likelihood, instead of config ``sampler.threads``; both
    are capped by NUMBA_NUM_THREADS and OMP_NUM_THREADS (``model.threads.use_threads``). The chain
    does not depend on it. ``report_curves``: after sampling, compute and keep the report's curves
    while the compiled model is loaded (runs/curve_cache.py), so that ``report`` need not load it."""
    from bayes_dnlr.model.threads import use_threads

    t0 = time.perf_counter()
    use_threads(threads if threads is not None else cfg.sampler.threads)
    build_priors(cfg)               # validate the model priors early
    make_moves(cfg.sampler.moves)
    check_output_dir(cfg.run_dir, writable=False)
    before = identity.stat_data(cfg)
    test = load_tests(cfg)
    created = make_dir(cfg.run_dir)
    try:
        with _run_lock(cfg.run_dir):
            post = _sample(cfg, test, restart=restart, progress=progress, before=before,
                           report_curves=report_curves)
    except BaseException:
        if created:
            discard_if_empty(cfg.run_dir)   # nothing half-made is left by a failed first command
        raise
    timing = post.extras.setdefault("timing", {})
    timing["total_s"] = time.perf_counter() - t0
    return post


def _results_kept(run_dir: Path) -> str:
    """What a damaged chain leaves usable: the results written when it was finished."""
    kept = [name for name in (POSTERIOR_FILE, SUMMARY_FILE) if (run_dir / name).is_file()]
    if len(kept) < 2:
        return ""
    return (f". The results made from it are still there ({', '.join(kept)}): `report` and "
            "`export` read them; copy them elsewhere before `sample --restart`, which removes them")


def _run_lock(run_dir: Path):
    """One ``sample`` per run directory at a time (bayes_dnlr/runs/lock.py: released even on SIGKILL,
    removed when the command ends)."""
    return run_lock(run_dir, SAMPLE_LOCK, f"{run_dir}: another `sample` is running on this run "
                    "directory; wait for it or stop it (its chain is kept and resumes)")


def _current_fit(cfg: Config, test, *, replace: bool, progress: bool) -> dict[str, Any]:
    """fit.json for this config and data, running the fit when it is missing. A fit.json made from
    another config or data is replaced only when ``replace`` (sample --restart): never silently."""
    from bayes_dnlr.runs.fit import fit as run_fit
    from bayes_dnlr.runs.fit import load_fit

    if not identity.fit_is_current(cfg, test.sha256):
        reason = None if replace else identity.stale_fit_reason(cfg, test.sha256)
        if reason is not None:
            path = cfg.run_dir / FIT_FILE
            config = cfg.source if cfg.source is not None else "<config.yaml>"
            chain = ("the chain in chains.h5 still matches the config and is kept"
                     if (cfg.run_dir / CHAINS_FILE).exists() else "nothing is lost")
            raise StaleRunError(
                f"{path} was made from {reason}, and `sample` does not replace a fit silently. Redo "
                f"the fit with `python -m bayes_dnlr fit --force {config}`, then run `sample` again "
                f"({chain}); or set output.dir to work in another run directory; or `sample "
                "--restart`, which redoes the fit and also discards this run's chain")
        if progress:
            print("fit.json missing or stale: running the least-squares fit first", file=sys.stderr)
        run_fit(cfg, overwrite=replace, test=test)
    return load_fit(cfg.run_dir)


def independence_moves(moves: str, target: Target, stored: StoredRun | None,
                       walkers: int) -> tuple[Any, Any, bool]:
    """The independence move `de` adds to DEMove (inference/mcmc/blocks.py): (the conditional
    map, the Laplace proposal, the complement move), at most one of them given. The conditional
    move with sampled discrepancy hyperparameters, the Laplace move where the posterior is close to
    its linearization (``Target.near_linear``), both from fit.json; where that linearization meets
    a bound of the prior (of a model parameter; of any, for the Laplace move), or neither applies,
    the complement move, when half of the ``walkers`` are enough for it (``complement_fits``). A
    resumed chain goes on with the moves it began with (its ``moves_detail``; DEMove alone for a
    chain of an earlier version)."""
    if moves != "de":
        return None, None, False
    post, priors = target.post, target.priors
    lin = linearized_root(priors, target.x0, target.cov)
    if stored is None:
        clear = lin is not None and clear_of_bounds(priors, *lin, target.model_indices)
        conditional = clear        # conditional_map is None where no hyperparameter is sampled
        laplace = clear and target.near_linear and clear_of_bounds(priors, *lin)
        complement = complement_fits(walkers, len(target.names))
    else:
        began = stored.attrs.get("moves_detail")
        conditional, laplace = began == CONDITIONAL, began == LAPLACE
        complement = began == COMPLEMENT
    mapper = post.conditional_map(priors.from_physical(target.x0)) if conditional else None
    lap = lin if laplace and mapper is None else None
    return mapper, lap, complement and mapper is None and lap is None


def _sample(cfg: Config, test: TestSet, *, restart: bool, progress: bool, before=None,
            report_curves: bool = True) -> Posterior:
    run_dir = cfg.run_dir
    chains = run_dir / CHAINS_FILE
    parts = fingerprint_parts(cfg, test.sha256)
    fp = digest(parts)
    record = identity.data_record(cfg, test, before)
    sc = cfg.sampler

    release_stale_writer(chains, lock_held=True)    # plain h5py reads it again, whatever follows
    stored: StoredRun | None = None
    if chains.exists() and restart:
        _remove_outputs(run_dir)
    elif chains.exists():
        try:
            attrs = read_attrs(chains)
            reason = identity.chain_stale_reason(attrs, cfg, test.sha256, run_dir)
        except OSError as err:
            raise StaleRunError(f"{chains}: cannot read the stored chain ({err}); `sample --restart` "
                                "discards it and starts again") from None
        except DamagedFileError as err:
            raise DamagedFileError(f"{err}{_results_kept(run_dir)}") from None
        if reason is not None:
            raise StaleRunError(f"{chains} was sampled from another config or data: {reason}. The chain "
                                "is kept, not mixed with new steps: set output.dir to sample these "
                                "inputs into another run directory beside it, or `sample --restart` "
                                "discards it and starts again")
        fp = str(attrs.get("fingerprint") or fp)      # a chain of the previous form keeps its own
        try:
            stored = read_run(chains)
        except OSError as err:
            raise StaleRunError(f"{chains}: no usable checkpoint ({err}); `sample --restart` discards "
                                "it") from None
        except DamagedFileError as err:
            raise DamagedFileError(f"{err}{_results_kept(run_dir)}") from None
        done = _finished_result(cfg, test, stored, fp, record)
        if done is not None:
            return done

    t_fit = time.perf_counter()
    fit = _current_fit(cfg, test, replace=restart, progress=progress)
    t_fit = time.perf_counter() - t_fit
    prepare_run_dir(cfg)
    used = held_config(cfg, fit)          # the parameters the window cannot identify held
    target = build_target(used, test, FitRecord.from_dict(fit, cfg.test_names), stored)
    post, priors, names = target.post, target.priors, target.names
    sigma0, sigma0_source = target.sigma0, target.sigma0_source
    if progress and any(like.discrepancy is not None for like in post.likelihoods.values()):
        from bayes_dnlr.inference.discrepancy.compiled import announce_first_compile

        announce_first_compile()          # before the wait, not after the progress bar
    check_sampler(used, names)
    if stored is not None and (stored.names != names or [bool(v) for v in stored.attrs.get(
            "log_space", [])] != [bool(v) for v in priors.log_space]):
        raise StaleRunError(f"{chains} holds parameters {stored.names} sampled in other coordinates "
                            f"(made by bayes_dnlr {stored.attrs.get('version')}); it cannot be continued "
                            "and is kept: set output.dir to sample into another run directory, or "
                            "`sample --restart` discards it and starts again")

    walkers, ndim = sc.walkers, len(names)
    mapper, laplace, complement = independence_moves(sc.moves, target, stored, walkers)
    if stored is None:
        coords, lp = start_ensemble(post, priors, target.x0, target.cov, walkers, sc.seed)
        state0 = SamplerState(coords, lp, np.random.RandomState(sc.seed).get_state())
        meta = {
            "names": names, "log_space": [bool(v) for v in priors.log_space], "walkers": walkers,
            "ndim": ndim, "config": resolved_config_text(cfg), "fingerprint": fp,
            "fingerprint_parts": json.dumps(parts), "data_sha256": test.sha256,
            "identity": identity.chain_record(cfg, test, before),
            "data_file": str(test.path), "version": package_version(), "modes": cfg.model.modes,
            "decades": cfg.model.decades, "moves": sc.moves, "seed": sc.seed,
            "moves_detail": (CONDITIONAL if mapper is not None else LAPLACE if laplace is not None
                             else COMPLEMENT if complement else MOVES.get(sc.moves, sc.moves)),
            "sigma0": _sigma0_attr(sigma0), "sigma0_source": json.dumps(sigma0_source),
            "created": datetime.now(UTC).isoformat(timespec="seconds"), **target.meta,
        }
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
    # storage inside the loop only: creating or re-publishing the file happened before it
    store_before, store_prev = writer.store_time, (stored.store_time if stored is not None else 0.0)
    try:
        out = run_ensemble(post, priors.to_physical, sc.moves, state, chain0, writer, rule,
                           fresh=fresh, elapsed0=elapsed0, evals0=evals0, progress=progress,
                           mapper=mapper, laplace=laplace, complement=complement)
    except BaseException as err:
        steps = writer.steps
        writer.close()
        kept = f"stopped at step {steps}; the chain is saved in {chains}: run `sample` again to continue"
        if isinstance(err, KeyboardInterrupt):
            raise Interrupted(kept) from None
        if progress and not isinstance(err, BayesDnlrError):
            print(f"\n{kept}", file=sys.stderr)
        raise
    conv, reason = out.convergence, out.reason
    elapsed = elapsed0 + out.sampling_time
    store_time = store_prev + writer.store_time - store_before
    t_finish = time.perf_counter()
    writer.finish({"stop_reason": reason, "steps": int(out.chain.shape[0]),
                   "finished": datetime.now(UTC).isoformat(timespec="seconds")})
    t_finish = time.perf_counter() - t_finish
    t_out = time.perf_counter()
    run = read_run(chains)
    post = write_result(used, run, fit, conv, reason, fp, test, sigma0_source,
                         wall_time=elapsed, store_time=store_time, evals=evals0 + out.evals,
                         check_time=out.check_time, record=record)
    t_out = time.perf_counter() - t_out + t_finish
    t_curves = time.perf_counter()
    if report_curves:
        _keep_report_curves(cfg, test)
    # where a call's time went (benchmarks/sample_command.py): the fit (or reading fit.json), the
    # sampling loop, the outputs (finishing chains.h5, statistics, posterior.nc, summary.json) and
    # the report's curves
    post.extras["timing"] = {"fit_s": t_fit, "loop_s": out.sampling_time,
                             "loop_cpu_s": out.cpu_time, "loop_steps": int(out.chain.shape[0]),
                             "output_s": t_out, "report_curves_s": time.perf_counter() - t_curves}
    return post


def _keep_report_curves(cfg: Config, test: TestSet) -> None:
    """The report's curves of the run just sampled (runs/curve_cache.py). Only a head start for
    ``report``: where they cannot be made here, the report makes them and says what it lacks."""
    from bayes_dnlr.runs.curve_cache import keep_report_curves

    try:
        keep_report_curves(cfg.run_dir, test.tests)
    except (BayesDnlrError, OSError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        pass


def _sigma0_attr(sigma0: Any) -> Any:
    """σ0 as a chain attribute: a number, NaN when sampled; JSON of the per-test values of a run
    with several tests."""
    if isinstance(sigma0, dict):
        return json.dumps({t: (None if v is None else float(v)) for t, v in sigma0.items()})
    return float("nan") if sigma0 is None else float(sigma0)


def _check_holds(cfg: Config, stored: StoredRun, fit: dict[str, Any]) -> None:
    """A chain samples the parameters the fit leaves free: one that samples a parameter fit.json
    now holds (a chain made before the window was found not to identify it), or holds one it now
    leaves free, belongs to another analysis (StaleRunError)."""
    held = set(held_parameters(fit))
    sampled = {base_name(n) for n in stored.names}
    wrong = sorted((held & sampled) | ({k for k in cfg.free_parameters if k not in held} - sampled))
    if wrong:
        raise StaleRunError(
            f"{cfg.run_dir / CHAINS_FILE} samples {sorted(sampled & set(cfg.parameter_names))}, but "
            f"the fit now holds {sorted(held) or 'nothing'} (the parameters the window cannot "
            f"identify, docs/fit.md): they differ on {', '.join(wrong)}. The chain is kept: `sample "
            "--restart` discards it and samples the fit's parameters")


def _finished_result(cfg: Config, test, stored: StoredRun, fp: str,
                     record: dict[str, Any] | None = None) -> Posterior | None:
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
            and summary.get("settings") == stopping_settings(cfg)
            and (cfg.run_dir / POSTERIOR_FILE).is_file()):
        return load_posterior(cfg.run_dir, note=note)
    # outputs missing or made with other burn-in/stopping settings: rebuild them from the chain
    fit = _current_fit(cfg, test, replace=False, progress=False)
    _check_holds(cfg, stored, fit)
    post = write_result(held_config(cfg, fit), stored, fit, conv, reason, fp, test,
                         json_attr(stored.attrs.get("sigma0_source", "")), wall_time=stored.elapsed,
                         store_time=stored.store_time, evals=stored.n_evals, record=record)
    post.note = note + "; summary.json and posterior.nc rewritten from the chain"
    return post


