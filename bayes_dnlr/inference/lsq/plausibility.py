"""Checks of an optimum against physics and plain words for a fit that cannot be analysed.

``plausibility_warnings``: estimates the DNLR model allows but a material does not. The relaxed
state of the tensile phase is σ_r = G ε_HT(ε) with ε_HT = exp(2ε) - exp(-ε) ≈ 3ε (eq. 7, 17), so
3G is the relaxed (long-time) modulus at small strain, and E the instantaneous one (eq. 18): a
viscoelastic solid relaxes from E towards a lower modulus, 3G < E.

``singular_message``: why the sensitivity matrix X (eq. 22) has no inverse at the optimum, naming
the parameters in the direction the data do not inform and those on a bound of their prior.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from bayes_dnlr.vocabulary import fixing


def plausibility_warnings(params: Mapping[str, float], estimate: str = "white least squares") -> list[str]:
    """Warnings for physically impossible estimates (never errors: the data decide, the user reads);
    ``estimate``: which estimate ``params`` are, said beside the numbers."""
    out: list[str] = []
    e, g = params.get("E"), params.get("G")
    if e is not None and g is not None and e > 0 and 3.0 * g > e:
        out.append(
            f"3G = {3.0 * g:.4g} MPa exceeds E = {e:.4g} MPa ({estimate}): the relaxed modulus at small "
            "strain (3G, the slope of G·ε_HT, eq. 7 and 17) above the instantaneous one (E, eq. 18) is "
            "physically impossible (a viscoelastic solid relaxes from E towards a lower modulus). Wide "
            "priors let the optimum land there when E, G and tau_max trade off on the window; if the data "
            "demand it, the model does not describe this test (a toe, a preload, stiffening). Bound G "
            f"(parameters.G.high below E/3, about {e / 3.0:.3g} MPa) and compare the residuals, or "
            "widen the window")
    return out


def singular_message(X: np.ndarray, names: Sequence[str], values: Sequence[float],
                     on_bound: Mapping[str, str], bounds: Mapping[str, tuple[float, float]]) -> str:
    """The error for a sensitivity matrix with no inverse at the optimum, in words."""
    X = np.asarray(X, dtype=float)
    norms = np.linalg.norm(X, axis=0)
    text = "the sensitivity matrix X (eq. 22) is singular at the optimum"
    involved: list[str] = []
    if np.all(norms > 0) and np.all(np.isfinite(X)):
        _, sv, vt = np.linalg.svd(X / norms, full_matrices=False)
        v = np.abs(vt[-1])
        involved = [names[j] for j in np.argsort(-v) if v[j] >= 0.3]
        text += f" (singular values of the column-normalised X: {', '.join(f'{x:.3g}' for x in sv)})"
    text += f": the free parameters {list(names)} cannot all be identified on this window"
    if involved:
        vals = dict(zip(names, values, strict=True))
        text += (f"; the data do not inform the combination of {', '.join(involved)}: fix one of them "
                 f"at a value another test measures (as {fixing(involved[0], vals[involved[0]])}, where "
                 "this fit ends) or widen data.window")
    if on_bound:
        vals = dict(zip(names, values, strict=True))
        parts = []
        for k, side in on_bound.items():
            b = bounds[k][0 if side == "lower" else 1]
            parts.append(f"{k} = {b:g} (its {side} bound)")
        text += (f". Even with {', '.join(parts)} held there, the others are not identified"
                 if len(parts) else "")
        text += "; " + ", ".join(f"{k} = {vals[k]:.6g}" for k in on_bound) + " at the optimum"
    return text
