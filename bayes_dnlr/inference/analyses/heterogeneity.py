"""Do tests look like specimens of one material? The check made before a population pools them.

Each test i gives its E as a posterior mean m_i with sd σ_i. Specimens of one material differ a
little (the population's s_E), so "the tests differ beyond their own uncertainty" alone does not
mean several materials; three things are measured:

1. **Spread against the tests' own uncertainty** (the meta-analysis statistics): Cochran's
   Q = Σ w_i (m_i − m̄)², w_i = 1/σ_i², on K − 1 degrees of freedom, its p-value, I² = (Q − (K−1))/Q
   (the share of the spread that the tests' own uncertainty does not explain) and the
   DerSimonian-Laird moment estimate τ of the spread between specimens beyond it. When Q is within
   chance (p ≥ P_SPREAD) the tests agree within their uncertainty: the check passes.
2. **How large that spread is**: τ / m̄. Specimens of one material differ in E by a few per cent
   (ISO 527 round robins: 2-5 % within a laboratory); a spread above RELATIVE_SPREAD_MAX of the mean
   is more than one material's specimens show.
3. **Whether the tests fall into separate sets**: the best split of the sorted means into two sets
   (the one that explains the largest share R² of their sum of squares, 1-D k-means with k = 2),
   against the R² of K tests drawn from one normal population with the tests' own σ_i and the
   spread τ (a parametric bootstrap of N_SIM sets, seeded): p below P_SPLIT means sets that one
   normal population of specimens would rarely give (two materials, or outliers).

The check fails when the spread is significant (1) and either too large (2) or split (3); the tests
that stand out are the smaller set of the best split. ``between_groups`` is the same test (1)
between groups of tests labelled as different materials, each with its population mean and sd.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

P_SPREAD = 0.05              # Cochran's Q: a spread within chance at this level is no spread
RELATIVE_SPREAD_MAX = 0.10   # a spread between specimens above this share of E: not one material
P_SPLIT = 0.01               # the two-set split: rarer than this under one normal population
N_SIM = 4000                 # sets drawn for the split's p-value
MIN_TESTS = 3                # fewer tests: nothing to check


def weighted_spread(values: Sequence[float], sds: Sequence[float]) -> dict[str, Any]:
    """The weighted mean of ``values`` (weights 1/sd²), Cochran's Q on n − 1 degrees of freedom and
    its p-value, I² and the DerSimonian-Laird spread τ beyond the sds."""
    from scipy.stats import chi2

    m = np.asarray(values, float)
    w = 1.0 / np.asarray(sds, float) ** 2
    mean = float(w @ m / w.sum())
    q = float(w @ (m - mean) ** 2)
    dof = m.size - 1
    p = float(chi2.sf(q, dof)) if dof > 0 else 1.0
    i2 = max(0.0, (q - dof) / q) if q > 0 else 0.0
    c = float(w.sum() - (w @ w) / w.sum())
    tau = math.sqrt(max(0.0, (q - dof) / c)) if c > 0 else 0.0
    return {"weighted_mean": mean, "Q": q, "dof": dof, "p_value": p, "I2": i2, "tau": tau}


def _split_r2(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each row of ``x``: the largest share of the sum of squares that a split of the sorted
    values into two sets explains, and where it splits (the size of the lower set)."""
    x = np.sort(x, axis=-1)
    n = x.shape[-1]
    total = ((x - x.mean(axis=-1, keepdims=True)) ** 2).sum(axis=-1)
    low = np.cumsum(x, axis=-1)[..., :-1]
    k = np.arange(1, n)
    between = k * (n - k) / n * (low / k - (x.sum(axis=-1, keepdims=True) - low) / (n - k)) ** 2
    best = between.argmax(axis=-1)
    r2 = np.take_along_axis(between, best[..., None], axis=-1)[..., 0] / np.where(total > 0, total, 1.0)
    return r2, best + 1


def one_material(names: Sequence[str], means: Sequence[float], sds: Sequence[float],
                 labelled: bool = False, seed: int = 0) -> dict[str, Any]:
    """The check of the module doc for tests ``names`` with posterior means and sds of E: its
    figures, ``passed`` and ``stand_out`` (the names of the smaller set of the best split when it
    failed, in input order), and ``words`` for the page. ``labelled``: the tests are all labelled
    as one material (the words then do not ask for labels)."""
    names = [str(n) for n in names]
    m, s = np.asarray(means, float), np.asarray(sds, float)
    out: dict[str, Any] = {"between": "tests", "tests": len(names),
                           "limits": {"p_spread": P_SPREAD, "relative_spread_max": RELATIVE_SPREAD_MAX,
                                      "p_split": P_SPLIT}}
    if len(names) < MIN_TESTS:
        out.update(passed=None, stand_out=[], words=f"{len(names)} tests: too few to check whether "
                   "they look like one material.")
        return out
    spread = weighted_spread(m, s)
    relative = spread["tau"] / abs(spread["weighted_mean"]) if spread["weighted_mean"] else math.inf
    r2, cut = _split_r2(m)
    rng = np.random.default_rng(seed)
    sim = rng.normal(spread["weighted_mean"], np.sqrt(spread["tau"] ** 2 + s ** 2), (N_SIM, m.size))
    r2_sim, _ = _split_r2(sim)
    p_split = float((1 + np.sum(r2_sim >= r2)) / (N_SIM + 1))
    order = np.argsort(m, kind="stable")
    low, high = order[: int(cut)], order[int(cut):]
    sets = [{"tests": [names[i] for i in sorted(idx)], "mean": float(m[idx].mean())}
            for idx in (low, high)]
    significant = spread["p_value"] < P_SPREAD
    too_wide = significant and relative > RELATIVE_SPREAD_MAX
    split = significant and p_split < P_SPLIT
    passed = not (too_wide or split)
    small = min(sets, key=lambda g: (len(g["tests"]), -abs(g["mean"] - float(np.median(m)))))
    out.update(spread, relative_spread=relative, split={"r2": float(r2), "p_value": p_split,
                                                        "sets": sets},
               passed=passed, stand_out=[] if passed else list(small["tests"]))
    out["words"] = _words(out, significant, too_wide, split, sets, small, labelled)
    return out


def dof_text(dof: int) -> str:
    return f"{dof} degree{'s' if dof != 1 else ''} of freedom"


def p_text(p: float) -> str:
    """A p-value in words: ``p = 0.03``, ``p < 1e-10`` when it underflows."""
    return f"p = {p:.2g}" if p >= 1e-10 else "p < 1e-10"


def _words(c: dict[str, Any], significant: bool, too_wide: bool, split: bool,
           sets: list[dict[str, Any]], small: dict[str, Any], labelled: bool) -> str:
    spread = (f"Q = {c['Q']:.1f} on {dof_text(c['dof'])}, {p_text(c['p_value'])}, "
              f"I² = {100 * c['I2']:.0f} %")
    if not significant:
        return (f"The tests agree within their own uncertainty ({spread}): they look like one "
                "material.")
    size = (f"a spread between tests of τ = {c['tau']:.3g} MPa beyond their own uncertainty "
            f"({100 * c['relative_spread']:.1f} % of E; {spread})")
    if c["passed"]:
        return (f"The tests differ by {size}, as specimens of one material do (up to "
                f"{100 * RELATIVE_SPREAD_MAX:.0f} % of E), and do not fall into separate sets (best "
                f"split p = {c['split']['p_value']:.2g}): they look like one material.")
    why = []
    if too_wide:
        why.append(f"more than specimens of one material differ (up to {100 * RELATIVE_SPREAD_MAX:.0f} % "
                   "of E)")
    if split:
        why.append(f"they fall into two sets that one population of specimens would rarely give "
                   f"(R² = {c['split']['r2']:.3f}, {p_text(c['split']['p_value'])})")
    parts = " and ".join(f"{len(g['tests'])} test{'s' if len(g['tests']) != 1 else ''} around "
                         f"{g['mean']:.0f} MPa" for g in sets)
    advice = ("Check these tests (their data, their specimens, their own verdicts): a pooled E would "
              "describe none of the sets." if labelled else
              "Label each test's material (the config's material:, a manifest column material) and "
              "each material is pooled alone.")
    return (f"The tests do not look like one material: {size}: {' and '.join(why)}. The sets: {parts}; "
            f"standing out: {', '.join(small['tests'])}. {advice}")


def between_groups(groups: Mapping[str, tuple[float, float]]) -> dict[str, Any]:
    """Do groups of tests (each its population mean of E and that mean's sd) look like one
    material? Cochran's Q between them (``weighted_spread``); ``passed``: their means agree within
    their sds."""
    names = [str(g) for g in groups]
    out: dict[str, Any] = {"between": "groups", "groups": names, "limits": {"p_spread": P_SPREAD}}
    if len(names) < 2:
        out.update(passed=None, words="One group: nothing to compare.")
        return out
    spread = weighted_spread([v[0] for v in groups.values()], [v[1] for v in groups.values()])
    passed = spread["p_value"] >= P_SPREAD
    out.update(spread, passed=passed)
    figures = f"Q = {spread['Q']:.1f} on {dof_text(spread['dof'])}, {p_text(spread['p_value'])}"
    out["words"] = (f"The groups' E agree within their uncertainty ({figures}): they could be one "
                    "material." if passed else
                    f"The groups' E differ beyond their uncertainty ({figures}): each group is given "
                    "on its own, and no E spans them.")
    return out
