"""Do estimates of one quantity agree? The package's one test of agreement: Cochran's Q with the
pair furthest apart, at one level, ``P_AGREE``.

Each estimate x_i comes with its sd s_i, and the estimates are independent (each test's own fit or
posterior uses only its data). If they estimate one value, Q = Σ w_i (x_i − x̄)², w_i = 1/s_i² and
x̄ their weighted mean, follows χ² with k − 1 degrees of freedom (Cochran 1954; the heterogeneity
test of a meta-analysis). They agree when Q is within its 1 − P_AGREE point. Beside the test:

- the pair furthest apart in combined sd, |x_i − x_j| / √(s_i² + s_j²): who disagrees most;
- I² = (Q − (k − 1))/Q: the share of the spread that the sds do not explain (Higgins & Thompson
  2002);
- τ, the DerSimonian-Laird moment estimate of the spread beyond the sds, and the random-effects
  mean Σ w*_i x_i / Σ w*_i, w*_i = 1/(s_i² + τ²), with its sd (Σ w*_i)^(-1/2): the pooled value
  whose sd holds the spread between the tests (the weighted mean and its sd when τ = 0).

Used by a joint run's ``consistency`` (runs/consistency.py), the check before pooling
(heterogeneity.py: the population and the batch) and ``compare`` (report/compare.py). The level,
its false alarms and its power: docs/thresholds.md, "The test of agreement".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from itertools import combinations

import numpy as np

P_AGREE = 0.01          # Cochran's Q above its 1 - P_AGREE point of χ²: the estimates disagree


@dataclass(frozen=True)
class Agreement:
    """One quantity over the tests: their values and sds, the pooled values, Cochran's Q."""

    quantity: str
    values: dict[str, float]
    sds: dict[str, float]
    pooled: float               # the weighted mean (weights 1/sd²)
    pooled_sd: float            # its sd, (Σ w)^(-1/2)
    q: float
    df: int
    p: float
    i2: float
    tau: float                  # DerSimonian-Laird spread beyond the sds
    re_mean: float              # the random-effects mean (weights 1/(sd² + τ²))
    re_sd: float
    worst_pair: tuple[str, str]
    worst_z: float              # that pair's distance in combined sd

    @property
    def agree(self) -> bool:
        return self.p >= P_AGREE

    def figures(self) -> str:
        """'Q = 13.0 on 3 degrees of freedom, p = 0.005, I² = 77 %'."""
        return f"Q = {self.q:.1f} on {dof_text(self.df)}, {p_text(self.p)}, I² = {100 * self.i2:.0f} %"

    def pair_text(self) -> str:
        """'a and b, 3.1 combined sd apart'."""
        a, b = self.worst_pair
        return f"{a} and {b}, {self.worst_z:.1f} combined sd apart"

    def to_dict(self) -> dict:
        return {"quantity": self.quantity,
                "tests": {t: {"mean": self.values[t], "sd": self.sds[t]} for t in self.values},
                "pooled": self.pooled, "pooled_sd": self.pooled_sd, "cochran_q": self.q,
                "df": self.df, "p": self.p, "I2": self.i2, "tau": self.tau,
                "random_effects": {"mean": self.re_mean, "sd": self.re_sd},
                "worst_pair": list(self.worst_pair), "worst_pair_combined_sd": self.worst_z,
                "level": P_AGREE, "agree": self.agree}


def agreement(quantity: str, values: Mapping[str, float],
              sds: Mapping[str, float]) -> Agreement | None:
    """The test of the module doc over the estimates with a finite value and a positive finite sd
    (None with fewer than two of them)."""
    from scipy.special import chdtrc  # the χ² survival function (scipy.stats costs seconds)

    use = [t for t in values if math.isfinite(values[t]) and math.isfinite(sds.get(t, math.nan))
           and sds[t] > 0]
    if len(use) < 2:
        return None
    x = np.array([values[t] for t in use], float)
    s = np.array([sds[t] for t in use], float)
    w = 1.0 / s**2
    pooled = float(np.sum(w * x) / np.sum(w))
    q = float(np.sum(w * (x - pooled) ** 2))
    df = len(use) - 1
    c = float(w.sum() - (w @ w) / w.sum())
    tau = math.sqrt(max(0.0, (q - df) / c)) if c > 0 else 0.0
    wr = 1.0 / (s**2 + tau**2)
    worst, worst_z = (use[0], use[1]), -1.0
    for a, b in combinations(use, 2):
        z = abs(values[a] - values[b]) / math.hypot(sds[a], sds[b])
        if z > worst_z:
            worst, worst_z = (a, b), z
    return Agreement(quantity, {t: float(values[t]) for t in use}, {t: float(sds[t]) for t in use},
                     pooled, float(w.sum() ** -0.5), q, df, float(chdtrc(df, q)),
                     max(0.0, (q - df) / q) if q > 0 else 0.0, tau,
                     float(np.sum(wr * x) / wr.sum()), float(wr.sum() ** -0.5), worst, float(worst_z))


def dof_text(dof: int) -> str:
    return f"{dof} degree{'s' if dof != 1 else ''} of freedom"


def p_text(p: float) -> str:
    """A p-value in words: ``p = 0.03``, ``p < 1e-10`` when it underflows."""
    return f"p = {p:.2g}" if p >= 1e-10 else "p < 1e-10"
