"""Initial guesses from the physics of the test (paper section 4.1) and the multi-start design.

Physics start:
- E from the initial slope of the stress-strain curve (a quadratic through the first samples up to a
  quarter of the early peak stress, so the curvature of the viscoelastic rise does not bias the slope).
- tau_max from the rise of the curve by the rule of tangents: the initial tangent σ = E ε meets the
  asymptote of the curve at ε_c; for a ramp ε̇ on the DNLR spectrum the plateau overstress is
  E ε̇ Σ p_j tau_j = E ε̇ m tau_max (m = Σ p_j tau_j / tau_max ≈ 1/3 for 6 decades), so
  tau_max ≈ ε_c / (m ε̇) (the paper's "decaying strain of 0.04, a typical time of about 8 s").
- G from the slope of σ against ε_HT (eq. 7) at large strain (the paper's "visual" 110/50), the
  intercept giving the asymptote used above.
- sigma_inf from the end of the hold, tau_max_R from the time the relaxation takes to cover 1 - 1/e
  of its drop (divided by m, as for tau_max).
- alpha, the spectrum's exponent (when it is free), starts at Cunat's ½ (eq. 12), the value the
  guesses above assume (``SPECTRUM_START``).

Multi-start: starts spread over the prior box (stratified, Latin-hypercube pairing), log-spaced
for log-uniform / log-normal priors and for time constants whose box spans more than a decade.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from bayes_dnlr.config import ParameterSpec
from bayes_dnlr.data.conversions import haward_thackray_strain
from bayes_dnlr.model import tau_scale, weights
from bayes_dnlr.vocabulary import TIME_CONSTANTS, UNIVERSAL_EXPONENT

SPECTRUM_START = {"alpha": (UNIVERSAL_EXPONENT, "Cunat's universal spectrum (eq. 12)")}

SD_SPAN = 3.0  # normal / log-normal priors without truncation: starts within ±3 sd


def spectrum_mean(modes: int = 50, decades: float = 6.0) -> float:
    """m = Σ p_j tau_j / tau_max: the mean relaxation time of the spectrum in units of tau_max."""
    return float(np.sum(weights(modes, decades) * tau_scale(modes, decades)))


def _initial_slope(strain: np.ndarray, stress: np.ndarray) -> float | None:
    """Slope at the origin: quadratic fit on the first samples up to 1/4 of the early peak."""
    de = strain - strain[0]
    ds = stress - stress[0]
    early = de <= min(0.25, de.max())
    peak = np.max(ds[early]) if early.any() else np.max(ds)
    if not peak > 0:
        return None
    n = int(np.argmax(ds >= 0.25 * peak)) + 1
    n = min(max(n, 6), de.size)
    x, y = de[:n], ds[:n]
    if n < 3 or np.ptp(x) <= 0:
        return None
    deg = 2 if n >= 6 else 1
    coef = np.polynomial.polynomial.polyfit(x, y, deg)
    slope = float(coef[1])
    return slope if np.isfinite(slope) and slope > 0 else None


def physics_start(time: np.ndarray, strain: np.ndarray, stress: np.ndarray,
                  relaxation_start: float | None, strain_rate: float,
                  modes: int = 50, decades: float = 6.0) -> tuple[dict[str, float], dict[str, str]]:
    """Physics-based guesses (paper 4.1) from the samples the model runs over.

    Returns the guesses (only those that could be derived) and a note per guess saying how.
    """
    time = np.asarray(time, dtype=float)
    strain = np.asarray(strain, dtype=float)
    stress = np.asarray(stress, dtype=float)
    m = spectrum_mean(modes, decades)
    tensile = np.ones(time.size, dtype=bool) if relaxation_start is None else time <= relaxation_start
    et, st = strain[tensile], stress[tensile]
    guess: dict[str, float] = {}
    note: dict[str, str] = {}
    if et.size < 3:
        return guess, note

    E0 = _initial_slope(et, st)
    if E0 is not None:
        guess["E"] = E0
        note["E"] = "initial slope of the stress-strain curve"

    span = et.max() - et[0]
    asymptote = None
    if span >= 0.4:
        large = et >= et[0] + 0.6 * span
        h = haward_thackray_strain(et[large])
        if large.sum() >= 3 and np.ptp(h) > 0:
            slope, intercept = np.polynomial.polynomial.polyfit(h, st[large], 1)[::-1]
            if np.isfinite(slope):
                guess["G"] = float(max(slope, 0.0))
                note["G"] = "slope of stress vs eps_HT at large strain"
                asymptote = float(intercept - stress[0])
    if asymptote is None or not asymptote > 0:
        asymptote = float(np.max(st) - stress[0])     # the yield plateau when hardening is not seen
    if E0 is not None and asymptote > 0 and strain_rate > 0:
        eps_c = asymptote / E0
        guess["tau_max"] = eps_c / (m * strain_rate)
        note["tau_max"] = f"rule of tangents: decaying strain {eps_c:.3g} / (m·rate), m = {m:.3f}"

    if relaxation_start is not None:
        hold = time > relaxation_start
        if hold.sum() >= 5:
            th, sh = time[hold], stress[hold]
            tail = max(3, sh.size // 10)
            s_inf = float(np.mean(sh[-tail:]))
            guess["sigma_inf"] = s_inf
            note["sigma_inf"] = "mean stress over the last tenth of the hold"
            s_r = float(stress[np.flatnonzero(hold)[0] - 1])
            drop = s_r - s_inf
            if drop > 0:
                below = np.flatnonzero(sh - s_inf <= drop / np.e)
                t_e = (th[below[0]] if below.size else th[-1]) - relaxation_start
                if t_e > 0:
                    guess["tau_max_R"] = float(t_e / m)
                    note["tau_max_R"] = "time to relax 1 - 1/e of the drop, / m"
    return guess, note


def box(spec: ParameterSpec) -> tuple[float, float, bool]:
    """Range the starts are spread over, and whether it is log-spaced.

    The prior support (truncation), capped to ±3 sd for normal and log-normal priors and to
    [scale/100, 3 scale] for a half-normal one.
    """
    lo, hi = spec.bounds()
    kind = spec.prior
    if kind == "normal":
        lo = max(lo, spec.mean - SD_SPAN * spec.sd)   # type: ignore[operator]
        hi = min(hi, spec.mean + SD_SPAN * spec.sd)   # type: ignore[operator]
    elif kind == "log-normal":
        lo = max(lo, spec.median * np.exp(-SD_SPAN * spec.sd_log))  # type: ignore[operator]
        hi = min(hi, spec.median * np.exp(SD_SPAN * spec.sd_log))   # type: ignore[operator]
    elif kind == "half-normal":
        lo = max(lo, 0.0)
        hi = min(hi, SD_SPAN * spec.scale)            # type: ignore[operator]
    log = kind in ("log-uniform", "log-normal")
    return float(lo), float(hi), log


def spread_starts(specs: Mapping[str, ParameterSpec], names: Sequence[str], n: int,
                  seed: int = 0, time_span: tuple[float, float] | None = None) -> np.ndarray:
    """``n`` starts (n, p) spread over the prior box of each parameter in ``names``.

    Stratified: start k sits at quantile (k + 1/2)/n of the box of each parameter; the strata are
    paired across parameters by a fixed random permutation (Latin hypercube), so every start differs
    in every parameter. Time constants are log-spaced when the box spans more than one decade.
    ``time_span`` = (sampling step, test duration) caps the box of the time constants to
    [step, 10 x duration]: outside it every mode is relaxed within a step, or frozen over the whole
    test, and the model does not depend on the time constant (a flat criterion, not a start).
    """
    rng = np.random.default_rng(seed)
    q = (np.arange(n) + 0.5) / n
    out = np.empty((n, len(names)))
    for j, k in enumerate(names):
        lo, hi, log = box(specs[k])
        if k in TIME_CONSTANTS and time_span is not None:
            c_lo, c_hi = time_span[0], 10.0 * time_span[1]
            if max(lo, c_lo) < min(hi, c_hi):
                lo, hi = max(lo, c_lo), min(hi, c_hi)
        if k in TIME_CONSTANTS and lo > 0 and hi / lo > 10.0:
            log = True
        if log and lo <= 0:
            lo = hi * 1e-6
        if log:
            vals = np.exp(np.log(lo) + q * (np.log(hi) - np.log(lo)))
        else:
            vals = lo + q * (hi - lo)
        out[:, j] = vals if j == 0 else rng.permutation(vals)
    return out


def clip_to(spec: ParameterSpec, value: float) -> float:
    """A guess moved inside the prior support (strictly, for time constants)."""
    lo, hi = spec.bounds()
    if lo >= 0 and value <= lo:
        value = lo * 1.01 if lo > 0 else value
    return float(min(max(value, lo), hi))


def fallback(spec: ParameterSpec, name: str) -> float:
    """A start when physics gives none: the centre of the box (geometric for time constants)."""
    lo, hi, log = box(spec)
    if (log or name in TIME_CONSTANTS) and lo > 0:
        return float(np.sqrt(lo * hi))
    if log and lo <= 0:
        return float(hi * 1e-3)
    return float(0.5 * (lo + hi))
