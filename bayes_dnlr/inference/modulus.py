"""E(t), the relaxation modulus of the identified model (model/modulus.py), as a result: at which
times a test resolves it, its value from posterior draws or linearized from a fit, and which samples
of the test carry its information.

A constant-rate loading's slope at strain ε is close to E(ε/ε̇): the data measure E(t) from the time
a few sampling steps into the first loading to the end of the window. E itself, E(t → 0), lies
before that: the spectrum's fast end, which the data never see, carries it there (eq. 12-14).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.inference.mcmc import ess
from bayes_dnlr.model.modulus import SMALL_STRAIN_SLOPE, relaxation_modulus, spectrum_weights
from bayes_dnlr.model.spectrum import tau_scale
from bayes_dnlr.vocabulary import SPECTRUM_EXPONENT, UNIVERSAL_EXPONENT, Z90

MODULUS_PARAMETERS = ("E", "G", "tau_max", SPECTRUM_EXPONENT)   # what E(t) depends on
RESOLVE_STEPS = 2        # E(t) is measured from this many sampling steps into the first loading
NICE_STEPS = (1.0, 2.0, 5.0)   # default times are rounded up to 1-2-5 values, so that tests of
#                                similar sampling share them
HDI_PROB = 0.9
ALPHA_STEP = 1.0e-4      # finite-difference step of d E(t)/d alpha


@dataclass(frozen=True)
class ResolvedWindow:
    """The times (s after the loading began) over which a test measures E(t)."""

    shortest: float          # RESOLVE_STEPS sampling steps into the first loading
    longest: float           # the end of the window, from the loading's start
    origin: float            # the time (file clock) the loading began
    step: float              # the median sampling step at the loading's start
    how: str                 # how the shortest time was found, for a person

    def contains(self, t: float) -> bool:
        return self.shortest * (1 - 1e-9) <= t <= self.longest * (1 + 1e-9)


def nice_time(t: float) -> float:
    """The smallest 1-2-5 value (…, 0.5, 1, 2, 5, 10, …) at or above ``t`` (> 0)."""
    if not (t > 0 and math.isfinite(t)):
        raise ValueError(f"a time must be a positive number, got {t}")
    decade = 10.0 ** math.floor(math.log10(t))
    for m in (*NICE_STEPS, 10.0):
        if m * decade >= t * (1 - 1e-12):
            return float(f"{m * decade:.12g}")
    return 10.0 * decade


def resolved_window(time: np.ndarray, strain: np.ndarray, window: np.ndarray,
                    strain_rate: float, unmeasured_start: bool = False) -> ResolvedWindow:
    """Where a test resolves E(t): from RESOLVE_STEPS sampling steps into its first loading to the
    end of its window. ``time``, ``strain`` (Hencky) and ``window`` are the test's samples (the
    model-only samples of an unloaded start included, never in the window).

    The loading began where the strain started to rise: at the first sample when the test starts
    unloaded, earlier when the file starts at a strain already reached (a cropped toe): then at
    the first sample's strain over the loading's rate before it. Where that first part of the
    loading was not measured (cropped, or ``unmeasured_start``: a model-only unloaded start put
    before the first sample), what the model assumed for it still weighs on E(t) for as long
    again: the shortest resolved time is then at least twice the first sample's delay.
    """
    t = np.asarray(time, dtype=float)
    e = np.asarray(strain, dtype=float)
    rows = np.flatnonzero(np.asarray(window, dtype=bool))
    if rows.size < 2:
        raise ValueError("the window holds fewer than two samples")
    first = int(rows[0])
    steps = np.diff(t[first:first + 21])
    step = float(np.median(steps[steps > 0])) if np.any(steps > 0) else math.nan
    rate = float(strain_rate)
    how = f"{RESOLVE_STEPS} sampling steps of {step:.3g} s into the loading"
    origin = float(t[0])
    if rate > 0 and float(e[0]) > RESOLVE_STEPS * rate * step:
        # the file starts with a strain that a few steps of loading would not reach (a cropped
        # toe): the loading began before the first sample, at its rate
        origin -= float(e[0]) / rate
        unmeasured_start = True
        how += (f"; the first sample already has strain {float(e[0]):.3g}, so the loading began "
                f"{float(e[0]) / rate:.3g} s before it, at its rate {rate:.3g} 1/s")
    elif first > 0 and t[first] > origin:
        how += f", which began {float(t[first]) - origin:.3g} s before the window's first sample"
    k = min(first + RESOLVE_STEPS, int(rows[-1]))
    shortest = float(t[k]) - origin
    delay = float(t[first]) - origin
    if unmeasured_start and 2 * delay > shortest:
        shortest = 2 * delay
        how += (f"; the loading's first {delay:.3g} s were not measured, and what the model assumes "
                f"for them weighs on E(t) for as long again: from {shortest:.3g} s")
    longest = float(t[int(rows[-1])]) - origin
    return ResolvedWindow(shortest=shortest, longest=longest, origin=origin, step=step, how=how)


def default_times(w: ResolvedWindow) -> tuple[list[float], str]:
    """The default times of E(t) and why: the shortest resolved time, rounded up to 1-2-5."""
    t = nice_time(w.shortest)
    if t > w.longest:
        t = w.shortest
    return [t], (f"the shortest time the test resolves, {w.shortest:.3g} s ({w.how}), rounded up "
                 f"to {t:g} s")


# ---------------------------------------------------------------- values

def parameter_columns(source: Mapping[str, np.ndarray | float]) -> dict[str, np.ndarray | float]:
    """E, G, tau_max and alpha from a mapping of draws or values (alpha ½ when absent, G 0)."""
    return {"E": source["E"], "G": source.get("G", 0.0), "tau_max": source["tau_max"],
            SPECTRUM_EXPONENT: source.get(SPECTRUM_EXPONENT, UNIVERSAL_EXPONENT)}


def modulus_draws(columns: Mapping[str, np.ndarray | float], times: Sequence[float],
                  modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """E(t) of every draw: (draws, times)."""
    c = parameter_columns(columns)
    out = relaxation_modulus(np.asarray(times, dtype=float), c["E"], c["G"], c["tau_max"],
                             c[SPECTRUM_EXPONENT], modes, decades)
    return np.atleast_2d(out)


def draw_stats(values: np.ndarray) -> dict[str, float | list[float]]:
    """Mean, sd, median and 90 % HDI of one time's E(t) draws."""
    x = np.asarray(values, dtype=float).ravel()
    lo, hi = ess.hdi(x, HDI_PROB)
    return {"mean": float(x.mean()), "sd": float(x.std(ddof=1)) if x.size > 1 else 0.0,
            "median": float(np.median(x)), "hdi_90": [float(lo), float(hi)]}


def gradient(params: Mapping[str, float], names: Sequence[str], times: Sequence[float],
             modes: int = 50, decades: float = 6.0) -> np.ndarray:
    """∂E(t)/∂β for the parameters ``names`` (β as the fit reports them: tau_max in s), one row per
    time; parameters E(t) does not depend on have a zero column."""
    t = np.asarray(times, dtype=float)
    E, G, tau = float(params["E"]), float(params.get("G", 0.0)), float(params["tau_max"])
    alpha = float(params.get(SPECTRUM_EXPONENT, UNIVERSAL_EXPONENT))
    shape = tau_scale(modes, decades)
    p = spectrum_weights(np.array([alpha]), modes, decades)[0]
    decay = np.exp(-t[:, None] / (tau * shape[None, :]))          # (times, modes)
    fast = decay @ p
    out = np.zeros((t.size, len(names)))
    for j, k in enumerate(names):
        if k == "E":
            out[:, j] = fast
        elif k == "G":
            out[:, j] = SMALL_STRAIN_SLOPE * (1.0 - fast)
        elif k == "tau_max":
            # d/dτ exp(−t/(τ s_j)) = exp(·) t/(τ² s_j)
            out[:, j] = (E - SMALL_STRAIN_SLOPE * G) * (decay * (t[:, None] / (tau**2 * shape))) @ p
        elif k == SPECTRUM_EXPONENT:
            up = relaxation_modulus(t, E, G, tau, alpha + ALPHA_STEP, modes, decades)
            down = relaxation_modulus(t, E, G, tau, alpha - ALPHA_STEP, modes, decades)
            out[:, j] = (up - down) / (2 * ALPHA_STEP)
    return out


def linearized(estimate: Mapping[str, float], covariance: np.ndarray | None, names: Sequence[str],
               times: Sequence[float], modes: int = 50, decades: float = 6.0
               ) -> list[dict[str, float | list[float]]]:
    """E(t) at the estimate with its linearized sd (the delta method on the fit's covariance, eq. 32)
    and the normal 90 % interval."""
    values = relaxation_modulus(np.asarray(times, dtype=float), *(
        parameter_columns(estimate)[k] for k in MODULUS_PARAMETERS), modes, decades)
    values = np.atleast_1d(values)
    out = []
    if covariance is None:
        sds = np.full(len(times), math.nan)
    else:
        g = gradient(estimate, names, times, modes, decades)
        cov = np.asarray(covariance, dtype=float)
        with np.errstate(invalid="ignore"):
            sds = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", g, np.nan_to_num(cov), g), 0.0))
    for t, v, s in zip(times, values, sds, strict=True):
        out.append({"t": float(t), "mean": float(v), "sd": float(s),
                    "hdi_90": [float(v - Z90 * s), float(v + Z90 * s)]})
    return out


def information_weights(X: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Each sample's share of the least-squares variance of the linear combination gᵀβ of the
    parameters (the columns of the Jacobian X, eq. 22): h = gᵀ(XᵀX)⁻¹Xᵀ, h_i² / Σ h². For g a unit
    vector this is one parameter's share (inference/checks/predictive.py ``weights``)."""
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    h = (np.asarray(g, dtype=float) / scale) @ np.linalg.pinv(X / scale)
    h2 = h**2
    total = h2.sum()
    return h2 / total if total > 0 else np.full(X.shape[0], 1.0 / X.shape[0])


# ---------------------------------------------------------------- a test's times and its fit's E(t)

def test_window(test) -> ResolvedWindow:
    """``resolved_window`` of a ``bayes_dnlr.data.TestData``."""
    return resolved_window(test.time, test.strain_input, test.window, test.strain_rate,
                           unmeasured_start=int(getattr(test, "virtual_start", 0)) > 0)


def times_for(cfg, test) -> tuple[list[float], str, ResolvedWindow]:
    """The times of E(t) for a test: ``output.modulus_at`` when the config gives it, else the
    default (``default_times``); with why, and the window the test resolves."""
    w = test_window(test)
    given = cfg.output.modulus_at
    if given:
        return list(given), "output.modulus_at", w
    times, why = default_times(w)
    return times, why, w


def fit_block(cfg, test, estimate: Mapping[str, float], names: Sequence[str],
              covariance: np.ndarray | None, discrepancy: Mapping | None) -> dict:
    """The ``modulus_at`` block of fit.json: the times, why they were chosen, the window the test resolves,
    and E(t) linearized at the white estimate and, under model error, at the generalized one."""
    times, why, w = times_for(cfg, test)
    modes, decades = cfg.model.modes, cfg.model.decades
    out = {"times": times, "why": why,
           "resolved": {"shortest": w.shortest, "longest": w.longest, "origin": w.origin,
                        "step": w.step, "how": w.how},
           "white": linearized(estimate, covariance, names, times, modes, decades)}
    for row in out["white"]:
        row["inside_window"] = w.contains(row["t"])
    d = discrepancy or {}
    if d.get("evidence") and d.get("estimate") and d.get("covariance") is not None:
        est = {**estimate, **d["estimate"]}
        out["model_error"] = linearized(est, np.asarray(d["covariance"], dtype=float), names,
                                        times, modes, decades)
        for row in out["model_error"]:
            row["inside_window"] = w.contains(row["t"])
    return out


def fit_lines(block: Mapping | None) -> list[str]:
    """The ``fit`` console's lines of E(t): each time's value ± sd, white and under model error."""
    from bayes_dnlr.numbers import pm

    if not block:
        return []
    lines = []
    err = {row["t"]: row for row in block.get("model_error") or []}
    for row in block["white"]:
        text = f"E(t = {row['t']:g} s) = {pm(row['mean'], row['sd'])} MPa (white"
        if row["t"] in err:
            e = err[row["t"]]
            text += f"; under model error {pm(e['mean'], e['sd'])} MPa"
        text += ")"
        if not row.get("inside_window", True):
            text += " [outside the times the test resolves: an extrapolation]"
        lines.append(text)
    r = block["resolved"]
    lines.append(f"  E(t): the relaxation modulus, stress per unit strain at t after a small step "
                 f"(E = E(0)); the test resolves t from {r['shortest']:.3g} to {r['longest']:.4g} s; "
                 f"times: {block['why']}")
    return lines
