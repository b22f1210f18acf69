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

The same modes answer a small sinusoidal strain ε0 e^{iωt} (a DMA, the harmonic load of a CSM
nanoindentation, an ultrasonic wave) with σ_j = p_j ε0 (3G + (E − 3G) iωτ_j/(1 + iωτ_j)) in the steady
state (eq. 10 with the relaxed state's 3G): the complex modulus E*(ω) = E' + iE'' of
``complex_modulus``, whose storage part rises from 3G to E as the modes freeze (ωτ_j ≫ 1).
"""

from __future__ import annotations

import numpy as np

from bayes_dnlr.model.spectrum import tau_scale, weights
from bayes_dnlr.vocabulary import UNIVERSAL_EXPONENT

SMALL_STRAIN_SLOPE = 3.0     # dε_HT/dε at ε = 0 (eq. 7)
FROZEN = 10.0                # ω τ_1 at or above this: (ωτ)²/(1 + (ωτ)²) >= 0.99 for every mode


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


def complex_modulus(frequency: np.ndarray | float, E: np.ndarray | float, G: np.ndarray | float,
                    tau_max: np.ndarray | float, alpha: np.ndarray | float = UNIVERSAL_EXPONENT,
                    modes: int = 50, decades: float = 6.0,
                    shift: np.ndarray | float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(E'(ω), E''(ω)) in MPa at the frequencies ``frequency`` (Hz, ω = 2π f): the linear response
    of the same modes as E(t) to a small sinusoidal strain ε0 e^{iωt} (module doc, eq. 10-14),

        E*(ω) = 3G + (E − 3G) Σ_j p_j iωτ_j / (1 + iωτ_j),
        E'  = 3G + (E − 3G) Σ_j p_j (ωτ_j)² / (1 + (ωτ_j)²),   E'' = (E − 3G) Σ_j p_j ωτ_j / (1 + (ωτ_j)²).

    E'(0) = 3G, E'(∞) = E. ``shift`` multiplies every τ_j (a shift factor of the time scale, such as
    a_T of another temperature; 1: the model's own). Shapes as ``relaxation_modulus``.
    """
    scalar = all(np.ndim(v) == 0 for v in (E, G, tau_max, alpha, shift))
    omega = 2.0 * np.pi * np.atleast_1d(np.asarray(frequency, dtype=float))
    E, G, tau, a, s = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float))
                                            for v in (E, G, tau_max, alpha, shift)))
    shape = tau_scale(modes, decades)
    p = spectrum_weights(a, modes, decades)                        # (k, modes)
    storage = np.empty((E.size, omega.size))
    loss = np.empty((E.size, omega.size))
    for i, w in enumerate(omega):
        x = w * (tau * s)[:, None] * shape[None, :]
        d = 1.0 + x * x
        storage[:, i] = np.sum(p * (x * x / d), axis=1)
        loss[:, i] = np.sum(p * (x / d), axis=1)
    delayed = (E - SMALL_STRAIN_SLOPE * G)[:, None]
    e1 = SMALL_STRAIN_SLOPE * G[:, None] + delayed * storage
    e2 = delayed * loss
    return (e1[0], e2[0]) if scalar else (e1, e2)


def storage_modulus(frequency: np.ndarray | float, E: np.ndarray | float, G: np.ndarray | float,
                    tau_max: np.ndarray | float, alpha: np.ndarray | float = UNIVERSAL_EXPONENT,
                    modes: int = 50, decades: float = 6.0, shift: np.ndarray | float = 1.0) -> np.ndarray:
    """E'(ω) (MPa) at ``frequency`` (Hz): ``complex_modulus``'s real part."""
    return complex_modulus(frequency, E, G, tau_max, alpha, modes, decades, shift)[0]


def loss_modulus(frequency: np.ndarray | float, E: np.ndarray | float, G: np.ndarray | float,
                 tau_max: np.ndarray | float, alpha: np.ndarray | float = UNIVERSAL_EXPONENT,
                 modes: int = 50, decades: float = 6.0, shift: np.ndarray | float = 1.0) -> np.ndarray:
    """E''(ω) (MPa) at ``frequency`` (Hz): ``complex_modulus``'s imaginary part."""
    return complex_modulus(frequency, E, G, tau_max, alpha, modes, decades, shift)[1]


def fastest_mode_product(frequency: float, tau_max: float, decades: float = 6.0,
                         shift: float = 1.0) -> float:
    """ω τ_1, the fastest mode's (τ_1 = τ_max 10^(−d), eq. 14): above FROZEN every mode is frozen
    at this frequency and E'(ω) is E itself (each mode keeps more than 99 % of its weight)."""
    return 2.0 * np.pi * float(frequency) * float(tau_max) * float(shift) * 10.0 ** (-float(decades))


def spectrum_weights(alpha: np.ndarray, modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """The weights p_j (eq. 12, p_j ∝ τ_j^alpha) for each alpha: shape (len(alpha), modes)."""
    alpha = np.atleast_1d(np.asarray(alpha, dtype=float))
    if np.all(alpha == alpha[0]):
        return np.broadcast_to(weights(modes, decades, float(alpha[0])), (alpha.size, modes))
    e = alpha[:, None] * np.log(tau_scale(modes, decades))[None, :]
    w = np.exp(e - e.max(axis=1, keepdims=True))
    return w / w.sum(axis=1, keepdims=True)
