"""emcee on a log-density: moves, the start of the ensemble, the stopping rule, the sampling loop.

Nothing here knows about configs or run directories (``bayes_dnlr.pipeline.sample`` does): the loop
takes a log-density in sampling coordinates (emcee ``vectorize=True``), a starting ``SamplerState``
and a ``ChainWriter`` (store.py) to commit checkpoints to.

Stopping rule: at each checkpoint, emcee's integrated autocorrelation time τ of every parameter is
estimated on the chain after a burn-in of ``burn_in_tau`` τ; the run stops when every
ESS = kept steps × walkers / τ >= ``target_ess``, the kept chain is >= ``min_tau_multiple`` τ long
and ArviZ's bulk/tail ESS and R-hat agree ("converged"), or at ``max_steps`` ("max_steps").

The progress bar counts the ESS this rule credits, toward target_ess (inference/progress.py).
emcee is imported inside the functions that need them, without scipy.stats (emcee_import.py);
the ESS and R-hat of the stopping rule come from inference/ess.py, not ArviZ.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bayes_dnlr.config import ConfigError
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.emcee_import import load_emcee
from bayes_dnlr.inference.ess import next_fast_len
from bayes_dnlr.inference.progress import EssProgress
from bayes_dnlr.inference.store import ChainWriter, SamplerState
from bayes_dnlr.interrupt import Interrupted, deferred_interrupt

START_SCALE = 1.0       # walkers start as a draw of the linearized (Laplace) posterior
MIN_STEPS_FOR_TAU = 20  # shorter chains: no τ estimate, no stopping decision
RHAT_MAX = 1.01         # convergence also needs R-hat (4 walker groups) <= this
TAU_WINDOW_C = 5.0      # Sokal's window constant of emcee's integrated_time
MOVES = {
    "de-snooker": "DEMove (0.8) + DESnookerMove (0.2)",
    "de": "DEMove",
    "stretch": "StretchMove (a = 2)",
}


# ---------------------------------------------------------------- configuration

def make_moves(kind: str) -> Any:
    """emcee moves for ``sampler.moves`` (benchmarks/moves.py compares them)."""
    emcee = load_emcee()

    if kind == "stretch":
        return emcee.moves.StretchMove()
    if kind == "de":
        return emcee.moves.DEMove()
    if kind == "de-snooker":
        return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
    raise ConfigError(f"sampler.moves: unknown moves {kind!r}; expected one of {list(MOVES)}")


# ---------------------------------------------------------------- stopping rule

@dataclass(frozen=True)
class Convergence:
    """emcee τ per parameter on the kept chain, the burn-in and the ESS it implies; ArviZ's
    diagnostics of the kept draws once emcee's criteria hold; the walkers that did not move."""

    tau: np.ndarray          # (ndim,) steps; inf when no walker moved in that parameter
    burn_in: int             # steps discarded
    kept: int                # steps kept
    ess: np.ndarray          # (ndim,) kept × moving walkers / τ
    converged: bool
    needed_steps: int        # estimated total steps for the stopping rule
    arviz_ess: float | None = None   # min over parameters of ArviZ ess_bulk and ess_tail
    r_hat: float | None = None       # max over parameters of R-hat (4 walker groups)
    stuck: dict[int, list[int]] = field(default_factory=dict)   # parameter index -> walkers that
    #                                                             never moved over the kept chain

    @property
    def min_ess(self) -> float:
        return float(np.min(self.ess)) if self.ess.size else 0.0


def _moving(chain: np.ndarray) -> np.ndarray:
    """(walkers, ndim): True where the walker's coordinate changes at least once in ``chain``."""
    return np.ptp(chain, axis=0) > 0


def _tau(chain: np.ndarray) -> np.ndarray:
    """emcee's integrated autocorrelation time per parameter over the walkers that move in it.

    A walker that stays at one point has no autocorrelation function (emcee divides 0 by 0 and
    the average over walkers becomes NaN): it is left out, and a parameter in which no walker
    moves gets τ = inf. Never NaN. emcee's estimator (``emcee.autocorr.integrated_time``, c = 5:
    the walkers' normalised autocorrelation functions averaged, Sokal's window), computed with one
    FFT over all walkers at once instead of one per walker: the stopping rule is checked every
    2 % of the chain, and emcee's loop over walkers made the checks a fifth of a long run."""
    moving = _moving(chain)
    n = chain.shape[0]
    size = next_fast_len(2 * n)     # any length >= 2n - 1 is exact; emcee pads to 2 × a power of 2
    tau = np.full(chain.shape[2], math.inf)
    for j in range(chain.shape[2]):
        m = moving[:, j]
        if not m.any():
            continue
        x = chain[:, m, j]
        f = np.fft.rfft(x - x.mean(axis=0), n=size, axis=0)
        acf = np.fft.irfft(f * np.conjugate(f), n=size, axis=0)[:n]
        acf /= acf[0]
        taus = 2.0 * np.cumsum(acf.mean(axis=1)) - 1.0
        inside = np.arange(n) < TAU_WINDOW_C * taus
        t = float(taus[int(np.argmin(inside)) if inside.any() else n - 1])
        tau[j] = t if math.isfinite(t) and t > 0 else math.inf
    return tau


def _steps(x: float, fallback: int) -> int:
    """ceil(x) as steps; ``fallback`` when x is not finite (a τ that could not be estimated)."""
    return int(math.ceil(x)) if math.isfinite(x) else int(fallback)


def convergence(chain: np.ndarray, burn_in_tau: float, min_tau_multiple: float,
                target_ess: float, check_arviz: bool = True) -> Convergence:
    """The stopping rule on a chain (steps, walkers, ndim) in physical units.

    τ (emcee's estimator) on the whole chain sets the burn-in, ``burn_in_tau`` τ (τ re-estimated on
    the kept part enlarges it when larger); τ on the kept part gives ESS = kept × walkers / τ.
    Converged when the kept part is >= ``min_tau_multiple`` τ long, every ESS >= ``target_ess`` and
    every walker moves in every parameter over the kept part (a stuck walker, which rejects every
    proposal, is a finding: ``stuck`` names it); then (``check_arviz``) also ArviZ's bulk and tail
    ESS >= ``target_ess`` and R-hat <= RHAT_MAX, so that every figure summary.json reports meets
    the target. A τ that cannot be estimated is inf, never NaN.
    """
    n, w, d = chain.shape
    if n < MIN_STEPS_FOR_TAU:
        tau = np.full(d, float(max(n, 1)))
        return Convergence(tau, 0, n, n * w / tau, False, 10 * MIN_STEPS_FOR_TAU)
    last = n - MIN_STEPS_FOR_TAU
    tau_all = _tau(chain)
    burn = min(_steps(burn_in_tau * tau_all.max(), last), last)
    tau = _tau(chain[burn:])
    if burn_in_tau * tau.max() > burn and burn < last:
        burn = min(_steps(burn_in_tau * tau.max(), last), last)
        tau = _tau(chain[burn:])
    kept = n - burn
    moving = _moving(chain[burn:])
    stuck = {j: [int(k) for k in np.flatnonzero(~moving[:, j])] for j in range(d)
             if not moving[:, j].all()}
    ess = kept * moving.sum(axis=0) / tau
    converged = bool(not stuck and kept >= min_tau_multiple * tau.max() and np.all(ess >= target_ess))
    tau_max = float(max(tau.max(), tau_all.max()))
    if math.isfinite(tau_max):
        need_kept = max(min_tau_multiple * tau_max, target_ess * tau_max / w)
        needed = _steps(burn_in_tau * tau_max + need_kept, 2 * n)
    else:
        needed = 2 * n        # no τ to extrapolate from: at least double the chain
    if stuck:
        needed = max(needed, n + 1)
    arviz_ess = r_hat = None
    if converged and check_arviz:
        from bayes_dnlr.inference.posterior import diagnostics

        diag = [diagnostics(chain[burn:, :, j]) for j in range(d)]
        arviz_ess = min(min(x["ess_bulk"], x["ess_tail"]) for x in diag)
        r_hat = max(x["r_hat"] for x in diag)
        if not (arviz_ess >= target_ess and r_hat <= RHAT_MAX):
            converged = False
            needed = max(needed, n + 1)
    return Convergence(tau, burn, kept, ess, converged, needed, arviz_ess, r_hat, stuck)


def stuck_words(conv: Convergence, names: list[str]) -> str | None:
    """The stuck walkers in words (None when every walker moves)."""
    if not conv.stuck:
        return None
    walkers = sorted({k for ws in conv.stuck.values() for k in ws})
    total = len(walkers)
    shown = ", ".join(str(k) for k in walkers[:10]) + (", ..." if total > 10 else "")
    params = ", ".join(names[j] for j in sorted(conv.stuck))
    return (f"{total} walker(s) ({shown}) did not move in {params} over the kept {conv.kept} steps: "
            "stuck where every proposal is rejected (a far, narrow or bounded region of the "
            "posterior), so the chain does not sample the posterior there")


def shortfall(conv: Convergence, names: list[str], target_ess: float, min_tau_multiple: float) -> str:
    """Which part of the stopping rule a chain does not meet, in words."""
    parts = []
    stuck = stuck_words(conv, names)
    if stuck:
        parts.append(stuck)
    tau_max = float(conv.tau.max())
    if conv.kept < min_tau_multiple * tau_max:
        parts.append(f"kept chain {conv.kept} steps < {min_tau_multiple:g} tau = "
                     f"{min_tau_multiple * tau_max:.0f}")
    low = [f"{n} {e:.0f}" for n, e in zip(names, conv.ess, strict=True) if e < target_ess]
    if low:
        parts.append(f"ESS below {target_ess:.0f}: {', '.join(low)}")
    if conv.arviz_ess is not None and conv.arviz_ess < target_ess:
        parts.append(f"ArviZ ESS {conv.arviz_ess:.0f} < {target_ess:.0f}")
    if conv.r_hat is not None and conv.r_hat > RHAT_MAX:
        parts.append(f"R-hat {conv.r_hat:.3f} > {RHAT_MAX}")
    return "; ".join(parts) or "criteria not evaluated"


def stop_reason(conv: Convergence | None, steps: int, max_steps: int) -> str | None:
    if conv is not None and conv.converged:
        return "converged"
    if steps >= max_steps:
        return "max_steps"
    return None


# ---------------------------------------------------------------- start

def support_box(priors) -> tuple[np.ndarray, np.ndarray]:
    """The prior support in sampling coordinates: (low, high) per parameter (may be infinite)."""
    lo = np.array([p.low for p in priors.priors], dtype=float)
    hi = np.array([p.high for p in priors.priors], dtype=float)
    with np.errstate(divide="ignore", over="ignore"):
        zlo = priors.from_physical(np.where(priors.log_space, np.maximum(lo, 0.0), lo))
        zhi = priors.from_physical(hi)
    return zlo, zhi


def _into_box(z: np.ndarray, zlo: np.ndarray, zhi: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """Reflect points into [zlo, zhi] at each face, then clip into the box shrunk by ``inner``."""
    z = z.copy()
    for _ in range(2):     # a second pass for points beyond the width of the box
        z = np.where(z < zlo, 2 * zlo - z, z)
        z = np.where(z > zhi, 2 * zhi - z, z)
    return np.clip(z, zlo + inner, zhi - inner)


def start_ensemble(log_prob: Callable[[np.ndarray], np.ndarray], priors, x0: np.ndarray,
                   cov: np.ndarray, walkers: int, seed: int,
                   scale: float = START_SCALE) -> tuple[np.ndarray, np.ndarray]:
    """Walkers drawn from N(x0, scale² cov) truncated to the prior support, carried into sampling
    coordinates (the Laplace approximation of the posterior around the least-squares estimate,
    eq. 32). Deterministic for a seed.

    A draw outside the support box is redrawn (up to 100 times per walker), then reflected into
    it; a draw inside the box whose posterior density is still zero is pulled halfway towards the
    estimate until it is not. So an estimate on a bound, or in a corner of the prior box, starts
    as well as one in the middle. ``x0`` and ``cov`` are in physical units; a parameter whose
    variance is not finite (e.g. held on a bound by the fit) gets a small spread of its own.
    """
    names = priors.names
    d = len(names)
    zlo, zhi = support_box(priors)
    width = zhi - zlo
    inner = np.where(np.isfinite(width), 1e-9 * width, 0.0)
    with np.errstate(divide="ignore"):
        jac = priors.jacobian(x0)
    z0 = priors.from_physical(x0)
    if np.all(np.isfinite(z0)):
        z0 = np.clip(z0, zlo + inner, zhi - inner)   # an estimate on a bound, after exp/log round trip
    if not np.all(np.isfinite(z0)) or not np.isfinite(log_prob(z0[None])[0]):
        raise RunError(
            "the least-squares estimate " + ", ".join(f"{k} = {v:.6g}" for k, v in zip(names, x0,
                                                                                      strict=True))
            + " has a zero posterior density (outside the prior support?): check the priors in "
            "parameters: and fit.json")
    cov_z = np.asarray(cov, dtype=float) * np.outer(jac, jac)
    ok = np.all(np.isfinite(cov_z), axis=0) & np.all(np.isfinite(cov_z), axis=1) & (np.diag(cov_z) > 0)
    small = np.where(np.isfinite(width), 1e-3 * width, 1e-4 * np.maximum(np.abs(z0), 1e-3))
    root = np.zeros((d, d))
    if ok.any():
        sub = cov_z[np.ix_(ok, ok)]
        vals, vecs = np.linalg.eigh(0.5 * (sub + sub.T))
        vals = np.clip(vals, max(vals.max(), 0.0) * 1e-12, None)
        root[np.ix_(ok, ok)] = vecs * np.sqrt(vals)
    root[~ok, ~ok] = small[~ok]
    if not np.any(root):
        root = np.diag(1e-4 * np.maximum(np.abs(z0), 1e-3))
    rng = np.random.default_rng([int(seed) % 2**63, 0x5A4D])

    def draw(k: int) -> np.ndarray:
        return z0 + scale * rng.standard_normal((k, d)) @ root.T

    coords = draw(walkers)
    for _ in range(100):               # the Gaussian truncated to the support box
        out = np.any((coords < zlo) | (coords > zhi), axis=1)
        if not out.any():
            break
        coords[out] = draw(int(out.sum()))
    coords = _into_box(coords, zlo, zhi, inner)
    lp = log_prob(coords)
    for _ in range(60):                # zero density inside the box: towards the estimate
        bad = ~np.isfinite(lp)
        if not bad.any():
            break
        coords[bad] = z0 + 0.5 * (coords[bad] - z0)
        lp[bad] = log_prob(coords[bad])
    if not np.all(np.isfinite(lp)):
        raise RunError(f"{int((~np.isfinite(lp)).sum())} of {walkers} starting walkers have a zero "
                       "posterior density even next to the least-squares estimate: check the priors "
                       "in parameters: against fit.json")
    return coords, lp


# ---------------------------------------------------------------- the loop

class _Growing:
    """An array that grows along axis 0 with amortised O(1) appends."""

    def __init__(self, initial: np.ndarray) -> None:
        self._a = np.empty((max(2 * initial.shape[0], 256), *initial.shape[1:]), initial.dtype)
        self.n = initial.shape[0]
        self._a[: self.n] = initial

    def extend(self, block: np.ndarray) -> None:
        m = block.shape[0]
        if self.n + m > self._a.shape[0]:
            bigger = np.empty((2 * (self.n + m), *self._a.shape[1:]), self._a.dtype)
            bigger[: self.n] = self._a[: self.n]
            self._a = bigger
        self._a[self.n: self.n + m] = block
        self.n += m

    @property
    def array(self) -> np.ndarray:
        return self._a[: self.n]



@dataclass(frozen=True)
class StopRule:
    """When to stop and what to keep (config ``sampler``)."""

    burn_in_tau: float
    min_tau_multiple: float
    target_ess: float
    max_steps: int
    checkpoint_every: int


@dataclass
class RunOutcome:
    """What the sampling loop did: the stopping decision and the chain it left (physical units)."""

    chain: np.ndarray               # (steps, walkers, ndim) the whole chain so far
    convergence: Convergence | None
    reason: str | None              # converged | max_steps
    state: SamplerState
    sampling_time: float            # s, this session's loop: steps, checks and storage
    evals: int                      # log-density evaluations this session
    check_time: float = 0.0         # s, this session, checking the stopping rule
    cpu_time: float = 0.0           # s, CPU time of the process (all threads) during the loop


def _progress_bar(progress: bool, total: int):
    """The bar counts the ESS the stopping rule credits, toward ``total`` = target_ess
    (inference/progress.py)."""
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=0, unit="ESS", desc="sampling", disable=not progress,
                dynamic_ncols=True, file=sys.stderr, leave=True)


def _steps_text(n: int, rule: StopRule, conv: Convergence | None) -> str:
    tau = "" if conv is None else f", tau {float(conv.tau.max()):.1f}"
    return f"step {n}/{rule.max_steps}{tau}"


CHECK_FRACTION = 0.02   # convergence is checked every 2 % of the chain's length (at least 1 step)


def next_check(n: int, conv: Convergence | None, every: int) -> int:
    """The step at which to check the stopping rule next, after a check at step ``n``.

    Every ``CHECK_FRACTION`` of the chain (ESS grows in proportion to the kept steps, so a run stops
    at most ~2-3 % past the step where the rule first holds, kept steps counted from the burn-in),
    and not before the step the last τ estimate says is needed (``conv.needed_steps``), but at least
    once per checkpoint block."""
    step = max(1, math.ceil(CHECK_FRACTION * n))
    if n < MIN_STEPS_FOR_TAU:
        return MIN_STEPS_FOR_TAU
    if conv is not None and not conv.stuck and conv.needed_steps > n + step:
        step = conv.needed_steps - n
    return n + min(step, every)


def run_ensemble(log_prob: Callable[[np.ndarray], np.ndarray], to_physical: Callable, moves: str,
                 state: SamplerState, chain0: np.ndarray, writer: ChainWriter, rule: StopRule, *,
                 fresh: bool, elapsed0: float = 0.0, evals0: int = 0,
                 progress: bool = True) -> RunOutcome:
    """Sample from ``state`` until the stopping rule holds or ``rule.max_steps``.

    Every ``rule.checkpoint_every`` steps the block is committed to ``writer`` with the state after
    its last step, so an interruption (Ctrl-C, SIGKILL) loses at most one block and a later call
    continues the same chain bit-exactly. The stopping rule is checked more often, at the steps of
    ``next_check``; a run that stops inside a block commits the steps it did.
    ``chain0``: the steps already done (physical units). ``log_prob.n_evals`` (when present)
    counts model evaluations.

    ``sampling_time`` (summary.json ``wall_time_s``) is the time of this loop only: the emcee
    steps, the likelihood, the checks of the stopping rule and the checkpoints; the imports, the
    start of the ensemble and the outputs are outside it.
    """
    emcee = load_emcee()

    walkers, ndim = state.coords.shape
    chain = _Growing(chain0)
    sampler = emcee.EnsembleSampler(walkers, ndim, log_prob, moves=make_moves(moves), vectorize=True)
    every = rule.checkpoint_every
    conv = None
    reason = None
    evals_start = getattr(log_prob, "n_evals", 0)
    meter = EssProgress(rule.target_ess, rule.min_tau_multiple)
    bar = _progress_bar(progress, meter.total)
    check_time = 0.0

    def check(full: np.ndarray) -> None:
        nonlocal conv, reason, check_time
        t0 = time.perf_counter()
        n = full.shape[0]
        conv = (convergence(full, rule.burn_in_tau, rule.min_tau_multiple, rule.target_ess)
                if n >= MIN_STEPS_FOR_TAU else None)
        reason = stop_reason(conv, n, rule.max_steps)
        bar.set_postfix_str(_steps_text(n, rule, conv), refresh=False)
        bar.update(meter.check(conv) - bar.n)
        check_time += time.perf_counter() - t0

    t_session = time.perf_counter()
    cpu0 = time.process_time()
    with bar, deferred_interrupt() as ctrl_c:
        check(chain.array)
        check_at = next_check(chain.n, conv, every)
        while reason is None and not ctrl_c.requested:
            n = chain.n
            m = min(every - n % every, rule.max_steps - n)
            block = np.empty((m, walkers, ndim))
            block_lp = np.empty((m, walkers))
            block_acc = np.empty((m, walkers), bool)
            prev = state.coords
            done = 0
            try:
                for i, st in enumerate(sampler.sample(
                        emcee.State(state.coords, log_prob=state.log_prob, random_state=state.rng),
                        iterations=m, store=False, skip_initial_state_check=not (fresh and n == 0))):
                    block[i] = st.coords
                    block_lp[i] = st.log_prob
                    block_acc[i] = np.any(st.coords != prev, axis=1)
                    prev = block[i]
                    last = st
                    done = i + 1
                    bar.set_postfix_str(_steps_text(n + done, rule, conv), refresh=False)
                    bar.update(0)
                    if ctrl_c.requested:    # Ctrl-C: commit what is done, stop outside emcee
                        break
                    if n + done >= check_at and done < m:
                        check(np.concatenate([chain.array, to_physical(block[:done])]))
                        check_at = next_check(n + done, conv, every)
                        if reason is not None:
                            break
            finally:
                if done:
                    state = SamplerState(block[done - 1].copy(), block_lp[done - 1].copy(),
                                         last.random_state)
                    chain.extend(to_physical(block[:done]))
                    evals = evals0 + getattr(log_prob, "n_evals", 0) - evals_start
                    writer.append(block[:done], block_lp[:done], block_acc[:done], state,
                                  elapsed0 + time.perf_counter() - t_session, evals)
            if reason is None and not ctrl_c.requested:
                check(chain.array)
                check_at = next_check(chain.n, conv, every)
    if ctrl_c.requested and reason is None:
        raise Interrupted(f"stopped at step {chain.n}")
    elapsed = time.perf_counter() - t_session
    return RunOutcome(chain.array, conv, reason, state, elapsed,
                      getattr(log_prob, "n_evals", 0) - evals_start, check_time,
                      time.process_time() - cpu0)
