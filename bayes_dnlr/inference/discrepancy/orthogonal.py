"""The projection construction of the model discrepancy: what the parameters mean under model error.

A discrepancy δ ~ GP(0, K) added to the model is confounded with its parameters: any part of δ
that looks like a change of θ can be read either way (Brynjarsdóttir & O'Hagan 2014; Tuo & Wu 2015),
so each kernel estimates another θ. Here the parameters have one target whatever the kernel, the
L2 projection of the measured curve onto the model,

    θ* = argmin_θ (y - y(θ))ᵀ W (y - y(θ)),   W = diag(w): quadrature weights on the axis,

(W = I on an even grid: θ* is then the paper's least-squares estimate), and the discrepancy is split
exactly into the part the data cannot tell from a change of θ and the rest (Plumlee 2017): with
X = ∂y/∂u at θ* (u = θ, ln θ for the time constants), V = W X, s = Vᵀ δ,

    δ = K V M⁻¹ s + δ⊥,   M = Vᵀ K V,   δ⊥ ~ GP conditioned on Vᵀ δ⊥ = 0, independent of s.

- δ⊥ is what the residual of θ* shows: its likelihood N(r | 0, K - K V M⁻¹ Vᵀ K + σ0² I)
  (inference/discrepancy/kalman.py, O(n p²)) identifies the hyperparameters h, and θ* with them.
- s moves the projection: θ* = θ_true + c, c = (XᵀWX)⁻¹ s ~ N(0, S(h)),
  S(h) = (XᵀWX)⁻¹ Xᵀ W K W X (XᵀWX)⁻¹ (``projection_covariance``), which no data can learn.

So the interval of θ_true is that of θ* widened by S(h): centred on the projection, its width set
by the kernel (the sum of the two is the sandwich variance of weighted least squares under the
discrepancy). ``fit`` computes both parts for each kernel and weighs the kernels by their maximum
orthogonal likelihood (``kernel_weights``): the centre never moves with the kernel, and the width
changes continuously with the data. ``sample`` samples θ* and h, and draws c per draw
(``draw_offsets``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayes_dnlr.inference.discrepancy import gp, kalman

EVEN = 1e-3     # weights within 0.1 % of 1: an even grid whose times were rounded (W = I)


def is_even(w: np.ndarray) -> bool:
    """True when the weights are all 1 to within ``EVEN``: an even grid, W = I, ordinary least
    squares (times written with a few digits make the steps of an even grid differ by rounding)."""
    return bool(np.all(np.abs(np.asarray(w) - 1.0) <= EVEN))


def quadrature_weights(x: np.ndarray) -> np.ndarray:
    """Weights of the sorted axis x for ∫ f dx ≈ Σ w_i f(x_i), scaled to mean 1: the half-distance
    to each neighbour, the end points mirrored (so an even grid has w = 1 everywhere, exactly when
    its steps differ by less than ``EVEN``; repeated points share their cell)."""
    x = np.asarray(x, dtype=float)
    n = x.size
    if n < 3:
        return np.ones(n)
    d = np.diff(x)
    w = np.empty(n)
    w[1:-1] = 0.5 * (d[:-1] + d[1:])
    w[0], w[-1] = d[0], d[-1]
    total = w.sum()
    if not total > 0:
        return np.ones(n)
    w = w * (n / total)
    return np.ones(n) if is_even(w) else w


@dataclass(frozen=True)
class Columns:
    """The constraint of the orthogonal discrepancy on one test, in the order of its axis."""

    names: list[str]            # the free parameters, the order of X's columns
    log: np.ndarray             # (p,) True: the column is ∂y/∂ln θ (a time constant)
    X: np.ndarray               # (n, p) ∂y/∂u at θ*
    weights: np.ndarray         # (n,) quadrature weights, mean 1
    scale: np.ndarray           # (p,) column norms of W X
    V: np.ndarray               # (n, p) W X / scale: the columns the likelihood conditions on
    B: np.ndarray               # (p, p) Xᵀ W X

    @property
    def p(self) -> int:
        return len(self.names)


def make_columns(names: list[str], log: np.ndarray, X: np.ndarray, x: np.ndarray) -> Columns:
    """Columns from X = ∂y/∂u (n, p) in axis order on the sorted axis x."""
    X = np.ascontiguousarray(X, dtype=float)
    w = quadrature_weights(x)
    V = w[:, None] * X
    scale = np.linalg.norm(V, axis=0)
    if not np.all(scale > 0):
        zero = [k for k, s in zip(names, scale, strict=True) if not s > 0]
        raise ValueError(f"parameter(s) {zero} have no effect on the window")
    return Columns(list(names), np.asarray(log, dtype=bool), X, w, scale,
                   np.ascontiguousarray(V / scale), X.T @ V)


def terms(cols: Columns, x: np.ndarray, r: np.ndarray, sigma0: float, amplitude: float, length: float,
          kind: str, start: float | None = None) -> dict[str, np.ndarray | float]:
    """The sums of the filter pass (kalman.py ``_sums``) for the residual r (axis order):
    rᵀC⁻¹r, log det C, D = Vᵀ K C⁻¹ V, μ = Vᵀ K C⁻¹ r and M̃ = Vᵀ K̃ V (K = a² K̃)."""
    p = cols.p
    D, Mt, mu = np.empty((p, p)), np.empty((p, p)), np.empty(p)
    quad, logdet = kalman._sums(gp._axis(x), np.ascontiguousarray(r, dtype=float), cols.V, float(sigma0),
                                float(amplitude), float(length), gp.kernel_code(kind), gp._gap(x, start),
                                D, mu, Mt)
    return {"quad": quad, "logdet": logdet, "D": D, "mu": mu, "Mt": Mt}


def log_likelihood(cols: Columns, x: np.ndarray, r: np.ndarray, sigma0: float, amplitude: float,
                   length: float, kind: str, start: float | None = None) -> float:
    """log N(r | 0, K - K V M⁻¹ Vᵀ K + σ0² I): the likelihood of the orthogonal discrepancy."""
    return gp.log_likelihood(x, r, sigma0, amplitude, length, kind, start, cols.V)


def _inverse(B: np.ndarray) -> np.ndarray:
    """B⁻¹ of a symmetric positive definite B, scaled to unit diagonal first (the sensitivities of E
    and tau_max are nearly collinear: ρ ≈ -0.999 leaves XᵀX ill-conditioned unscaled)."""
    d = np.sqrt(np.diag(B))
    inv = np.linalg.inv(B / d[:, None] / d[None, :]) / d[:, None] / d[None, :]
    return 0.5 * (inv + inv.T)


def projection_covariance(cols: Columns, amplitude: float, mtilde: np.ndarray) -> np.ndarray:
    """S = (XᵀWX)⁻¹ Xᵀ W K W X (XᵀWX)⁻¹ in u coordinates, from M̃ = Vᵀ K̃ V of the scaled columns."""
    Binv = _inverse(cols.B)
    M = amplitude**2 * (cols.scale[:, None] * mtilde * cols.scale[None, :])
    S = Binv @ M @ Binv.T
    return 0.5 * (S + S.T)


def star_covariance(cols: Columns, x: np.ndarray, sigma0: float, amplitude: float, length: float,
                    kind: str, start: float | None = None) -> np.ndarray:
    """Var(θ* | h) = (Xᵀ Σ⊥⁻¹ X)⁻¹ in u coordinates, Σ⊥ = K - K V M⁻¹ Vᵀ K + σ0² I. On an even grid
    this is σ0² (XᵀX)⁻¹: the orthogonal discrepancy has no variance along X, only the noise."""
    if is_even(cols.weights) or amplitude == 0:
        return sigma0**2 * _inverse(cols.X.T @ cols.X)
    p = cols.p
    Z, _ = gp.whiten(x, np.column_stack([cols.X, cols.V]), sigma0, amplitude, length, kind, start)
    wX, wV = Z[:, :p], Z[:, p:]
    t = terms(cols, x, np.zeros(x.size), sigma0, amplitude, length, kind, start)
    A = sigma0**2 * t["D"]
    G = cols.V.T @ cols.X - sigma0**2 * (wV.T @ wX)      # Vᵀ K C⁻¹ X
    info = wX.T @ wX + G.T @ np.linalg.solve(A, G)
    return _inverse(0.5 * (info + info.T))


def kernel_weights(log_likelihoods: dict[str, float]) -> dict[str, float]:
    """The kernels' weights ∝ exp(maximum orthogonal log-likelihood) (equal prior odds; each kernel
    has the same hyperparameters): continuous in the data, unlike a choice of one."""
    top = max(log_likelihoods.values())
    raw = {k: math.exp(v - top) for k, v in log_likelihoods.items()}
    total = sum(raw.values())
    return {k: v / total for k, v in raw.items()}


# ------------------------------------------------------------------ M̃ over many lengths

def mtilde(cols: Columns, x: np.ndarray, length: float, kind: str, start: float | None = None) -> np.ndarray:
    """M̃ = Vᵀ K̃ V (unit amplitude) at one length."""
    return terms(cols, x, np.zeros(x.size), 1.0, 1.0, length, kind, start)["Mt"]


class MtildeTable:
    """M̃(ℓ) over [lo, hi] by Chebyshev interpolation in ln ℓ on ``nodes`` exact values (M̃ is an
    analytic function of ln ℓ: 33 nodes over two decades reproduce it to ~1e-12 relative); outside
    [lo, hi] it is computed exactly."""

    def __init__(self, cols: Columns, x: np.ndarray, kind: str, start: float | None, lo: float,
                 hi: float, nodes: int = 33) -> None:
        self.cols, self.x, self.kind, self.start = cols, x, kind, start
        self.lo, self.hi = math.log(lo), math.log(max(hi, lo * (1 + 1e-12)))
        k = np.arange(nodes)
        self.t = np.cos(math.pi * (k + 0.5) / nodes)          # Chebyshev points in [-1, 1]
        values = np.array([mtilde(cols, x, self._length(t), kind, start) for t in self.t])
        self.coef = np.polynomial.chebyshev.chebfit(self.t, values.reshape(nodes, -1), nodes - 1)

    def _length(self, t: float) -> float:
        return math.exp(self.lo + 0.5 * (t + 1.0) * (self.hi - self.lo))

    def __call__(self, lengths: np.ndarray) -> np.ndarray:
        """M̃ (m, p, p) at ``lengths`` (m,)."""
        lengths = np.asarray(lengths, dtype=float)
        p = self.cols.p
        out = np.empty((lengths.size, p, p))
        u = np.log(lengths)
        inside = (u >= self.lo) & (u <= self.hi)
        t = 2.0 * (u[inside] - self.lo) / (self.hi - self.lo) - 1.0 if self.hi > self.lo else u[inside] * 0
        out[inside] = np.polynomial.chebyshev.chebval(t, self.coef).T.reshape(-1, p, p)
        for i in np.flatnonzero(~inside):
            out[i] = mtilde(self.cols, self.x, float(lengths[i]), self.kind, self.start)
        return 0.5 * (out + np.transpose(out, (0, 2, 1)))


# ------------------------------------------------------------------ the offsets of the draws

def draw_offsets(S: np.ndarray, u_star: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 rng: np.random.Generator, tries: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """c ~ N(0, S_i) for each draw i (S: (m, p, p)), conditioned on θ_true = u*_i - c lying in the
    prior box [lo, hi] (u coordinates) by rejection. Returns (c (m, p), tries used (m,)); a draw
    that found no admissible c in ``tries`` keeps c = 0 and reports tries + 1."""
    m, p = u_star.shape
    L = np.linalg.cholesky(S + 1e-300 * np.eye(p)[None])
    c = np.zeros((m, p))
    used = np.full(m, tries + 1)
    todo = np.arange(m)
    for attempt in range(1, tries + 1):
        if not todo.size:
            break
        z = rng.standard_normal((todo.size, p))
        trial = np.einsum("mij,mj->mi", L[todo], z)
        theta = u_star[todo] - trial
        ok = np.all((theta >= lo) & (theta <= hi), axis=1)
        c[todo[ok]] = trial[ok]
        used[todo[ok]] = attempt
        todo = todo[~ok]
    return c, used


def offset_draws(draws: np.ndarray, names: list[str], projection: dict, sampled_kernel: str,
                 cols: Columns, x: np.ndarray, start: float | None, fixed: dict[str, float],
                 bounds: dict[str, tuple[float, float]], seed: int) -> tuple[np.ndarray, dict]:
    """θ_true = θ* - c for every posterior draw (m, ndim) of (θ*, h): c ~ N(0, S(h)) in u
    coordinates, the kernel of each draw picked by fit's weights (``projection["kernels"]``). A draw
    of the sampled kernel uses its own amplitude and length; a draw of another kernel draws them
    from that kernel's Laplace approximation (its maximum and the curvature of ln h). c is
    conditioned on θ_true lying in the prior box ``bounds`` (physical units). Returns the new draws
    and what the offsets did: per parameter the sd of θ* and of c, and how often the prior box
    rejected an offset (a bound that decides part of the answer)."""
    rng = np.random.default_rng(seed)
    m = draws.shape[0]
    kernels = projection["kernels"]
    labels = list(kernels)
    w = np.array([kernels[k]["weight"] for k in labels], dtype=float)
    pick = rng.choice(len(labels), size=m, p=w / w.sum())
    amp = np.empty(m)
    length = np.empty(m)
    for i, k in enumerate(labels):
        sel = pick == i
        if not sel.any():
            continue
        if k == sampled_kernel:
            for arr, key, name in ((amp, "amplitude", "disc_amplitude"), (length, "length", "disc_length")):
                arr[sel] = draws[sel, names.index(name)] if name in names else fixed[key]
        else:
            h = kernels[k]["hyperparameters"]
            free = list(kernels[k].get("estimated") or [])
            cov = np.asarray(kernels[k].get("hyper_log_covariance") or np.zeros((0, 0)), dtype=float)
            for arr, key, name in ((amp, "amplitude", "disc_amplitude"), (length, "length", "disc_length")):
                sd = math.sqrt(max(cov[free.index(name), free.index(name)], 0.0)) if name in free else 0.0
                arr[sel] = h[key] * np.exp(sd * rng.standard_normal(int(sel.sum())))
    S = np.empty((m, cols.p, cols.p))
    Binv = _inverse(cols.B)
    for i, k in enumerate(labels):
        sel = np.flatnonzero(pick == i)
        if not sel.size:
            continue
        lo, hi = float(length[sel].min()), float(length[sel].max())
        table = MtildeTable(cols, x, k, start, lo, hi)
        Mt = table(length[sel])
        M = amp[sel, None, None] ** 2 * (cols.scale[None, :, None] * Mt * cols.scale[None, None, :])
        S[sel] = Binv[None] @ M @ Binv.T[None]
    col = [names.index(k) for k in cols.names]
    star = draws[:, col].copy()
    u = np.where(cols.log[None, :], np.log(np.where(cols.log[None, :], star, 1.0)), star)
    with np.errstate(divide="ignore"):
        lo_u = np.array([(math.log(bounds[k][0]) if bounds[k][0] > 0 else -math.inf) if g else bounds[k][0]
                         for k, g in zip(cols.names, cols.log, strict=True)])
        hi_u = np.array([math.log(bounds[k][1]) if g else bounds[k][1]
                         for k, g in zip(cols.names, cols.log, strict=True)])
    c, tries = draw_offsets(S, u, lo_u, hi_u, rng)
    u_true = u - c
    out = draws.copy()
    with np.errstate(over="ignore"):
        out[:, col] = np.where(cols.log[None, :], np.exp(np.where(cols.log[None, :], u_true, 0.0)), u_true)
    info = {
        "kernel_draws": {k: int((pick == i).sum()) for i, k in enumerate(labels)},
        "sd_star": dict(zip(cols.names, (float(v) for v in star.std(axis=0)), strict=True)),
        "sd_offset_u": dict(zip(cols.names, (float(v) for v in c.std(axis=0)), strict=True)),
        "offsets_rejected_by_prior_box": float(np.mean(tries > 1)),
        "offsets_not_placed": float(np.mean(tries > 100)),
    }
    return out, info


def adjust_draws(draws: np.ndarray, names: list[str], u_names: list[str], log: np.ndarray,
                 model_cov: np.ndarray, target_cov: np.ndarray,
                 bounds: dict[str, tuple[float, float]]) -> tuple[np.ndarray, dict]:
    """The open-faced sandwich adjustment (Shaby 2014) of draws (m, ndim) sampled under a working
    model whose covariance of the parameters ``u_names`` is ``model_cov`` when their estimator's
    covariance is ``target_cov`` (both in u coordinates, ln θ for the time constants): about the
    draws' mean ū, u ↦ ū + T (u - ū), T = chol(target) chol(model)⁻¹, so the adjusted draws have the
    target covariance and keep the shape the sampler found. Draws leaving the prior box are put on
    its edge and counted (a bound that decides part of the answer)."""
    log = np.asarray(log, dtype=bool)
    lo = np.array([bounds[k][0] for k in u_names], dtype=float)
    hi = np.array([bounds[k][1] for k in u_names], dtype=float)
    target_cov, model_cov = _symmetric(target_cov), _symmetric(model_cov)
    # A parameter whose target sd exceeds its prior box's (a uniform's over the box, in u) is one
    # the linearized estimate does not identify (sigma_s of a stress shift the test never reaches):
    # scaled by it, its draws were pushed onto both edges of the box, two spikes where the chain
    # had a spread. Such parameters keep the draws the sampler found; the others are adjusted.
    with np.errstate(divide="ignore", invalid="ignore"):
        lo_u = np.where(log, np.log(np.where(log, lo, 1.0)), lo)
        hi_u = np.where(log, np.log(np.where(log, hi, 1.0)), hi)
    box_sd = (hi_u - lo_u) / math.sqrt(12.0)
    kept = np.sqrt(np.diag(target_cov)) > np.where(np.isfinite(box_sd), box_sd, np.inf)
    adjusted = [i for i in range(len(u_names)) if not kept[i]]
    col = [names.index(u_names[i]) for i in adjusted]
    sub = np.ix_(adjusted, adjusted)
    out = draws.copy()
    outside = np.zeros((draws.shape[0], len(u_names)), dtype=bool)
    if adjusted:
        lg = log[adjusted]
        theta = draws[:, col]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.where(lg[None, :], np.log(np.where(lg[None, :], theta, 1.0)), theta)
        mean = u.mean(axis=0)
        T = np.linalg.cholesky(target_cov[sub]) @ np.linalg.inv(np.linalg.cholesky(model_cov[sub]))
        adj = mean + (u - mean) @ T.T
        with np.errstate(over="ignore"):
            out_theta = np.where(lg[None, :], np.exp(np.where(lg[None, :], adj, 0.0)), adj)
        outside[:, adjusted] = (out_theta < lo[adjusted]) | (out_theta > hi[adjusted])
        out[:, col] = np.clip(out_theta, lo[adjusted], hi[adjusted])
    info = {
        "method": "open-faced sandwich adjustment of the exp posterior's draws (Shaby 2014)",
        "sd_factor": dict(zip(u_names, (float(v) for v in np.sqrt(np.diag(target_cov) / np.diag(model_cov))),
                              strict=True)),
        "draws_on_a_prior_bound": dict(zip(u_names, (float(v) for v in outside.mean(axis=0)), strict=True)),
        "not_identified": [u_names[i] for i in range(len(u_names)) if kept[i]],
    }
    return out, info


def _symmetric(A: np.ndarray) -> np.ndarray:
    A = np.asarray(A, dtype=float)
    return 0.5 * (A + A.T)
