"""Do the tests of a run agree? Each test's own estimate of a shared quantity (E(t), E), from its
own fit, against the others', in their combined sd.

A joint posterior with a shared E always gives one E, however far apart the tests are; this check
says whether they look like one material first. Each test's own fit uses only its data, so two
tests' estimates are independent and their difference has the variance sd_i² + sd_j². The tests
agree when Cochran's Q, Σ w_i (x_i − x̄)² with w = 1/sd², is within the 99 % point of χ² with
k − 1 degrees of freedom (the heterogeneity test of a meta-analysis), and it names the pair
furthest apart in combined sd.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from itertools import combinations

import numpy as np

P_AGREE = 0.01          # Cochran's Q above its 1 - P_AGREE point of χ²: the tests disagree


@dataclass(frozen=True)
class Agreement:
    """One quantity over the tests: their values and sds, the pooled value, Cochran's Q."""

    quantity: str
    values: dict[str, float]
    sds: dict[str, float]
    pooled: float
    q: float
    df: int
    p: float
    worst_pair: tuple[str, str] | None
    worst_z: float

    @property
    def agree(self) -> bool:
        return self.df < 1 or self.p >= P_AGREE

    def to_dict(self) -> dict:
        return {"quantity": self.quantity,
                "tests": {t: {"mean": self.values[t], "sd": self.sds[t]} for t in self.values},
                "pooled": self.pooled, "cochran_q": self.q, "df": self.df, "p": self.p,
                "worst_pair": list(self.worst_pair) if self.worst_pair else None,
                "worst_pair_combined_sd": self.worst_z, "agree": self.agree}


def agreement(quantity: str, values: Mapping[str, float], sds: Mapping[str, float]) -> Agreement | None:
    """Cochran's Q of the tests' estimates (None with fewer than two usable ones)."""
    from scipy.special import chdtrc  # the χ² survival function (scipy.stats costs seconds)

    use = [t for t in values if math.isfinite(values[t]) and math.isfinite(sds.get(t, math.nan))
           and sds[t] > 0]
    if len(use) < 2:
        return None
    x = np.array([values[t] for t in use])
    w = 1.0 / np.array([sds[t] for t in use]) ** 2
    pooled = float(np.sum(w * x) / np.sum(w))
    q = float(np.sum(w * (x - pooled) ** 2))
    df = len(use) - 1
    worst, worst_z = None, 0.0
    for a, b in combinations(use, 2):
        z = abs(values[a] - values[b]) / math.hypot(sds[a], sds[b])
        if z > worst_z:
            worst, worst_z = (a, b), z
    return Agreement(quantity, {t: float(values[t]) for t in use}, {t: float(sds[t]) for t in use},
                     pooled, q, df, float(chdtrc(df, q)), worst, float(worst_z))
