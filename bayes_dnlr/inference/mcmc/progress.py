"""Progress of a sampling run as the stopping rule sees it: the ESS it credits, toward the target.

The stopping rule (stopping.convergence) stops when every emcee ESS >= target, the kept chain is
>= ``min_tau_multiple`` τ long, no walker is stuck, and ArviZ's bulk/tail ESS >= target with R-hat
<= 1.01. The bar counts one number toward one fixed total, ``target_ess``: the ESS the rule would
credit now, the least of the emcee ESS, ArviZ's (when evaluated) and ``target × kept / (m τ)``
(the chain-length condition as a share of the target). It is shown monotone (an estimate that
drops leaves the bar where it was), reaches the total only when the rule says "converged", and
stays below it otherwise (the total no longer jumps with the predicted number of steps).
"""

from __future__ import annotations

import math

from bayes_dnlr.inference.mcmc.stopping import Convergence


def credited_ess(conv: Convergence | None, target_ess: float, min_tau_multiple: float) -> float:
    """The ESS the stopping rule credits ``conv`` with (0 before τ can be estimated)."""
    if conv is None or conv.ess.size == 0:
        return 0.0
    tau = float(conv.tau.max())
    if not math.isfinite(tau) or tau <= 0:
        return 0.0
    ess = conv.min_ess
    if conv.arviz_ess is not None:
        ess = min(ess, float(conv.arviz_ess))
    if min_tau_multiple > 0:
        ess = min(ess, target_ess * conv.kept / (min_tau_multiple * tau))
    return max(0.0, ess) if math.isfinite(ess) else 0.0


class EssProgress:
    """The bar's position (ESS, 0..total) after each stopping-rule check: monotone, the total fixed
    at the target, the total reached exactly when the run converged."""

    def __init__(self, target_ess: float, min_tau_multiple: float) -> None:
        self.target = float(target_ess)
        self.total = max(1, math.ceil(self.target))
        self.min_tau_multiple = min_tau_multiple
        self.position = 0
        self.ess = 0.0               # the credited ESS at the last check (may drop; the bar does not)

    def check(self, conv: Convergence | None) -> int:
        """Record one check of the rule; return the new position."""
        self.ess = credited_ess(conv, self.target, self.min_tau_multiple)
        if conv is not None and conv.converged:
            pos = self.total
        else:
            pos = min(math.floor(self.ess), self.total - 1)
        self.position = max(self.position, pos)
        return self.position
