"""False alarms and power of the test that decides "one material" (inference/analyses/heterogeneity.py:
the one test of agreement, Cochran's Q at P_AGREE), beside the rule it replaced.

Synthetic estimates: K tests, each test's estimate x_i ~ Normal(θ_i, σ_i) with σ_i drawn uniform in
a band, the test told its σ_i (or a σ_i too small by a factor: posterior sds that are too narrow);
θ_i the true value of test i: one value (identical specimens), one material whose specimens differ
(θ_i ~ Normal(θ, s)), or two materials apart by a share of θ. Each row is the share of R replicates
in which the check says "not one material", for:

- new: the check as the package makes it (``heterogeneity.one_material``), and the same Q at 5 %;
- before: the rule it replaced (Q at 5 % and either τ above 10 % of the mean or a split into two
  sets rarer than 1 % under one normal population, by a parametric bootstrap of SPLIT_SIM sets;
  the package used 4000), written out here as it was.

    .venv/bin/python benchmarks/agreement.py [--replicates 2000] [--seed 0]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from bayes_dnlr.inference.analyses import heterogeneity  # noqa: E402
from bayes_dnlr.inference.analyses.agreement import P_AGREE  # noqa: E402

SPLIT_SIM = 1000


def _q(x: np.ndarray, s: np.ndarray) -> tuple[float, float, float]:
    w = 1 / s**2
    m = float(w @ x / w.sum())
    q = float(w @ (x - m) ** 2)
    c = float(w.sum() - (w @ w) / w.sum())
    return m, q, math.sqrt(max(0.0, (q - x.size + 1) / c)) if c > 0 else 0.0


def _split_r2(x: np.ndarray) -> np.ndarray:
    x = np.sort(x, axis=-1)
    n = x.shape[-1]
    total = ((x - x.mean(axis=-1, keepdims=True)) ** 2).sum(axis=-1)
    low = np.cumsum(x, axis=-1)[..., :-1]
    k = np.arange(1, n)
    between = k * (n - k) / n * (low / k - (x.sum(axis=-1, keepdims=True) - low) / (n - k)) ** 2
    return between.max(axis=-1) / np.where(total > 0, total, 1.0)


def before(x: np.ndarray, s: np.ndarray, rng: np.random.Generator) -> bool:
    """The rule before: fails when Q is significant at 5 % and (τ > 10 % of the mean or the best
    split's R² is rarer than 1 % among SPLIT_SIM sets drawn from Normal(mean, √(τ² + σ²)))."""
    from scipy.stats import chi2

    if x.size < 3:
        return False
    m, q, tau = _q(x, s)
    if chi2.sf(q, x.size - 1) >= 0.05:
        return False
    if tau / abs(m) > 0.10:
        return True
    sim = rng.normal(m, np.sqrt(tau**2 + s**2), (SPLIT_SIM, x.size))
    p = (1 + np.sum(_split_r2(sim) >= _split_r2(x[None])[0])) / (SPLIT_SIM + 1)
    return p < 0.01


def new(x: np.ndarray, s: np.ndarray) -> tuple[bool, float]:
    """The check's decision (fails: True) and its p-value."""
    c = heterogeneity.one_material([str(i) for i in range(x.size)], x, s)
    return c["passed"] is False, c["p_value"]


def scenario(rng, reps: int, k: list[int], theta: list[float], sd_band: tuple[float, float],
             spread: float = 0.0, told: float = 1.0) -> tuple[float, float, float]:
    """Shares of ``reps`` replicates that fail the new rule, the same test at 5 %, and the rule
    before: groups of ``k`` tests around the true values ``theta`` (one per group), specimen spread
    ``spread`` (share of θ), σ_i uniform in ``sd_band`` (shares of θ), each test told σ_i ×
    ``told``."""
    fired_new = fired_5 = fired_old = 0
    for _ in range(reps):
        th = np.concatenate([np.full(n, t) for n, t in zip(k, theta, strict=True)])
        th = th * (1 + spread * rng.standard_normal(th.size))
        s = th * rng.uniform(*sd_band, th.size)
        x = th + s * rng.standard_normal(th.size)
        fails, p = new(x, s * told)
        fired_new += fails
        fired_5 += p < 0.05
        fired_old += before(x, s * told, rng)
    return fired_new / reps, fired_5 / reps, fired_old / reps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--replicates", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    r = args.replicates
    t0 = time.perf_counter()
    et, e = (0.002, 0.02), (0.008, 0.02)      # σ_i: E(t) (0.2-2 % of it), E (0.8-2 %: 20-50 MPa at 2500)
    rows = [
        ("identical specimens, σ 0.8-2 %", [[2], [3], [4], [8], [15]], [1.0], e, 0.0, 1.0),
        ("identical specimens, σ told 0.8× the true one", [[3], [8]], [1.0], e, 0.0, 0.8),
        ("identical specimens, σ told 0.5× the true one", [[3], [8]], [1.0], e, 0.0, 0.5),
        ("one material, specimens differ by s = 0.5 σ̄", [[3], [8]], [1.0], e, 0.007, 1.0),
        ("one material, specimens differ by s = 1 σ̄", [[3], [8]], [1.0], e, 0.014, 1.0),
        ("one material, specimens 4 % apart (s = 100 MPa at 2500), σ 20-50 MPa", [[4], [8], [15]],
         [1.0], e, 0.04, 1.0),
        ("I² ≈ 0.98: E(t) 2 % apart, σ 0.1-0.3 %", [[3], [5]], [1.0], (0.001, 0.003), 0.02, 1.0),
        ("two materials 40 % apart, 3 + 3, σ 0.8-2 %", [[3, 3]], [1.0, 1.67], e, 0.02, 1.0),
        ("two materials 10 % apart, 5 + 5, s 2.4 %, σ 0.8-2 %", [[5, 5]], [1.0, 1.1], e, 0.024, 1.0),
        ("two materials 5 % apart, 5 + 5, s 2.4 %, σ 0.8-2 %", [[5, 5]], [1.0, 1.05], e, 0.024, 1.0),
        ("two materials 5 % apart, 3 + 3, σ 0.8-2 %", [[3, 3]], [1.0, 1.05], e, 0.0, 1.0),
        ("two materials 2 % apart, 3 + 3, σ 0.8-2 %", [[3, 3]], [1.0, 1.02], e, 0.0, 1.0),
        ("two materials 2 % apart, 3 + 3, σ 0.2-2 % (E(t))", [[3, 3]], [1.0, 1.02], et, 0.0, 1.0),
        ("two materials 1 % apart, 3 + 3, σ 0.2-2 % (E(t))", [[3, 3]], [1.0, 1.01], et, 0.0, 1.0),
        ("two materials 1 % apart, 2 + 1, σ 0.2-2 % (E(t))", [[2, 1]], [1.0, 1.01], et, 0.0, 1.0),
    ]
    print(f"'not one material' in {r} replicates each; new: Cochran's Q at {P_AGREE}; before: the "
          f"rule it replaced (split by {SPLIT_SIM} bootstrap sets)\n")
    print(f"| case | tests | new (Q at {P_AGREE}) | Q at 0.05 | before |")
    print("|---|---|---|---|---|")
    for label, ks, theta, band, spread, told in rows:
        for k in ks:
            reps = r if sum(k) <= 8 else r // 2
            fn, f5, fo = scenario(rng, reps, k, theta, band, spread, told)
            tests = " + ".join(map(str, k))
            old = "–" if sum(k) < 3 else f"{100 * fo:.1f} %"
            print(f"| {label} | {tests} | {100 * fn:.1f} % | {100 * f5:.1f} % | {old} |", flush=True)
    print(f"\n{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
