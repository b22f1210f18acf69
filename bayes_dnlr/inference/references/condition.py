"""The linearized analysis of a run with references in its data (``use: data``): the tensile
test(s) through their own analysis, the references through their exact prediction.

The tests' least squares leave an estimate û with a covariance V (eq. 32, in the optimiser's
coordinates u: ln of the time constants) and, under model error, the covariance Σ_w = A⁻¹ of the
working model the sampler uses (inference/discrepancy/gls.py). A reference adds the Gaussian term
Σ ((v − g(θ))/s)² to the criterion; with the tests' criterion in its quadratic form around û,

    Q(u) = (u − û)ᵀ A (u − û) + Σ ((v − g(θ(u)))/s)²,

minimised by Gauss-Newton (the references are exact, the tests linearized as their own Δ is).
At the optimum, with J = ∂g/∂u and W = diag(1/s²):

    A' = A + Jᵀ W J,        V' = A'⁻¹ (M + Jᵀ W J) A'⁻¹,    M = A V A,

the sandwich of the tests' analysis carried over (M = A and V' = A'⁻¹ for the white analysis,
where V = A⁻¹). Δ̃ (eq. 35) follows from V'.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.inference.references.terms import PREDICTED_BY, Reference, gradient, predict
from bayes_dnlr.vocabulary import base_name

MAX_ITERATIONS = 60
STEP_TOLERANCE = 1e-8      # in units of the step's own sd


@dataclass(frozen=True)
class Conditioned:
    """The analysis with the references: free names, estimate (all parameters), the covariances in
    u (ln of the time constants) and of β, the working model's Fisher matrix A' in u."""

    names: list[str]
    estimate: dict[str, float]
    covariance_u: np.ndarray
    covariance: np.ndarray
    fisher_u: np.ndarray
    iterations: int
    converged: bool


def parameter_map(ref: Reference, names: Sequence[str], layout_name) -> dict[str, str]:
    """The run's name of each parameter the reference's prediction uses (those not in ``names``
    are fixed): ``layout_name(k, test)`` as ``Layout.name``. A run whose spectrum is per test must
    say which test predicts a reference."""
    test = ref.test
    out = {}
    for k in PREDICTED_BY:
        g = layout_name(k, test) if test is not None else k
        if test is None and g not in names and any(base_name(n) == k and "[" in n for n in names):
            raise BayesDnlrError(
                f"reference_moduli ({ref.label}): {k} is one per test in this run: say which test's "
                "parameters predict it (reference_moduli[i].test)")
        out[k] = g
    return out


def _values(ref: Reference, params: Mapping[str, float], names: Sequence[str], layout_name,
            fixed: Mapping[str, float]) -> dict[str, float]:
    out = {}
    for k, g in parameter_map(ref, names, layout_name).items():
        if g in params:
            out[k] = float(params[g])
        elif k in fixed:
            out[k] = float(fixed[k])
    return out


def stacked(refs: Sequence[Reference], params: Mapping[str, float], names: Sequence[str],
            layout_name, fixed: Mapping[str, float], modes: int, decades: float
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r, X, s): the references' residuals v − g(θ), their Jacobian ∂g/∂β over the run's free
    ``names`` (β as reported: time constants in s), and their sd, stacked over the elements."""
    rs, Xs, ss = [], [], []
    for ref in refs:
        pmap = parameter_map(ref, names, layout_name)
        local = _values(ref, params, names, layout_name, fixed)
        g = predict(ref, local, modes, decades)
        own = [k for k in PREDICTED_BY if pmap[k] in names]
        d = gradient(ref, local, own, modes, decades)
        X = np.zeros((ref.m, len(names)))
        for j, k in enumerate(own):
            X[:, list(names).index(pmap[k])] = d[:, j]
        rs.append(ref.value - g)
        Xs.append(X)
        ss.append(ref.sd)
    return np.concatenate(rs), np.vstack(Xs), np.concatenate(ss)


def condition(refs: Sequence[Reference], names: Sequence[str], is_log: Sequence[bool],
              estimate: Mapping[str, float], covariance_u: np.ndarray, fisher_u: np.ndarray | None,
              bounds: Mapping[str, tuple[float, float]], layout_name, fixed: Mapping[str, float],
              modes: int = 50, decades: float = 6.0) -> Conditioned:
    """The analysis with the data references ``refs`` (module doc). ``estimate`` holds the free
    parameters (β) at the tests' optimum, ``covariance_u`` their covariance V in u, ``fisher_u`` the
    working model's A (None: A = V⁻¹, the white analysis); ``bounds`` the prior box of each name."""
    names = list(names)
    log = np.asarray(is_log, dtype=bool)
    beta0 = np.array([float(estimate[k]) for k in names])
    u0 = np.where(log, np.log(np.where(log, beta0, 1.0)), beta0)
    V = 0.5 * (np.asarray(covariance_u, dtype=float) + np.asarray(covariance_u, dtype=float).T)
    A = np.linalg.inv(V) if fisher_u is None else np.asarray(fisher_u, dtype=float)
    M = A if fisher_u is None else A @ V @ A
    lo = np.array([bounds[k][0] for k in names], dtype=float)
    hi = np.array([bounds[k][1] for k in names], dtype=float)
    with np.errstate(divide="ignore"):
        u_lo = np.where(log, np.log(np.maximum(lo, 0.0)), lo)
        u_hi = np.where(log, np.log(hi), hi)

    def beta(u: np.ndarray) -> np.ndarray:
        return np.where(log, np.exp(np.where(log, u, 0.0)), u)

    def parts(u: np.ndarray):
        b = beta(u)
        params = {**dict(fixed), **dict(zip(names, map(float, b), strict=True))}
        r, X, s = stacked(refs, params, names, layout_name, fixed, modes, decades)
        J = X * np.where(log, b, 1.0)[None, :]           # ∂g/∂u
        du = u - u0
        q = float(du @ A @ du + np.sum((r / s) ** 2))
        return q, r, J, s

    u = u0.copy()
    q, r, J, s = parts(u)
    converged = False
    it = 0
    while it < MAX_ITERATIONS:
        it += 1
        W = 1.0 / s**2
        H = A + J.T @ (J * W[:, None])
        grad = A @ (u0 - u) + J.T @ (W * r)
        step = np.linalg.solve(H, grad)
        t = 1.0
        while True:
            trial = np.clip(u + t * step, u_lo, u_hi)
            q_new, r_new, J_new, s_new = parts(trial)
            if q_new <= q or t < 1e-6:
                break
            t *= 0.5
        size = float(np.sqrt(max(step @ H @ step, 0.0))) * t
        u, q, r, J, s = trial, q_new, r_new, J_new, s_new
        if size < STEP_TOLERANCE:
            converged = True
            break
    W = 1.0 / s**2
    info = J.T @ (J * W[:, None])
    A2 = A + info
    inv = np.linalg.inv(A2)
    V2 = inv @ (M + info) @ inv
    V2 = 0.5 * (V2 + V2.T)
    b = beta(u)
    jac = np.where(log, b, 1.0)
    cov = V2 * jac[:, None] * jac[None, :]
    return Conditioned(names, {**dict(fixed), **dict(zip(names, map(float, b), strict=True))},
                       V2, cov, A2, it, converged)


def physical_to_u(covariance: np.ndarray, estimate: Sequence[float], is_log: Sequence[bool]) -> np.ndarray:
    """A covariance of β as one of u (ln β for the time constants), by the delta method."""
    log = np.asarray(is_log, dtype=bool)
    j = np.where(log, 1.0 / np.asarray(estimate, dtype=float), 1.0)
    return np.asarray(covariance, dtype=float) * j[:, None] * j[None, :]
