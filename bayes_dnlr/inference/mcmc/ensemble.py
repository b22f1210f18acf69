"""emcee on a log-density: moves, the start of the ensemble and the sampling loop.

Nothing here knows about configs or run directories (``bayes_dnlr.runs.sample`` does): the loop
takes a log-density in sampling coordinates (emcee ``vectorize=True``), a starting ``SamplerState``
and a ``CheckpointSink`` (state.py; runs/chains.py writes chains.h5) to commit checkpoints to, and
stops by the rule of stopping.py.

The progress bar counts the ESS this rule credits, toward target_ess (inference/mcmc/progress.py).
emcee is imported inside the functions that need them, without scipy.stats (emcee_import.py);
the ESS and R-hat of the stopping rule come from inference/mcmc/ess.py, not ArviZ.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from bayes_dnlr.config import ConfigError
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.mcmc.emcee_import import load_emcee
from bayes_dnlr.inference.mcmc.progress import EssProgress
from bayes_dnlr.inference.mcmc.state import CheckpointSink, SamplerState
from bayes_dnlr.inference.mcmc.stopping import (
    MIN_STEPS_FOR_TAU,
    Convergence,
    StopRule,
    convergence,
    stop_reason,
)
from bayes_dnlr.interrupt import Interrupted, deferred_interrupt

START_SCALE = 1.0       # walkers start as a draw of the linearized (Laplace) posterior
MOVES = {
    "de-snooker": "DEMove (0.8) + DESnookerMove (0.2)",
    "de": "DEMove",
    "stretch": "StretchMove (a = 2)",
    "de-plain": "DEMove (also with the discrepancy's hyperparameters sampled)",
}
CONDITIONAL = ("DEMove (0.3) + the conditional move (0.7): the discrepancy's hyperparameters from "
               "the other walkers, the model parameters from their conditional given them")
LAPLACE = "DEMove (0.3) + the Laplace move (0.7): every parameter from the linearized posterior"
COMPLEMENT = ("DEMove (0.3) + the complement move (0.7): every parameter from a Student t fitted to "
              "the other walkers")


# ---------------------------------------------------------------- configuration

def make_moves(kind: str, mapper: Any = None, laplace: tuple[np.ndarray, np.ndarray] | None = None,
               complement: bool = False) -> Any:
    """emcee moves for ``sampler.moves`` (benchmarks/moves.py compares them). ``de`` adds to
    DEMove an independence move (inference/mcmc/blocks.py, benchmarks/chain_mixing.py): the
    conditional move when ``mapper`` (the model parameters' conditional given the discrepancy's
    hyperparameters, inference/posterior/conditional.py) is given, else the Laplace move when
    ``laplace`` (the estimate and a square root of its covariance, sampling coordinates:
    ``linearized_root``) is, else the complement move when ``complement``; ``de-plain`` is DEMove
    alone."""
    emcee = load_emcee()

    if kind == "stretch":
        return emcee.moves.StretchMove()
    if kind == "de" and mapper is not None:
        from bayes_dnlr.inference.mcmc.blocks import CONDITIONAL_WEIGHT, ConditionalMove

        return [(emcee.moves.DEMove(), 1.0 - CONDITIONAL_WEIGHT),
                (ConditionalMove(mapper), CONDITIONAL_WEIGHT)]
    if kind == "de" and laplace is not None:
        from bayes_dnlr.inference.mcmc.blocks import LAPLACE_WEIGHT, LaplaceMove

        return [(emcee.moves.DEMove(), 1.0 - LAPLACE_WEIGHT), (LaplaceMove(*laplace), LAPLACE_WEIGHT)]
    if kind == "de" and complement:
        from bayes_dnlr.inference.mcmc.blocks import COMPLEMENT_WEIGHT, ComplementMove

        return [(emcee.moves.DEMove(), 1.0 - COMPLEMENT_WEIGHT), (ComplementMove(), COMPLEMENT_WEIGHT)]
    if kind in ("de", "de-plain"):
        return emcee.moves.DEMove()
    if kind == "de-snooker":
        return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
    raise ConfigError(f"sampler.moves: unknown moves {kind!r}; expected one of {list(MOVES)}")


def complement_fits(walkers: int, ndim: int) -> bool:
    """Whether half of ``walkers`` is enough for the complement move's covariance of ``ndim``
    parameters (2 ndim + 2 walkers in it; inference/mcmc/blocks.py)."""
    return walkers // 2 >= 2 * ndim + 2


# ---------------------------------------------------------------- stopping rule

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


def _root(cov_z: np.ndarray, z0: np.ndarray, width: np.ndarray) -> np.ndarray:
    """An invertible square root of the covariance ``cov_z`` (sampling coordinates): its
    eigenvalues floored at 1e-12 of the largest; a parameter without a finite variance gets a
    spread of 1e-3 of its prior ``width`` (or 1e-4 of its value when the prior is unbounded)."""
    d = z0.size
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
    return root


def _linearized(priors, x0: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """The estimate in sampling coordinates (clipped into the support box: an estimate on a bound,
    after the exp/log round trip) and a square root of its covariance there (delta method; None
    when the estimate is not finite there)."""
    zlo, zhi = support_box(priors)
    width = zhi - zlo
    inner = np.where(np.isfinite(width), 1e-9 * width, 0.0)
    with np.errstate(divide="ignore"):
        jac = priors.jacobian(x0)
    z0 = priors.from_physical(x0)
    if not np.all(np.isfinite(z0)):
        return z0, None
    z0 = np.clip(z0, zlo + inner, zhi - inner)
    return z0, _root(np.asarray(cov, dtype=float) * np.outer(jac, jac), z0, width)


# the linearized posterior is a proposal only this many sd inside the support: measured, an
# estimate 1.5 sd from a bound still mixed best with it (τ 2.2 against 4.8 with the complement
# move, white; 5.8 against 9.8 with the discrepancy), one on the bound with the complement move
# (τ 7.7-22 against 31-71)
INSIDE_SDS = 1.0


def linearized_root(priors, x0: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The linearized posterior (eq. 32) as the walkers start from it, in sampling coordinates:
    (the estimate, an invertible square root of its covariance); None when the estimate is not
    finite there."""
    z0, root = _linearized(priors, np.asarray(x0, dtype=float), cov)
    if root is None or not np.all(np.isfinite(root)) or np.linalg.det(root) == 0:
        return None
    return z0, root


def clear_of_bounds(priors, z0: np.ndarray, root: np.ndarray, which: Sequence[int] | None = None
                    ) -> bool:
    """Whether the linearized posterior (``linearized_root``) of the parameters ``which`` (default:
    all) lies ``INSIDE_SDS`` sd inside its prior's support. Not for an estimate near a bound (held
    on it by the fit, say): the posterior is cut there where the linearization is not, and an
    independence move from it is mostly rejected (docs/sampling.md)."""
    zlo, zhi = support_box(priors)
    sd = np.sqrt(np.sum(root * root, axis=1))
    idx = np.arange(z0.size) if which is None else np.asarray(which, dtype=int)
    return bool(np.all(z0[idx] - INSIDE_SDS * sd[idx] >= zlo[idx])
                and np.all(z0[idx] + INSIDE_SDS * sd[idx] <= zhi[idx]))


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
    z0, root = _linearized(priors, x0, cov)
    if root is None or not np.isfinite(log_prob(z0[None])[0]):
        raise RunError(
            "the least-squares estimate " + ", ".join(f"{k} = {v:.6g}" for k, v in zip(names, x0,
                                                                                      strict=True))
            + " has a zero posterior density (outside the prior support?): check the priors in "
            "parameters: and fit.json")
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
    (inference/mcmc/progress.py)."""
    from tqdm.auto import tqdm

    # no monitor thread (tqdm's, to refresh a bar left without updates): the bar is updated at
    # every check of the stopping rule, and a thread left asleep in the process keeps the report
    # of `sample --report` from forking its figure worker
    bar = type("SamplingBar", (tqdm,), {"monitor_interval": 0})
    return bar(total=total, initial=0, unit="ESS", desc="sampling", disable=not progress,
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
                 state: SamplerState, chain0: np.ndarray, writer: CheckpointSink, rule: StopRule, *,
                 fresh: bool, elapsed0: float = 0.0, evals0: int = 0,
                 progress: bool = True, mapper: Any = None,
                 laplace: tuple[np.ndarray, np.ndarray] | None = None,
                 complement: bool = False) -> RunOutcome:
    """Sample from ``state`` until the stopping rule holds or ``rule.max_steps``.

    Every ``rule.checkpoint_every`` steps the block is committed to ``writer`` with the state after
    its last step, so an interruption (Ctrl-C, SIGKILL) loses at most one block and a later call
    continues the same chain bit-exactly. The stopping rule is checked more often, at the steps of
    ``next_check``; a run that stops inside a block commits the steps it did.
    ``chain0``: the steps already done (physical units). ``log_prob.n_evals`` (when present)
    counts model evaluations. ``mapper``, ``laplace``, ``complement``: see ``make_moves``.

    ``sampling_time`` (summary.json ``wall_time_s``) is the time of this loop only: the emcee
    steps, the likelihood, the checks of the stopping rule and the checkpoints; the imports, the
    start of the ensemble and the outputs are outside it.
    """
    emcee = load_emcee()

    walkers, ndim = state.coords.shape
    chain = _Growing(chain0)
    sampler = emcee.EnsembleSampler(walkers, ndim, log_prob, vectorize=True,
                                    moves=make_moves(moves, mapper, laplace, complement))
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
