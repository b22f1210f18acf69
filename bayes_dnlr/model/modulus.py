"""The relaxation modulus E(t) of the DNLR model: what a tensile curve determines.

A small strain step Δε applied at t = 0 from the unloaded state sets every mode to σ_j = p_j E Δε
(eq. 18 with ε̇ = Δε δ(t)); each then relaxes towards its share of the relaxed state,
p_j G ε_HT(Δε) ≈ 3 p_j G Δε (eq. 7: ε_HT = e^{2ε} − e^{−ε} ≈ 3ε). The stress per unit strain is

    E(t) = 3G + (E − 3G) Σ_j p_j exp(−t/τ_j)          (eq. 11-14, p_j ∝ τ_j^alpha)

so E(0) = E, the instantaneous modulus, and E(∞) = 3G. A constant-rate ramp's slope at strain ε is
close to E(ε/ε̇): a curve sampled every Δt over a duration T measures E(t) for t between a few Δt and
T, while E is E(t) extrapolated to t → 0 through the spectrum's fast end.

With a shift factor (model/shift.py) tau_max is the reference state's: E(t) at a temperature T is
the same curve with every tau_j multiplied by a_T(T) (``shift_factor``), and with a stress shift
it is the small-strain limit σ → 0, where a_σ = 1.
"""

from __future__ import annotations

import numpy as np

from bayes_dnlr.model.spectrum import tau_scale, weights
from bayes_dnlr.vocabulary import UNIVERSAL_EXPONENT

SMALL_STRAIN_SLOPE = 3.0     # dε_HT/dε at ε = 0 (eq. 7)


def relaxation_modulus(t: np.ndarray | float, E: np.ndarray | float, G: np.ndarray | float,
                       tau_max: np.ndarray | float, alpha: np.ndarray | float = UNIVERSAL_EXPONENT,
                       modes: int = 50, decades: float = 6.0,
                       shift_factor: np.ndarray | float = 1.0) -> np.ndarray:
    """E(t) (MPa) at the times ``t`` (s) for one parameter set or many.

    E, G, tau_max and alpha broadcast against each other (shape (k,) for k draws, or scalars);
    the result has shape (k, len(t)), or (len(t),) when every parameter is a scalar.
    ``shift_factor``: a_T at the temperature wanted (model/shift.py ``temperature_shift``), which
    multiplies tau_max (the reference temperature's); 1 there.
    """
    if np.any(np.asarray(shift_factor) != 1.0):
        tau_max = np.asarray(tau_max, dtype=float) * np.asarray(shift_factor, dtype=float)
    scalar = all(np.ndim(v) == 0 for v in (E, G, tau_max, alpha))
    times = np.atleast_1d(np.asarray(t, dtype=float))
    E, G, tau, a = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float))
                                         for v in (E, G, tau_max, alpha)))
    shape = tau_scale(modes, decades)
    p = spectrum_weights(a, modes, decades)                        # (k, modes)
    fast = np.empty((E.size, times.size))
    for i, ti in enumerate(times):
        fast[:, i] = np.sum(p * np.exp(-ti / (tau[:, None] * shape[None, :])), axis=1)
    out = SMALL_STRAIN_SLOPE * G[:, None] + (E - SMALL_STRAIN_SLOPE * G)[:, None] * fast
    return out[0] if scalar else out


def spectrum_weights(alpha: np.ndarray, modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """The weights p_j (eq. 12, p_j ∝ τ_j^alpha) for each alpha: shape (len(alpha), modes)."""
    alpha = np.atleast_1d(np.asarray(alpha, dtype=float))
    if np.all(alpha == alpha[0]):
        return np.broadcast_to(weights(modes, decades, float(alpha[0])), (alpha.size, modes))
    e = alpha[:, None] * np.log(tau_scale(modes, decades))[None, :]
    w = np.exp(e - e.max(axis=1, keepdims=True))
    return w / w.sum(axis=1, keepdims=True)
