"""Sensitivities and the paper's stochastic analysis (section 3.2).

X (eq. 22) is the Jacobian of the model stress with respect to the parameters, one column per
parameter. Its columns are exact: the model is linear in E, G and sigma_inf, so their columns are the
unit responses of ``DNLR.basis``; the time-constant columns come from the forward-mode derivatives
the integrator carries (d/d ln tau, divided by tau), the spectrum exponent's (alpha) from the
derivative of the weights (model/kernel.py).

From X and the noise level sigma0: Δ = sigma0² (XᵀX)⁻¹ (eq. 32), Err(β_j) = sqrt(Δ_jj)/β_j (eq. 33),
ρ_rs = Δ_rs / sqrt(Δ_rr Δ_ss) (eq. 34), and Δ̃ with Err on the diagonal and ρ off it (eq. 35).
The normalised sensitivities X̃_j = β_j ∂y/∂β_j (eq. 37) are in MPa and comparable across parameters.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.model import Basis
from bayes_dnlr.vocabulary import LINEAR_COLUMN, SPECTRUM_PARAMETERS, fixing

# identifiability thresholds (warnings, never errors)
RHO_WARN = 0.99
NEGLIGIBLE_SENSITIVITY = 0.05
CONDITION_WARN = 1.0e8
RELATIVE_ERROR_WARN = 0.5
NEGLIGIBLE_ERR = 0.1     # ... and only for a parameter whose Err is above 10 %: a well-determined
#                          parameter's sensitivity is not negligible, however small next to E's
ZERO_VALUE = 1.0e-12     # |β_j|·|X_j| below this fraction of the largest: β_j counts as zero
# The parameters a fit holds where the window cannot identify them, and the value it holds them
# at: G at 0, the relaxed state left out, as the paper does on interval I ("the sensitivity to G
# is only 5 % of the maximum sensitivities of E and tau_max and therefore, this parameter can be
# omitted", section 4.2); the threshold is the paper's NEGLIGIBLE_SENSITIVITY.
HOLD_AT = {"G": 0.0}


def _nonlinear_derivative(basis: Basis, params: Mapping[str, float], name: str) -> np.ndarray:
    """∂y/∂ln(tau) for a time constant, ∂y/∂alpha for the spectrum exponent."""
    if name == "tau_max":
        g = basis.grad_tau_max
    elif name == "tau_max_R":
        g = basis.grad_tau_max_R
    elif name == "alpha":
        g = basis.grad_alpha
    else:
        raise ValueError(f"unknown parameter {name!r}")
    if g is None:
        raise ValueError(f"the basis holds no derivative with respect to {name} (grad=True, "
                         "and tau_max_R needs a relaxation phase)")
    s = params["E"] * g[:, 0] + params["G"] * g[:, 1]
    if "sigma_inf" in params:
        s = s + params["sigma_inf"] * g[:, 2]
    return s


def log_sensitivity(basis: Basis, params: Mapping[str, float], name: str) -> np.ndarray:
    """∂y/∂ln(β) for one parameter (eq. 22 times β), on the model's full grid."""
    v = basis.values
    if name in LINEAR_COLUMN:
        return params[name] * v[:, LINEAR_COLUMN[name]]
    s = _nonlinear_derivative(basis, params, name)
    return params[name] * s if name in SPECTRUM_PARAMETERS else s


def derivative(basis: Basis, params: Mapping[str, float], name: str) -> np.ndarray:
    """∂y/∂β for one parameter (eq. 22), on the model's full grid."""
    if name in LINEAR_COLUMN:
        return basis.values[:, LINEAR_COLUMN[name]]
    s = _nonlinear_derivative(basis, params, name)
    return s if name in SPECTRUM_PARAMETERS else s / params[name]


def sensitivity_matrix(basis: Basis, params: Mapping[str, float], names: Sequence[str],
                       mask: np.ndarray | None = None) -> np.ndarray:
    """X (eq. 22): X[i, j] = ∂y(t_i)/∂β_j for the parameters ``names``, rows where ``mask`` is True."""
    cols = []
    for k in names:
        c = derivative(basis, params, k)
        cols.append(c if mask is None else c[mask])
    return np.column_stack(cols)


def normalised(X: np.ndarray, values: Sequence[float]) -> np.ndarray:
    """X̃_j = β_j X_j (eq. 37), in the unit of the stress (MPa)."""
    return X * np.asarray(values, dtype=float)[None, :]


def covariance(X: np.ndarray, sigma0: float, values: Sequence[float] | None = None) -> np.ndarray:
    """Δ = sigma0² (XᵀX)⁻¹ (eq. 32).

    Computed from the SVD of the column-scaled X (scaled by ``values`` when given, else to unit
    column norms; a column whose value is zero is scaled to unit norm), which is far better
    conditioned than forming XᵀX: ρ(E, tau_max) ≈ -0.999 makes XᵀX nearly singular in double
    precision otherwise. Raises numpy.linalg.LinAlgError when X is
    rank deficient.
    """
    norms = np.linalg.norm(X, axis=0)
    if np.any(norms == 0):
        raise np.linalg.LinAlgError("a sensitivity column is zero: that parameter has no effect")
    if values is not None:
        scale = np.abs(np.asarray(values, dtype=float))
        # a value at (or next to) zero, e.g. G = 0 on its lower bound, would scale its column away:
        # scale that column to unit norm instead (any column scaling gives the same Δ)
        weight = scale * norms
        tiny = ~(weight > ZERO_VALUE * weight.max())
        scale[tiny] = 1.0 / norms[tiny]
    else:
        scale = 1.0 / norms
    Xs = X * scale[None, :]
    _, s, vt = np.linalg.svd(Xs, full_matrices=False)
    if s[-1] <= s[0] * 1e-14:
        raise np.linalg.LinAlgError(f"X is rank deficient (singular values {s})")
    inv = (vt.T / s**2) @ vt            # (XsᵀXs)⁻¹
    return sigma0**2 * inv * np.outer(scale, scale)


def standard_deviations(delta: np.ndarray) -> np.ndarray:
    return np.sqrt(np.diag(delta))


def relative_errors(delta: np.ndarray, values: Sequence[float]) -> np.ndarray:
    """Err(β_j) = sqrt(V(β_j)) / β_j (eq. 33), as a fraction (x100 for the paper's %)."""
    return standard_deviations(delta) / np.abs(np.asarray(values, dtype=float))


def correlation(delta: np.ndarray) -> np.ndarray:
    """ρ_rs = cov(β_r, β_s) / (sqrt V(β_r) sqrt V(β_s)) (eq. 34)."""
    sd = standard_deviations(delta)
    rho = delta / np.outer(sd, sd)
    np.fill_diagonal(rho, 1.0)
    return np.clip(rho, -1.0, 1.0)


def delta_tilde(delta: np.ndarray, values: Sequence[float]) -> np.ndarray:
    """Δ̃ (eq. 35): Err(β_j) (fraction) on the diagonal, ρ_rs off it."""
    out = correlation(delta)
    np.fill_diagonal(out, relative_errors(delta, values))
    return out


def condition_number(Xn: np.ndarray) -> float:
    """Condition number of X̃ᵀX̃ (the normalised information matrix), = cond(X̃)²."""
    s = np.linalg.svd(Xn, compute_uv=False)
    return float(np.inf) if s[-1] == 0 else float((s[0] / s[-1]) ** 2)


@dataclass(frozen=True)
class StochasticAnalysis:
    """The paper's section 3.2 at one parameter point."""

    names: list[str]
    values: np.ndarray
    X: np.ndarray                 # eq. 22, on the window
    Xn: np.ndarray                # eq. 37
    covariance: np.ndarray        # Δ, eq. 32
    sd: np.ndarray
    err: np.ndarray               # eq. 33 (fraction)
    correlation: np.ndarray       # eq. 34
    delta_tilde: np.ndarray       # eq. 35
    condition_number: float
    max_normalised: np.ndarray    # max |X̃_j| over the window, MPa


def _zero_valued(X: np.ndarray, values: np.ndarray) -> np.ndarray:
    """True for parameters whose value is zero for the normalised analysis (|β_j|·|X_j| below
    ZERO_VALUE of the largest): Err and X̃ are undefined or zero for them."""
    weight = np.abs(values) * np.linalg.norm(X, axis=0)
    return ~(weight > ZERO_VALUE * weight.max()) if weight.size else np.zeros(0, bool)


def analyse(X: np.ndarray, names: Sequence[str], values: Sequence[float],
            sigma0: float) -> StochasticAnalysis:
    """Δ, Err, ρ, Δ̃ and the conditioning from X (eq. 32-35, 37).

    A parameter whose value is zero (e.g. G = 0 on its lower bound) keeps its sd and correlations;
    its Err (eq. 33) is undefined (NaN) and it is left out of the condition number of X̃ᵀX̃ (its
    normalised column X̃ = 0 · X is zero)."""
    values = np.asarray(values, dtype=float)
    Xn = normalised(X, values)
    unit = covariance(X, 1.0, values)      # (XᵀX)⁻¹: ρ does not depend on sigma0
    delta = sigma0**2 * unit
    zero = _zero_valued(X, values)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.where(zero, np.nan, relative_errors(delta, values))
    dt = correlation(unit)
    np.fill_diagonal(dt, err)
    return StochasticAnalysis(
        names=list(names), values=values, X=X, Xn=Xn, covariance=delta,
        sd=standard_deviations(delta), err=err,
        correlation=correlation(unit), delta_tilde=dt,
        condition_number=condition_number(Xn[:, ~zero]) if (~zero).any() else float("inf"),
        max_normalised=np.max(np.abs(Xn), axis=0))


def analyse_holding(X: np.ndarray, names: Sequence[str], values: Sequence[float], sigma0: float,
                    held: Sequence[str]) -> StochasticAnalysis:
    """The analysis of the parameters not in ``held``, those held at their values (parameters on a
    bound of their prior: an active constraint). Δ, Err, ρ and Δ̃ of the others are conditional on
    the held values; the held parameters' rows and columns are NaN (they have no linearized sd).
    Raises numpy.linalg.LinAlgError when the others are not identifiable either."""
    names = list(names)
    values = np.asarray(values, dtype=float)
    keep = np.array([k not in held for k in names])
    if not keep.any():
        raise np.linalg.LinAlgError("every free parameter is on a bound")
    sub = analyse(X[:, keep], [k for k, f in zip(names, keep, strict=True) if f], values[keep], sigma0)
    p = len(names)
    idx = np.flatnonzero(keep)

    def full(m: np.ndarray) -> np.ndarray:
        out = np.full((p, p), np.nan)
        out[np.ix_(idx, idx)] = m
        return out

    def vec(v: np.ndarray) -> np.ndarray:
        out = np.full(p, np.nan)
        out[idx] = v
        return out

    corr = full(sub.correlation)
    np.fill_diagonal(corr, 1.0)
    Xn = normalised(X, values)
    return StochasticAnalysis(
        names=names, values=values, X=X, Xn=Xn, covariance=full(sub.covariance), sd=vec(sub.sd),
        err=vec(sub.err), correlation=corr, delta_tilde=full(sub.delta_tilde),
        condition_number=sub.condition_number, max_normalised=np.max(np.abs(Xn), axis=0))


def alpha_dependence(X: np.ndarray, names: Sequence[str], values: Sequence[float],
                     x_alpha: np.ndarray, alpha: float, sampled: bool) -> dict[str, object]:
    """How the least-squares estimate depends on the spectrum's exponent alpha (eq. 12 has ½):
    dβ̂/dα = -(XᵀX)⁻¹Xᵀ x_α, X the columns of the other free parameters ``names`` (eq. 22) and
    x_α = ∂y/∂α: the shift of their estimate when alpha is held at another value. With alpha
    sampled, the same number is the slope Σ_βα/Σ_αα of the linearized posterior. ``per_tenth`` is
    the shift for Δα = +0.1, ``relative_per_tenth`` that shift as a fraction of the estimate."""
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    slope = np.linalg.lstsq(X / scale, -x_alpha, rcond=None)[0] / scale
    vals = np.asarray(values, dtype=float)
    return {"alpha": float(alpha), "sampled": bool(sampled),
            "derivative": {k: float(d) for k, d in zip(names, slope, strict=True)},
            "per_tenth": {k: float(0.1 * d) for k, d in zip(names, slope, strict=True)},
            "relative_per_tenth": {k: (float(0.1 * d / v) if v != 0 else None)
                                   for k, d, v in zip(names, slope, vals, strict=True)}}


def score_test(X: np.ndarray, x_alpha: np.ndarray, residuals: np.ndarray,
               sigma0: float) -> dict[str, float]:
    """The score (Lagrange-multiplier) test of a held parameter (the spectrum exponent at ½, the
    stress shift off: inference/lsq/stress_score.py): how far the data pull it from the value it is
    held at. One Gauss-Newton step for it from the optimum with it held, the other free parameters
    re-optimised with it: step = x̃ᵀr / x̃ᵀx̃, x̃ = its column x minus its projection on the columns
    of X (eq. 22), r = y - f; its sd σ0/|x̃|; z = step/sd. Whitened X, x and r (with σ0 = 1) give
    the same test under the model discrepancy."""
    norms = np.linalg.norm(X, axis=0)
    norms[norms == 0] = 1.0
    q, _ = np.linalg.qr(X / norms)
    xt = x_alpha - q @ (q.T @ x_alpha)
    nx = float(np.linalg.norm(xt))
    if not nx > 0:
        return {"step": math.nan, "sd": math.inf, "z": 0.0}
    step = float(xt @ residuals) / nx**2
    sd = sigma0 / nx
    return {"step": step, "sd": sd, "z": step / sd}


def bound_side(value: float, low: float, high: float) -> str | None:
    """"lower" or "upper" when ``value`` sits on that bound of its prior (within 1e-6 of the prior's
    width, or of the bound's magnitude for a half-open prior), else None."""
    width = high - low if math.isfinite(low) and math.isfinite(high) else 0.0
    for side, b in (("lower", low), ("upper", high)):
        if math.isfinite(b):
            tol = 1e-6 * max(width, abs(b), 1e-300)
            if abs(value - b) <= tol:
                return side
    return None


def bound_warning(name: str, value: float, low: float, high: float, side: str, held: bool) -> str:
    """The fit warning for a parameter on a bound of its prior: which bound, what it means for the
    stochastic analysis, what to do."""
    b = low if side == "lower" else high
    shown = f"{b:g}" if abs(value - b) <= 1e-9 * max(abs(high - low), abs(b), 1e-300) else f"{value:.6g}"
    text = (f"{name} = {shown} (its {side} bound; prior [{low:g}, {high:g}]), the white least-squares "
            f"estimate: the data push {name} "
            f"{'below' if side == 'lower' else 'above'} what the prior allows, a constrained optimum. ")
    if held:
        text += (f"The stochastic analysis holds {name} there: the sd, Err and Δ̃ of the other "
                 f"parameters are conditional on {name} = {shown}, and {name} has none. ")
    else:
        text += "Its linearized sd and Δ̃ describe the unconstrained curvature only. "
    if side == "lower":
        text += (f"If {name} = {b:g} is physical, fix it (parameters.{name}: {{value: {b:g}}}); if not, "
                 "the model or the window does not describe these data (read the residuals)")
    else:
        text += (f"If larger values are physical, raise parameters.{name}.high; else fix {name} or "
                 "read the residuals for a model or window problem")
    return text


def identifiability_warnings(a: StochasticAnalysis, held: Sequence[str] = ()) -> list[str]:
    """Warnings to read before sampling: near-collinear columns, negligible sensitivities.

    A parameter in ``held`` (on a bound: it has its own warning) or with the value zero gets no
    negligible-sensitivity or Err warning: both are relative to its value. A sensitivity is called
    negligible only for a parameter that is also poorly determined (Err > NEGLIGIBLE_ERR)."""
    out: list[str] = []
    if not a.condition_number < CONDITION_WARN:
        out.append(f"the normalised information matrix X̃ᵀX̃ is ill-conditioned (condition number "
                   f"{a.condition_number:.3g} ≥ {CONDITION_WARN:.0e}, white least squares): some "
                   "combination of parameters is not identified on this window")
    p = len(a.names)
    for r in range(p):
        for s in range(r + 1, p):
            rho = a.correlation[r, s]
            if abs(rho) > RHO_WARN:
                out.append(
                    f"|ρ({a.names[r]}, {a.names[s]})| = {abs(rho):.4f} > {RHO_WARN} (white least squares): "
                    "the two are strongly "
                    "correlated; their sensitivities are nearly proportional over most of the window. "
                    "The paper finds ρ(E, tau_max) ≈ -0.9988 on the whole curve and still identifies "
                    "both (Err ≈ 1.4 %); check Err and the multi-start outcome before trusting them")
    skip = set(held) | {k for k, e in zip(a.names, a.err, strict=True) if not np.isfinite(e)}
    top = float(np.max(a.max_normalised)) if a.max_normalised.size else 0.0
    for k, m, e, v in zip(a.names, a.max_normalised, a.err, a.values, strict=True):
        if k not in skip and top > 0 and m < NEGLIGIBLE_SENSITIVITY * top and e > NEGLIGIBLE_ERR:
            out.append(f"the normalised sensitivity to {k} is negligible on this window (max |X̃| = "
                       f"{m:.3g} MPa, {100 * m / top:.1f} % of the largest; Err({k}) = {100 * e:.0f} %, "
                       "white least squares): "
                       f"hold {k} where this fit puts it ({fixing(k, v)}) or widen the window "
                       "(paper 4.2: G on interval I)")
    for k, e in zip(a.names, a.err, strict=True):
        if k not in skip and e > RELATIVE_ERROR_WARN:
            out.append(f"Err({k}) = {100 * e:.0f} % (white least squares): {k} is poorly determined by "
                       "these data")
    return out


def unidentified(a: StochasticAnalysis, reference: Mapping[str, float],
                 width: Mapping[str, float]) -> dict[str, float]:
    """The parameters of ``HOLD_AT`` the window cannot identify: name -> its normalised
    sensitivity (eq. 37), at its ``reference`` value, as a fraction of the largest at the estimate.

    Either the parameter makes no difference the data can see, wherever it is: its sensitivity is
    below NEGLIGIBLE_SENSITIVITY of the largest even at ``reference``, the largest value its prior
    allows (the paper omits G on such a window, 4.2). Or the data do not place it: its linearized
    sd (eq. 32) is wider than its prior box (``width``), as when G trades off with the spectrum's
    slow end on a small-strain window (ρ(G, tau_max) ≈ -1). Left free, its box decides it and,
    through its correlations, E. Taken at the estimate instead of ``reference``, the rule would
    hold a G the data place at 0 on a whole curve."""
    top = float(np.max(a.max_normalised)) if a.max_normalised.size else 0.0
    if not top > 0:
        return {}
    out = {}
    for j, k in enumerate(a.names):
        ref = reference.get(k)
        if k not in HOLD_AT or ref is None or not math.isfinite(ref):
            continue
        m = float(np.max(np.abs(ref * a.X[:, j]))) / top
        box = width.get(k, math.inf)
        if m < NEGLIGIBLE_SENSITIVITY or (math.isfinite(box) and np.isfinite(a.sd[j]) and a.sd[j] > box):
            out[k] = m
    return out


def hold_words(held: Mapping[str, Mapping[str, float]]) -> str:
    """One sentence: which parameters the fit holds, where and why."""
    parts = []
    for k, v in held.items():
        if v["sensitivity"] < NEGLIGIBLE_SENSITIVITY:
            why = (f"its normalised sensitivity on this window, even at the top of its prior "
                   f"({v['reference']:g}), is {100 * v['sensitivity']:.1f} % of the largest, below the "
                   f"paper's {100 * NEGLIGIBLE_SENSITIVITY:.0f} %")
        else:
            why = (f"its linearized sd, {v['sd']:.3g}, is wider than its prior box: the data do not "
                   "place it, it trades off with the other parameters")
        parts.append(f"{k} held at {v['value']:g} ({why}; the window does not identify it, as G on "
                     "the paper's interval I, section 4.2)")
    return "; ".join(parts) + (". fit.hold_unidentified: false leaves it to its prior instead")
