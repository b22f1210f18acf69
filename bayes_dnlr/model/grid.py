"""The parameter-free grid of one strain history, prepared once for the compiled kernel
(model/kernel.py): the step table, the step *levels* and the spectrum.

Decays without a table over all steps (O(N) memory, cost linear in q): the steps of each phase
are grouped once per grid (``step_levels``) into *levels*:

- exact levels: few distinct step lengths (uniform grids, timestamps on a clock tick): a level is
  a distinct step, its decays are computed once per call, each step only reads them;
- quantized levels (jittered grids): geometric levels Δ_L with spacing LEVEL_SPACING; a step
  Δ = Δ_L + ρ has a = a_L·exp(-ρ/tau) with |ρ/tau| <= 0.1, a short polynomial, and
  1 - a = (1 - a_L) + a_L (1 - exp(-ρ/tau)) without cancellation;
- steps in sparse regions (levels with fewer than MIN_LEVEL_COUNT steps) take a full exp.

Grid data (``DNLR.kernel_args``, a ``Grid`` named tuple built by ``grid_arrays``):

    steps      float64 (q-1, 6)  per step i (t_i -> t_i+1), columns DT, IDT, DE, DH, H1, RHO:
                                 Δ, 1/Δ, Δε, Δh, h_{i+1}, ρ
    level      int64   (q-1,)    the step's level within its phase, -1 for a full exp
    levels     float64 (n_t+n_r,) the level step lengths Δ_L, tensile levels first
    p, shape   float64 (N,)      the weights p_j at the exponent alpha0 = ½ and the spectrum shape
    log_shape                    tau_j/tau_max and its ln (eq. 12-14); other exponents alpha
    alpha0                       (p_j ∝ tau_j^alpha) are computed per call (``mode_weights``)
    n_tensile, n_levels_t, n_levels_r, exact_t, exact_r, h0, d_min_t, d_min_r: the tensile step
                                 count, level counts and kinds per phase, h_0 and the shortest
                                 step of each phase

Plain numpy: the compiled code is in kernel.py, which reads the grid through these names.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from bayes_dnlr.model.kernel import DE, DH, DT, H1, IDT, RHO, X_RELAXED
from bayes_dnlr.model.reduced_time import EYRING_END, EYRING_STEP, LATTICE_BITS

LEVEL_SPACING = 0.005   # ln(Δ_L+1/Δ_L) of quantized levels: |ρ|/Δ_L <= 0.0025, |ρ/tau| <= 0.0025 x
LEVEL_RANGE = 2.0       # only steps up to 2x the shortest of their phase get a level: active modes
                        # then have x_L <= 80 and |ρ/tau| <= 0.2 (longer steps take a full exp)
MIN_LEVEL_COUNT = 4     # a quantized level must serve this many steps, else they take a full exp
EXACT_LEVELS_MAX = 256  # at most this many exact levels (and at most 1/8 of the steps, or 16)


class Grid(NamedTuple):
    """The parameter-free data of one strain history (module docstring), built by ``grid_arrays``."""

    steps: np.ndarray       # (q-1, 6): DT, IDT, DE, DH, H1, RHO
    level: np.ndarray       # (q-1,) int64: the step's level in its phase, -1 for a full exp
    levels: np.ndarray      # (n_levels_t + n_levels_r,): Δ_L, tensile levels first
    p: np.ndarray           # (N,): the weights p_j at the exponent alpha0 (eq. 12)
    shape: np.ndarray       # (N,): tau_j / tau_max (eq. 14)
    log_shape: np.ndarray   # (N,): ln(tau_j / tau_max), for the weights at another exponent
    alpha0: float           # the exponent of p: ½, Cunat's universal spectrum
    n_tensile: int          # steps of the tensile phase (the first ones)
    n_levels_t: int
    n_levels_r: int
    exact_t: bool           # the tensile phase uses exact levels
    exact_r: bool
    h0: float               # ε_HT at the first sample
    d_min_t: float          # shortest step of each phase (1.0 for an empty phase)
    d_min_r: float
    log_dt: np.ndarray      # (q-1,): ln Δ of each step, for the shifted model's reduced steps
    lattice_a: np.ndarray   # (K, n): the decay lattice of the shifted model (``decay_lattice``)
    lattice_om: np.ndarray
    lattice_step: float     # its spacing h in ln x
    eyring: np.ndarray      # (k, 2): ln(x/sinh x) and its slope at x = k·EYRING_STEP (``eyring_table``)


def step_levels(steps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Group the step lengths of one phase into levels (see the module docstring).

    Returns (levels, index of each step's level or -1, ρ = step - level, exact). Exact levels when
    the distinct lengths are few: at most EXACT_LEVELS_MAX and at most max(16, steps/8).
    """
    steps = np.asarray(steps, dtype=float)
    if steps.size == 0:
        return np.empty(0), np.empty(0, dtype=np.int64), np.empty(0), True
    distinct, inverse = np.unique(steps, return_inverse=True)
    if distinct.size <= min(EXACT_LEVELS_MAX, max(16, steps.size // 8)):
        return distinct, inverse.astype(np.int64), np.zeros(steps.size), True
    bins = np.rint(np.log(steps / distinct[0]) / LEVEL_SPACING).astype(np.int64)
    bins[steps > LEVEL_RANGE * distinct[0]] = -1          # long steps: a full exp
    used, which, counts = np.unique(bins, return_inverse=True, return_counts=True)
    keep = (counts >= MIN_LEVEL_COUNT) & (used >= 0)
    new_index = np.cumsum(keep) - 1
    levels = distinct[0] * np.exp(used[keep] * LEVEL_SPACING)
    index = np.where(keep[which], new_index[which], -1).astype(np.int64)
    rho = np.zeros(steps.size)
    on_level = index >= 0
    rho[on_level] = steps[on_level] - levels[index[on_level]]
    return levels, index, rho, False




LATTICE_POINTS = 1 << LATTICE_BITS    # K = 256, lattice points per spacing of two modes' ln tau
LATTICE_SLOW_END = 1e-9  # the lattice reaches down to this x; slower modes take 1 - a = x - x²/2
_LATTICES: dict[tuple[int, float], tuple[np.ndarray, np.ndarray, float]] = {}


def decay_lattice(shape: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The decays of the shifted model (kernel ``_shift_phase``) on a lattice in ln x: with
    h = ln(tau_{j+1}/tau_j)/K and x_k = X_RELAXED e^{-k h}, k = K n + κ, the tables
    (a, 1 - a)[κ, n] = (e^{-x_k}, 1 - e^{-x_k}) for n up to the slow end. A step whose reduced
    length places mode j at k_j places mode j + 1 at k_j + K: the modes of a step read one row κ,
    contiguously. Built once per spectrum shape (modes, decades) and shared by every grid."""
    n = shape.size
    ln_ratio = float(np.log(shape[1] / shape[0])) if n > 1 else 1.0
    key = (n, ln_ratio)
    hit = _LATTICES.get(key)
    if hit is not None:
        return hit
    h = ln_ratio / LATTICE_POINTS
    cols = int(np.ceil(np.log(X_RELAXED / LATTICE_SLOW_END) / ln_ratio)) + 1
    k = LATTICE_POINTS * np.arange(cols)[None, :] + np.arange(LATTICE_POINTS)[:, None]
    x = X_RELAXED * np.exp(-k * h)
    hit = (np.ascontiguousarray(np.exp(-x)), np.ascontiguousarray(-np.expm1(-x)), h)
    _LATTICES[key] = hit
    return hit


def eyring_table() -> np.ndarray:
    """ln(x/sinh x) and its derivative 1/x - coth x at the nodes k·EYRING_STEP up to EYRING_END
    (and one node past it), for the kernel's cubic Hermite interpolation (``_log_eyring``)."""
    global _EYRING
    if _EYRING is None:
        from bayes_dnlr.model.shift import log_stress_shift

        x = np.arange(int(round(EYRING_END / EYRING_STEP)) + 2) * EYRING_STEP
        slope = np.zeros_like(x)
        big = x > 1e-3
        slope[big] = 1.0 / x[big] - 1.0 / np.tanh(x[big])
        slope[~big] = -x[~big] / 3.0 + x[~big] ** 3 / 45.0
        _EYRING = np.ascontiguousarray(np.column_stack([log_stress_shift(x, 1.0), slope]))
    return _EYRING


_EYRING: np.ndarray | None = None


def grid_arrays(time: np.ndarray, strain: np.ndarray, h: np.ndarray, n_tensile: int,
                p: np.ndarray, shape: np.ndarray, alpha0: float = 0.5) -> Grid:
    """The parameter-free ``Grid`` of ``stress_into`` and ``integrate`` (module docstring); p are
    the weights at the exponent alpha0 (eq. 12: ½)."""
    dt = np.diff(time)
    n_steps = dt.size
    fg = np.empty((n_steps, 6))
    fg[:, DT] = dt
    fg[:, IDT] = 1.0 / dt
    fg[:, DE] = np.diff(strain)
    fg[:, DH] = np.diff(h)
    fg[:, H1] = h[1:]
    lev_t, idx_t, rho_t, exact_t = step_levels(dt[:n_tensile])
    lev_r, idx_r, rho_r, exact_r = step_levels(dt[n_tensile:])
    fg[:, RHO] = np.concatenate([rho_t, rho_r])
    lattice = decay_lattice(np.ascontiguousarray(shape, dtype=float))
    return Grid(
        steps=fg, level=np.concatenate([idx_t, idx_r]).astype(np.int64),
        levels=np.concatenate([lev_t, lev_r]), p=np.ascontiguousarray(p, dtype=float),
        shape=np.ascontiguousarray(shape, dtype=float),
        log_shape=np.log(np.ascontiguousarray(shape, dtype=float)), alpha0=float(alpha0),
        n_tensile=int(n_tensile),
        n_levels_t=int(lev_t.size), n_levels_r=int(lev_r.size), exact_t=bool(exact_t),
        exact_r=bool(exact_r), h0=float(h[0]),
        d_min_t=float(dt[:n_tensile].min()) if n_tensile > 0 else 1.0,
        d_min_r=float(dt[n_tensile:].min()) if n_tensile < n_steps else 1.0,
        log_dt=np.log(dt), lattice_a=lattice[0], lattice_om=lattice[1], lattice_step=lattice[2],
        eyring=eyring_table())
