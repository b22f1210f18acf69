"""When an emcee run stops: the autocorrelation time, the ESS it implies, and the rule.

At each check, emcee's integrated autocorrelation time τ of every parameter is estimated on the
chain after a burn-in of ``burn_in_tau`` τ; the run stops when every
ESS = kept steps × walkers / τ >= ``target_ess``, the kept chain is >= ``min_tau_multiple`` τ long
and the bulk/tail ESS and R-hat of ess.py agree ("converged"), or at ``max_steps`` ("max_steps").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bayes_dnlr.inference.mcmc.ess import next_fast_len

MIN_STEPS_FOR_TAU = 20  # shorter chains: no τ estimate, no stopping decision
RHAT_MAX = 1.01         # convergence also needs R-hat (4 walker groups) <= this
TAU_WINDOW_C = 5.0      # Sokal's window constant of emcee's integrated_time


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
        from bayes_dnlr.inference.mcmc.ess import diagnostics

        diag = [diagnostics(chain[burn:, :, j]) for j in range(d)]
        arviz_ess = min(min(x["ess_bulk"], x["ess_tail"]) for x in diag)
        r_hat = max(x["r_hat"] for x in diag)
        if not (arviz_ess >= target_ess and r_hat <= RHAT_MAX):
            converged = False
            # ESS grows about in proportion to the kept steps: the next check half-way to the
            # step where that puts ArviZ's ESS at the target, not every 2 % of the chain (a dozen
            # such checks, 20-25 ms each, cost a real curve's white chain 0.3 s)
            short = kept * (target_ess / arviz_ess - 1.0) if 0 < arviz_ess < target_ess else 0.0
            needed = max(needed, n + max(1, int(0.5 * short)))
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


@dataclass(frozen=True)
class StopRule:
    """When to stop and what to keep (config ``sampler``)."""

    burn_in_tau: float
    min_tau_multiple: float
    target_ess: float
    max_steps: int
    checkpoint_every: int
