"""Minimisers of the least-squares criterion (eq. 20).

``trust_region``: scipy's bounded trust-region reflective method (the Levenberg-Marquardt family) in
internal coordinates (ln of the time constants) with the exact Jacobian.
``gauss_newton``: the paper's iteration (eq. 29), β ← β + (XᵀX)⁻¹Xᵀ(Y^m - Y), solved by least squares
on the column-scaled X (not by inverting XᵀX), with step halving until the criterion decreases and
projection onto the prior bounds.
``variable_projection``: the criterion minimised over the time constants (and the spectrum
exponent) only, E, G and sigma_inf being the linear least-squares solution for each
(Golub-Pereyra, with Kaufman's Jacobian).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayes_dnlr.inference.lsq.problem import LsqProblem


def least_squares(*args, **kwargs):
    """scipy.optimize.least_squares, imported on first use (``sample`` imports this module but
    does not optimise, and scipy costs it 0.2-0.5 s)."""
    from scipy.optimize import least_squares as solve

    return solve(*args, **kwargs)

STEP_TOL = 1.0e-6       # converged when every step is below this fraction of the linearized sd
REL_TOL = 1.0e-12       # ... or below this relative change (noise-free data: sd = 0)
TAU_STEP = 10.0         # Gauss-Newton: a time constant changes by at most this factor per step


@dataclass
class Optimum:
    beta: np.ndarray            # free parameters, in the problem's order
    criterion: float            # SSR (eq. 20)
    iterations: int
    evaluations: int
    converged: bool
    message: str


def _inside(problem: LsqProblem, beta: np.ndarray) -> np.ndarray:
    """β moved just inside the bounds (optimisers need a feasible start)."""
    u = problem.to_u(beta)
    lo, hi = problem.u_lower, problem.u_upper
    width = np.where(np.isfinite(hi - lo), hi - lo, np.abs(u) + 1.0)
    margin = 1e-9 * width
    return problem.to_beta(np.clip(u, lo + margin, hi - margin))


def trust_region(problem: LsqProblem, beta0: np.ndarray, max_iterations: int = 200) -> Optimum:
    """Bounded trust-region least squares (scipy ``least_squares``, method 'trf')."""
    n0 = problem.evaluations

    def fun(u: np.ndarray) -> np.ndarray:
        return -problem.residuals(problem.params(problem.to_beta(u)))

    def jac(u: np.ndarray) -> np.ndarray:
        return problem.jacobian_u(problem.params(problem.to_beta(u)))

    u0 = problem.to_u(_inside(problem, np.asarray(beta0, dtype=float)))
    res = least_squares(fun, u0, jac=jac, bounds=(problem.u_lower, problem.u_upper), method="trf",
                        x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12, max_nfev=max_iterations)
    beta = problem.to_beta(res.x)
    return Optimum(beta=beta, criterion=float(2.0 * res.cost), iterations=int(res.njev),
                   evaluations=problem.evaluations - n0, converged=bool(res.status > 0),
                   message=str(res.message))


def _linearized_sd(X: np.ndarray, ssr: float, dof: int) -> np.ndarray:
    """sqrt(diag(s²(XᵀX)⁻¹)) with s² = SSR/dof, via the SVD of the column-scaled X."""
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    _, s, vt = np.linalg.svd(X / scale, full_matrices=False)
    if s[-1] <= s[0] * 1e-15:
        return np.full(X.shape[1], np.inf)
    d = np.sum((vt / s[:, None]) ** 2, axis=0)
    return np.sqrt(max(ssr, 0.0) / max(dof, 1) * d) / scale


def _gn_step(X: np.ndarray, r: np.ndarray, beta: np.ndarray, lower: np.ndarray,
             upper: np.ndarray) -> np.ndarray:
    """(XᵀX)⁻¹Xᵀr (eq. 29) by least squares on the column-scaled X; parameters sitting on a bound
    that the step would push through are held there and the step is solved for the others."""
    p = X.shape[1]
    free = np.ones(p, dtype=bool)
    delta = np.zeros(p)
    for _ in range(p + 1):
        delta[:] = 0.0
        if not free.any():
            break
        Xf = X[:, free]
        scale = np.linalg.norm(Xf, axis=0)
        scale[scale == 0] = 1.0
        delta[free] = np.linalg.lstsq(Xf / scale, r, rcond=None)[0] / scale
        blocked = free & (((beta <= lower) & (delta < 0)) | ((beta >= upper) & (delta > 0)))
        if not blocked.any():
            break
        free &= ~blocked
    return delta


def gauss_newton(problem: LsqProblem, beta0: np.ndarray, max_iterations: int = 200) -> Optimum:
    """Gauss-Newton (eq. 29) with step halving and projection onto the bounds."""
    n0 = problem.evaluations
    beta = _inside(problem, np.asarray(beta0, dtype=float))
    params = problem.params(beta)
    S = problem.ssr(params)
    dof = problem.n_points - problem.n_free
    width = np.where(np.isfinite(problem.upper - problem.lower), problem.upper - problem.lower, np.inf)
    message = f"reached max_iterations ({max_iterations})"
    converged = False
    it = 0
    for it in range(1, max_iterations + 1):  # noqa: B007 - the count is reported
        X = problem.jacobian(params)
        r = problem.residuals(params)
        delta = _gn_step(X, r, beta, problem.lower, problem.upper)
        # converged when a step is below 1e-6 linearized sd (and 1e-6 of the value or box)
        ref = np.minimum(np.maximum(np.abs(beta), 1e-300), width)
        tol = np.maximum(np.minimum(STEP_TOL * _linearized_sd(X, S, dof), STEP_TOL * ref),
                         REL_TOL * np.abs(beta))
        lam = 1.0
        accepted = False
        while lam > 1e-12:
            trial = beta + lam * delta
            # time constants: stay positive, change by at most TAU_STEP per step
            trial = np.where(problem.is_log, np.clip(trial, beta / TAU_STEP, beta * TAU_STEP), trial)
            trial = np.clip(trial, problem.lower, problem.upper)
            trial = np.where(problem.is_log, np.maximum(trial, beta / TAU_STEP), trial)
            tp = problem.params(trial)
            St = problem.ssr(tp)
            if St <= S:
                accepted = True
                break
            lam *= 0.5
        if not accepted:
            # no decrease along the Gauss-Newton direction: at the minimum to rounding if the
            # step is within tolerance, else stalled
            converged = bool(np.all(np.abs(delta) <= tol))
            message = ("no further decrease of the criterion (converged)" if converged
                       else "stalled: no decrease of the criterion along the Gauss-Newton step")
            break
        step = trial - beta
        beta, params, S = trial, tp, St
        if np.all(np.abs(step) <= tol):
            converged = True
            message = "step below 1e-6 of the linearized sd (converged)"
            break
    return Optimum(beta=beta, criterion=float(S), iterations=it,
                   evaluations=problem.evaluations - n0, converged=converged, message=message)


def variable_projection(problem: LsqProblem, beta0: np.ndarray, max_iterations: int = 200) -> Optimum:
    """Minimise over the time constants (and alpha) only; E, G, sigma_inf by linear least squares
    (VP)."""
    n0 = problem.evaluations
    beta0 = _inside(problem, np.asarray(beta0, dtype=float))
    nl = [problem.names.index(k) for k in problem.nonlinear]
    if not nl:
        params = problem.project(problem.params(beta0))
        return Optimum(beta=problem.vector(params), criterion=problem.ssr(params), iterations=1,
                       evaluations=problem.evaluations - n0, converged=True,
                       message="linear problem: solved by linear least squares")
    lin_cols = [problem.names.index(k) for k in problem.linear]
    u0 = problem.to_u(beta0)

    def full(v: np.ndarray) -> dict[str, float]:
        u = u0.copy()
        u[nl] = v
        return problem.project(problem.params(problem.to_beta(u)))

    def fun(v: np.ndarray) -> np.ndarray:
        return -problem.residuals(full(v))

    def jac(v: np.ndarray) -> np.ndarray:
        params = full(v)
        J = problem.jacobian_u(params)
        Jn = J[:, [problem.names.index(k) for k in problem.nonlinear]]
        if lin_cols:
            # Kaufman: remove the part of ∂y/∂u_nl that the linear parameters absorb
            A = J[:, lin_cols]
            Q, _ = np.linalg.qr(A / np.linalg.norm(A, axis=0))
            Jn = Jn - Q @ (Q.T @ Jn)
        return Jn

    lo = problem.u_lower[nl]
    hi = problem.u_upper[nl]
    v0 = u0[nl]
    res = least_squares(fun, v0, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac",
                        ftol=1e-12, xtol=1e-12, gtol=1e-12, max_nfev=max_iterations)
    params = full(res.x)
    return Optimum(beta=problem.vector(params), criterion=float(2.0 * res.cost),
                   iterations=int(res.njev), evaluations=problem.evaluations - n0,
                   converged=bool(res.status > 0), message=str(res.message))


def run_minimiser(problem: LsqProblem, method: str, beta0: np.ndarray,
                  max_iterations: int) -> Optimum:
    """``fit.method`` from beta0: the paper's Gauss-Newton, or variable projection then a joint
    trust-region polish (lm)."""
    if method == "gauss-newton":
        return gauss_newton(problem, beta0, max_iterations)
    vp = variable_projection(problem, beta0, max_iterations)
    polish = trust_region(problem, vp.beta, max_iterations)
    better = polish if polish.criterion <= vp.criterion else vp
    return Optimum(
        beta=better.beta, criterion=better.criterion, iterations=vp.iterations + polish.iterations,
        evaluations=vp.evaluations + polish.evaluations, converged=vp.converged or polish.converged,
        message=f"variable projection: {vp.message}; joint polish: {polish.message}")
