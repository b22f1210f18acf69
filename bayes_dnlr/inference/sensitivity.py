"""Sensitivities and the paper's stochastic analysis (section 3.2).

X (eq. 22) is the Jacobian of the model stress with respect to the parameters, one column per
parameter. Its columns are exact: the model is linear in E, G and sigma_inf, so their columns are the
unit responses of ``DNLR.basis``; the time-constant columns come from the forward-mode derivatives
the integrator carries (d/d ln tau, divided by tau).

From X and the noise level sigma0: Δ = sigma0² (XᵀX)⁻¹ (eq. 32), Err(β_j) = sqrt(Δ_jj)/β_j (eq. 33),
ρ_rs = Δ_rs / sqrt(Δ_rr Δ_ss) (eq. 34), and Δ̃ with Err on the diagonal and ρ off it (eq. 35).
The normalised sensitivities X̃_j = β_j ∂y/∂β_j (eq. 37) are in MPa and comparable across parameters.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.model import Basis

LINEAR_COLUMN = {"E": 0, "G": 1, "sigma_inf": 2}
TIME_CONSTANTS = ("tau_max", "tau_max_R")

# identifiability thresholds (warnings, never errors)
RHO_WARN = 0.99
NEGLIGIBLE_SENSITIVITY = 0.05
CONDITION_WARN = 1.0e8
RELATIVE_ERROR_WARN = 0.5


def log_sensitivity(basis: Basis, params: Mapping[str, float], name: str) -> np.ndarray:
    """∂y/∂ln(β) for one parameter (eq. 22 times β), on the model's full grid."""
    v = basis.values
    if name in LINEAR_COLUMN:
        return params[name] * v[:, LINEAR_COLUMN[name]]
    if name == "tau_max":
        g = basis.grad_tau_max
    elif name == "tau_max_R":
        g = basis.grad_tau_max_R
    else:
        raise ValueError(f"unknown parameter {name!r}")
    if g is None:
        raise ValueError(f"the basis holds no derivative with respect to {name} (grad=True, "
                         "and tau_max_R needs a relaxation phase)")
    s = params["E"] * g[:, 0] + params["G"] * g[:, 1]
    if "sigma_inf" in params:
        s = s + params["sigma_inf"] * g[:, 2]
    return s


def sensitivity_matrix(basis: Basis, params: Mapping[str, float], names: Sequence[str],
                       mask: np.ndarray | None = None) -> np.ndarray:
    """X (eq. 22): X[i, j] = ∂y(t_i)/∂β_j for the parameters ``names``, rows where ``mask`` is True."""
    cols = []
    for k in names:
        if k in LINEAR_COLUMN:
            c = basis.values[:, LINEAR_COLUMN[k]]
        else:
            c = log_sensitivity(basis, params, k) / params[k]
        cols.append(c if mask is None else c[mask])
    return np.column_stack(cols)


def normalised(X: np.ndarray, values: Sequence[float]) -> np.ndarray:
    """X̃_j = β_j X_j (eq. 37), in the unit of the stress (MPa)."""
    return X * np.asarray(values, dtype=float)[None, :]


def covariance(X: np.ndarray, sigma0: float, values: Sequence[float] | None = None) -> np.ndarray:
    """Δ = sigma0² (XᵀX)⁻¹ (eq. 32).

    Computed from the SVD of the column-scaled X (scaled by ``values`` when given, else by the
    column norms), which is far better conditioned than forming XᵀX: ρ(E, tau_max) ≈ -0.999 makes
    XᵀX nearly singular in double precision otherwise. Raises numpy.linalg.LinAlgError when X is
    rank deficient.
    """
    if values is not None:
        scale = np.abs(np.asarray(values, dtype=float))
        scale[scale == 0] = 1.0
    else:
        scale = np.linalg.norm(X, axis=0)
    if np.any(np.linalg.norm(X, axis=0) == 0):
        raise np.linalg.LinAlgError("a sensitivity column is zero: that parameter has no effect")
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


def analyse(X: np.ndarray, names: Sequence[str], values: Sequence[float],
            sigma0: float) -> StochasticAnalysis:
    """Δ, Err, ρ, Δ̃ and the conditioning from X (eq. 32-35, 37)."""
    values = np.asarray(values, dtype=float)
    Xn = normalised(X, values)
    unit = covariance(X, 1.0, values)      # (XᵀX)⁻¹: ρ does not depend on sigma0
    delta = sigma0**2 * unit
    dt = correlation(unit)
    np.fill_diagonal(dt, relative_errors(delta, values))
    return StochasticAnalysis(
        names=list(names), values=values, X=X, Xn=Xn, covariance=delta,
        sd=standard_deviations(delta), err=relative_errors(delta, values),
        correlation=correlation(unit), delta_tilde=dt,
        condition_number=condition_number(Xn), max_normalised=np.max(np.abs(Xn), axis=0))


def identifiability_warnings(a: StochasticAnalysis) -> list[str]:
    """Warnings to read before sampling: near-collinear columns, negligible sensitivities."""
    out: list[str] = []
    if not a.condition_number < CONDITION_WARN:
        out.append(f"the normalised information matrix X̃ᵀX̃ is ill-conditioned (condition number "
                   f"{a.condition_number:.3g} ≥ {CONDITION_WARN:.0e}): some combination of "
                   "parameters is not identified on this window")
    p = len(a.names)
    for r in range(p):
        for s in range(r + 1, p):
            rho = a.correlation[r, s]
            if abs(rho) > RHO_WARN:
                out.append(
                    f"|ρ({a.names[r]}, {a.names[s]})| = {abs(rho):.4f} > {RHO_WARN}: the two are strongly "
                    "correlated; their sensitivities are nearly proportional over most of the window. "
                    "The paper finds ρ(E, tau_max) ≈ -0.9988 on the whole curve and still identifies "
                    "both (Err ≈ 1.4 %); check Err and the multi-start outcome before trusting them")
    top = float(np.max(a.max_normalised)) if a.max_normalised.size else 0.0
    for k, m in zip(a.names, a.max_normalised, strict=True):
        if top > 0 and m < NEGLIGIBLE_SENSITIVITY * top:
            out.append(f"the normalised sensitivity to {k} is negligible on this window (max |X̃| = "
                       f"{m:.3g} MPa, {100 * m / top:.1f} % of the largest): fix {k} (value: ...) or "
                       "widen the window (paper 4.2: G on interval I)")
    for k, e in zip(a.names, a.err, strict=True):
        if e > RELATIVE_ERROR_WARN:
            out.append(f"Err({k}) = {100 * e:.0f} %: {k} is poorly determined by these data")
    return out
