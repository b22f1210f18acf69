"""Richer generating models for synthetic tests: data made by a model the package does not fit.

The fitted model is the reduced DNLR model of section 3.1 with its two entry points fixed: Cunat's
universal spectrum p_j ∝ tau_j^½ (eq. 12) and the Haward-Thackray relaxed state σ^r = G ε_HT
(eq. 16-17), driven by the strain the file reports. ``truth.model_form`` replaces one of these
assumptions in ``simulate`` by a richer one, E staying the instantaneous modulus (the weights of
all modes sum to 1, eq. 11), so that a fit can be judged against the true E:

Kinds, each with its strength parameter and the values "mild" and "strong" stand for:

- ``spectrum-power``, alpha (mild 0.4, strong 0.3): p_j ∝ tau_j^alpha (eq. 12 has ½);
- ``spectrum-lognormal``, width (0.6, 0.3 decades): p_j ∝ exp(-(log10 tau_j - c)²/(2 width²)),
  c the mean log10 tau of eq. 12's weights: a peaked spectrum, outside the power family;
- ``spectrum-two-slope``, alpha_short (0.3, 0.1): p_j ∝ tau_j^alpha_short below tau_max/10^1.5,
  tau_j^½ above, continuous at the knee;
- ``hardening-langevin``, segments (100, 25): σ^r of eq. 15 (eight-chain network of n segments),
  scaled to the slope G at ε = 0: stiffer than eq. 16 at large strain;
- ``strain-toe``, slack (1e-3, 4e-3): measured strain = specimen's + slack (1 - exp(-ε/slack)),
  a seating toe;
- ``strain-drift``, drift (0.02, 0.05): measured strain = specimen's + drift ε_max (t/t_end)²;
- ``two-process``, weight (0.03, 0.1): a second spectrum of eq. 12-14's shape, its tau_max and
  tau_max_R SLOW_RATIO (30) times the test's, holding ``weight`` of E.

The stress is computed here, by a plain numpy exponential integrator (exact for inputs linear
between samples, as the package's kernel), independent of the fitted model's code: with the
trivial form (alpha = ½, one process, Haward-Thackray, exact strain) it reproduces
``bayes_dnlr.model.simulate`` to rounding, which the tests check.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

LN10 = float(np.log(10.0))
SLOW_RATIO = 30.0        # two-process: the second spectrum's time scale relative to the first
KNEE_DECADES = 1.5       # spectrum-two-slope: the knee lies this many decades below tau_max

# kind -> (name of the strength parameter, {"mild": value, "strong": value})
KINDS: dict[str, tuple[str, dict[str, float]]] = {
    "spectrum-power": ("alpha", {"mild": 0.4, "strong": 0.3}),
    "spectrum-lognormal": ("width", {"mild": 0.6, "strong": 0.3}),
    "spectrum-two-slope": ("alpha_short", {"mild": 0.3, "strong": 0.1}),
    "hardening-langevin": ("segments", {"mild": 100.0, "strong": 25.0}),
    "strain-toe": ("slack", {"mild": 1e-3, "strong": 4e-3}),
    "strain-drift": ("drift", {"mild": 0.02, "strong": 0.05}),
    "two-process": ("weight", {"mild": 0.03, "strong": 0.1}),
}


def strength_value(kind: str, strength: str | float) -> float:
    """The kind's strength parameter: a number as given, or the value of "mild" / "strong"."""
    if kind not in KINDS:
        raise ValueError(f"unknown model form {kind!r}; expected one of {', '.join(KINDS)}")
    if isinstance(strength, str):
        levels = KINDS[kind][1]
        if strength not in levels:
            raise ValueError(f"strength {strength!r}: expected mild, strong or a number")
        return levels[strength]
    return float(strength)


def _log10_shape(modes: int, decades: float) -> np.ndarray:
    """log10(tau_j / tau_max) of eq. 14."""
    if modes == 1:
        return np.zeros(1)
    j = np.arange(1, modes + 1)
    return -(modes - j) / (modes - 1) * decades


def _normalised(w: np.ndarray) -> np.ndarray:
    return w / w.sum()


def spectrum_weights(kind: str, value: float, modes: int, decades: float) -> np.ndarray:
    """The weights p_j of a spectrum of another shape on the grid of eq. 14 (they sum to 1)."""
    u = _log10_shape(modes, decades)
    if kind == "spectrum-power":
        return _normalised(np.exp(value * LN10 * u))
    if kind == "spectrum-lognormal":
        if not value > 0:
            raise ValueError(f"spectrum-lognormal: width must be > 0 decades, got {value}")
        centre = float(np.sum(_normalised(np.exp(0.5 * LN10 * u)) * u))
        return _normalised(np.exp(-0.5 * ((u - centre) / value) ** 2))
    if kind == "spectrum-two-slope":
        knee = -KNEE_DECADES
        expo = np.where(u < knee, value * (u - knee), 0.5 * (u - knee))
        return _normalised(np.exp(LN10 * expo))
    return _normalised(np.exp(0.5 * LN10 * u))


def langevin_factor(strain: np.ndarray, segments: float) -> np.ndarray:
    """(√n/(3λc)) L⁻¹(λc/√n) of eq. 15 divided by its value at ε = 0: 1 at small strain, growing
    towards the network's locking stretch. λc = √((e^{2ε} + 2e^{-ε})/3), the chain stretch of the
    eight-chain cell in incompressible uniaxial tension; L⁻¹(x) ≈ x(3 - x²)/(1 - x²) (Cohen's
    Padé approximant)."""
    n = float(segments)
    lam = np.sqrt((np.exp(2.0 * strain) + 2.0 * np.exp(-strain)) / 3.0)

    def f(lc: np.ndarray) -> np.ndarray:
        x = lc / np.sqrt(n)
        if np.any(x >= 1.0):
            raise ValueError(f"hardening-langevin: the chain stretch reaches the locking stretch "
                             f"√n = {np.sqrt(n):.3g} (n = {n:g} segments is too few for strain "
                             f"{float(np.max(strain)):.3g})")
        return np.sqrt(n) / (3.0 * lc) * x * (3.0 - x * x) / (1.0 - x * x)

    return f(lam) / f(np.ones(1))[0]


def haward_thackray(strain: np.ndarray) -> np.ndarray:
    """ε_HT = exp(2ε) - exp(-ε) (eq. 7-8)."""
    return np.exp(2.0 * strain) - np.exp(-strain)


@dataclass(frozen=True)
class Process:
    """One relaxation process: its share of E, the weights of its modes (summing to 1) and the
    times tau_j/tau_max; its tau_max is ``ratio`` times the test's (both phases)."""

    share: float
    weights: np.ndarray
    shape: np.ndarray
    ratio: float = 1.0


def integrate(time: np.ndarray, strain: np.ndarray, relaxed: np.ndarray, params: Mapping[str, float],
              processes: tuple[Process, ...], relaxation_start: float | None) -> np.ndarray:
    """Stress of modes dσ_j/dt = P_j E dε/dt - (σ_j - P_j σ^r)/tau_j (eq. 10), P_j = share·p_j,
    for the specimen strain ``strain`` and σ^r = G·``relaxed`` (tensile) or sigma_inf (after
    ``relaxation_start``), inputs linear between samples. With D_j = σ_j - P_j σ^r and a step Δ:
    D_j <- a D_j + P_j tau_j (1 - a)/Δ (E Δε - Δσ^r), a = exp(-Δ/tau_j); σ = σ^r + Σ D_j."""
    t = np.asarray(time, dtype=float)
    e = np.asarray(strain, dtype=float)
    P = np.concatenate([pr.share * pr.weights for pr in processes])
    shape = np.concatenate([pr.ratio * pr.shape for pr in processes])
    E, G = float(params["E"]), float(params["G"])
    switch = np.inf if relaxation_start is None else float(relaxation_start)
    s_r = G * np.asarray(relaxed, dtype=float)
    out = np.empty(t.size)
    out[0] = s_r[0]
    D = np.zeros(P.size)
    relaxing = False
    for i in range(t.size - 1):
        dt = t[i + 1] - t[i]
        if not relaxing and t[i + 1] > switch:
            relaxing = True
            s_inf = float(params["sigma_inf"])
            D += P * (s_r[i] - s_inf)         # σ_j continuous, σ^r jumps to sigma_inf
        if relaxing:
            tau = float(params["tau_max_R"]) * shape
            d_sr, sr1 = 0.0, s_inf
        else:
            tau = float(params["tau_max"]) * shape
            d_sr, sr1 = s_r[i + 1] - s_r[i], s_r[i + 1]
        x = dt / tau
        a = np.exp(-np.minimum(x, 700.0))
        c = -np.expm1(-x) / x
        D = a * D + P * c * (E * (e[i + 1] - e[i]) - d_sr)
        out[i + 1] = sr1 + D.sum()
    return out


@dataclass(frozen=True)
class Generated:
    """A synthetic test of a richer model: the true stress and the strain the file reports."""

    stress: np.ndarray
    measured_strain: np.ndarray


def generate(time: np.ndarray, strain: np.ndarray, params: Mapping[str, float],
             relaxation_start: float | None, kind: str | None, strength: str | float = "mild",
             modes: int = 50, decades: float = 6.0) -> Generated:
    """True stress and measured strain of a test whose specimen follows ``strain`` (Hencky),
    under the model form ``kind`` (None: the fitted model, eq. 12 and 16-17, computed here)."""
    t = np.asarray(time, dtype=float)
    e = np.asarray(strain, dtype=float)
    value = strength_value(kind, strength) if kind is not None else 0.5
    relaxed = haward_thackray(e)
    measured = e.copy()
    processes = linear_processes(kind, strength, modes, decades)
    if kind == "hardening-langevin":
        relaxed = relaxed * langevin_factor(e, value)
    elif kind == "strain-toe":
        if not value > 0:
            raise ValueError(f"strain-toe: slack must be > 0, got {value}")
        measured = e + value * -np.expm1(-np.maximum(e, 0.0) / value)
    elif kind == "strain-drift":
        span = t[-1] - t[0]
        measured = e + value * float(np.max(e)) * ((t - t[0]) / span) ** 2
    stress = integrate(t, e, relaxed, params, processes, relaxation_start)
    return Generated(stress, measured)


def linear_processes(kind: str | None, strength: str | float = "mild", modes: int = 50,
                     decades: float = 6.0) -> tuple[Process, ...]:
    """The processes of the specimen's linear response under the model form ``kind`` (None: eq.
    12). The strain kinds (toe, drift) change what the file reports, not the specimen, and the
    Langevin hardening has the slope G at ε = 0, so theirs are the fitted model's form."""
    value = strength_value(kind, strength) if kind is not None else 0.5
    shape = 10.0 ** _log10_shape(modes, decades)
    base = spectrum_weights("", 0.5, modes, decades)
    if kind is not None and kind.startswith("spectrum-"):
        return (Process(1.0, spectrum_weights(kind, value, modes, decades), shape),)
    if kind == "two-process":
        if not 0.0 < value < 1.0:
            raise ValueError(f"two-process: weight must lie in (0, 1), got {value}")
        return (Process(1.0 - value, base, shape), Process(value, base, shape, SLOW_RATIO))
    return (Process(1.0, base, shape),)


def relaxation_modulus(t: np.ndarray | float, params: Mapping[str, float], kind: str | None,
                       strength: str | float = "mild", modes: int = 50,
                       decades: float = 6.0) -> np.ndarray:
    """The specimen's relaxation modulus E(t) under the model form ``kind`` (None: eq. 12):
    3G + (E − 3G) Σ P_j exp(−t/τ_j) over every process's modes (model/modulus.py)."""
    times = np.atleast_1d(np.asarray(t, dtype=float))
    E, G, tau = float(params["E"]), float(params["G"]), float(params["tau_max"])
    fast = sum(pr.share * np.exp(-times[:, None] / (tau * pr.ratio * pr.shape[None, :])) @ pr.weights
               for pr in linear_processes(kind, strength, modes, decades))
    return 3.0 * G + (E - 3.0 * G) * fast


def complex_modulus(frequency: np.ndarray | float, params: Mapping[str, float], kind: str | None,
                    strength: str | float = "mild", modes: int = 50,
                    decades: float = 6.0) -> tuple[np.ndarray, np.ndarray]:
    """The specimen's (E'(ω), E''(ω)) at ``frequency`` (Hz) under the model form ``kind``: the
    steady response of every process's modes to a small sinusoidal strain (model/modulus.py)."""
    omega = 2.0 * np.pi * np.atleast_1d(np.asarray(frequency, dtype=float))
    E, G, tau = float(params["E"]), float(params["G"]), float(params["tau_max"])
    storage = np.zeros(omega.size)
    loss = np.zeros(omega.size)
    for pr in linear_processes(kind, strength, modes, decades):
        x = omega[:, None] * (tau * pr.ratio * pr.shape[None, :])
        storage += pr.share * (x * x / (1.0 + x * x)) @ pr.weights
        loss += pr.share * (x / (1.0 + x * x)) @ pr.weights
    return 3.0 * G + (E - 3.0 * G) * storage, (E - 3.0 * G) * loss
