"""Do tests look like specimens of one material? The check made before a population pools them.

"One material" is decided by the package's one test of agreement (agreement.py): Cochran's Q of
the tests' own estimates of one quantity, at the level ``agreement.P_AGREE``. The quantity is the
one the package tells users to quote, E(t) at a time every test resolves, given by the caller
(workflows/population/run.py; E where no such time exists, and the words say so). The tests look
like one material when they agree within their own uncertainty. When they do not, they are not
called one material, however small their relative spread: specimens that differ beyond their
uncertainty (I² near 1) are not interchangeable, whether they are one material's specimens that
differ, several materials, or a test the model does not describe; the data alone cannot tell
those apart.

Beside the decision, for the words: the pair furthest apart, I² and τ, the spread beyond the sds
(agreement.py), and the best split of the sorted values into two sets (the one that explains the
largest share R² of their sum of squares, 1-D k-means with k = 2), whose smaller set "stands out".
The split only describes; it decides nothing. ``between_groups`` is the same test between groups
of tests labelled as different materials, each with its pooled value and that value's sd.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from bayes_dnlr.inference.analyses.agreement import P_AGREE, Agreement, agreement

MIN_TESTS = 2                # fewer tests: nothing to check


def split_r2(x: np.ndarray) -> tuple[float, int]:
    """The largest share of the sum of squares of ``x`` that a split of its sorted values into two
    sets explains, and where it splits (the size of the lower set)."""
    x = np.sort(np.asarray(x, float))
    n = x.size
    total = float(((x - x.mean()) ** 2).sum())
    low = np.cumsum(x)[:-1]
    k = np.arange(1, n)
    between = k * (n - k) / n * (low / k - (x.sum() - low) / (n - k)) ** 2
    best = int(between.argmax())
    return (float(between[best]) / total if total > 0 else 0.0), best + 1


def check_fields(a: Agreement) -> dict[str, Any]:
    """The test's figures as population.json keeps them (docs/population.md)."""
    return {"weighted_mean": a.pooled, "weighted_mean_sd": a.pooled_sd, "Q": a.q, "dof": a.df,
            "p_value": a.p, "I2": a.i2, "tau": a.tau,
            "relative_spread": a.tau / abs(a.pooled) if a.pooled else float("inf"),
            "random_effects": {"mean": a.re_mean, "sd": a.re_sd},
            "worst_pair": list(a.worst_pair), "worst_pair_combined_sd": a.worst_z}


def one_material(names: Sequence[str], means: Sequence[float], sds: Sequence[float],
                 labelled: bool = False, quantity: str = "E", note: str = "") -> dict[str, Any]:
    """The check of the module doc for tests ``names`` with their estimates (means and sds) of
    ``quantity``: its figures, ``passed`` and ``stand_out`` (the smaller set of the best split when
    it failed, in input order), and ``words`` for the page. ``labelled``: the tests are all labelled
    as one material (the words then do not ask for labels); ``note``: why ``quantity`` was chosen
    (said with the words: E where no time is resolved by every test)."""
    names = [str(n) for n in names]
    out: dict[str, Any] = {"between": "tests", "tests": len(names), "quantity": quantity,
                           "note": note or None, "limits": {"p_agree": P_AGREE}}
    m = np.asarray(means, float)
    a = agreement(quantity, dict(zip(names, m, strict=True)), dict(zip(names, sds, strict=True)))
    if len(names) < MIN_TESTS or a is None:
        out.update(passed=None, stand_out=[], words=f"{len(names)} test{'s' if len(names) != 1 else ''}"
                   f" with {quantity} and its sd: too few to check whether they look like one material.")
        return out
    out.update(check_fields(a), passed=a.agree, stand_out=[])
    if len(names) >= 3:
        r2, cut = split_r2(m)
        order = np.argsort(m, kind="stable")
        sets = [{"tests": [names[i] for i in sorted(idx)], "mean": float(m[idx].mean())}
                for idx in (order[:cut], order[cut:])]
        out["split"] = {"r2": r2, "sets": sets}
        if not a.agree:
            small = min(sets, key=lambda g: (len(g["tests"]), -abs(g["mean"] - float(np.median(m)))))
            out["stand_out"] = list(small["tests"])
    out["words"] = _words(a, out, labelled) + (f" ({note})" if note else "")
    return out


def _words(a: Agreement, c: dict[str, Any], labelled: bool) -> str:
    q = a.quantity
    if a.agree:
        return (f"The tests' {q} agree within their own uncertainty ({a.figures()}): they look like "
                "one material.")
    size = (f"τ = {a.tau:.3g} MPa beyond their own uncertainty, {100 * c['relative_spread']:.1f} % "
            f"of {q}")
    sets = ""
    if c.get("split"):
        parts = " and ".join(f"{len(g['tests'])} test{'s' if len(g['tests']) != 1 else ''} around "
                             f"{g['mean']:.0f} MPa" for g in c["split"]["sets"])
        sets = f" The best split into two sets: {parts}; standing out: {', '.join(c['stand_out'])}."
    advice = (" Specimens of one material that differ this much, or a test the model does not "
              "describe: check these tests (their data, their specimens, their own verdicts) before "
              "quoting a value for the material." if labelled else
              " Label each test's material (the config's material:, a manifest column material) and "
              "each material is pooled alone.")
    return (f"The tests' {q} differ beyond their own uncertainty ({a.figures()}; furthest apart: "
            f"{a.pair_text()}): they are not shown as one material ({size}).{sets}{advice}")


def between_groups(groups: Mapping[str, tuple[float, float]], quantity: str = "E",
                   note: str = "") -> dict[str, Any]:
    """Do groups of tests (each its pooled ``quantity`` and that value's sd) look like one
    material? The test of agreement between them; ``passed``: their values agree within their sds."""
    names = [str(g) for g in groups]
    out: dict[str, Any] = {"between": "groups", "groups": names, "quantity": quantity,
                           "note": note or None, "limits": {"p_agree": P_AGREE}}
    a = agreement(quantity, {k: v[0] for k, v in zip(names, groups.values(), strict=True)},
                  {k: v[1] for k, v in zip(names, groups.values(), strict=True)})
    if a is None:
        out.update(passed=None, words="One group: nothing to compare.")
        return out
    out.update(check_fields(a), passed=a.agree)
    out["words"] = ((f"The groups' {quantity} agree within their uncertainty ({a.figures()}): they "
                     "could be one material." if a.agree else
                     f"The groups' {quantity} differ beyond their uncertainty ({a.figures()}; furthest "
                     f"apart: {a.pair_text()}): each group is given on its own, and no value spans "
                     "them.") + (f" ({note})" if note else ""))
    return out
