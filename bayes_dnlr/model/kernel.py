"""The exponential integrator of the DNLR modal equations (paper eq. 18), compiled with numba.

Each mode j obeys  dσ_j/dt = p_j E dε/dt - (σ_j - p_j σ^r(t)) / tau_j  (eq. 10, 18).
Between two samples the input (ε and ε_HT = h) is taken linear in time, and the update over a
step of length Δ is exact. With x = Δ/tau_j, a = exp(-x), φ = (1 - a)/x:

    tensile (σ^r = G h, eq. 17):  A_j <- a A_j + p_j φ Δε
                                  B_j <- a B_j + p_j (h1 - a h0 - φ Δh)
    relaxation (σ^r = σ_inf):     A_j <- a A_j + p_j φ Δε,  B_j <- a B_j,  C_j <- a C_j + p_j (1 - a)

and σ = E ΣA + G ΣB + σ_inf ΣC: linear in E, G, σ_inf for fixed time constants (``integrate``,
the unit responses with their derivatives, used by least squares). For one parameter set the
three sums fold into one state per mode, the distance to the relaxed state D_j = σ_j - p_j σ^r:

    D_j <- a D_j + p_j φ w,   w = E Δε - G Δh (tensile) or E Δε (relaxation),
    σ = G h1 (or σ_inf) + Σ_j D_j                                   (``stress_into``)

Modes with x > X_RELAXED in every step of a phase have forgotten their past (a < 5e-18): their
D_j is the quasi-static p_j tau_j w/Δ, summed in O(1) per step. Only the "active" modes iterate.

Decays without a table over all steps (O(N) memory, cost linear in q): the steps of each phase
are grouped once per grid into *levels* (model/grid.py): exact levels share their decays, computed
once per call; a step on a quantized level Δ_L + ρ takes a = a_L·exp(-ρ/tau) by a short
polynomial; the few others a full exp.

exp is computed by ``decay``, an inlined polynomial (Cody-Waite reduction, degree-12 Estrin,
2 ulp) that the compiler vectorises over modes (llvmlite has no SVML: a libm exp costs 10-15 ns).
The same routines serve ``integrate`` and ``stress_into``, so both agree to rounding.

The grid (``DNLR.kernel_args``) is a ``grid.Grid`` named tuple; its step table's columns are DT,
IDT, DE, DH, H1, RHO below. Its weights p_j are those of eq. 12 (alpha0 = ½); other exponents
alpha (p_j ∝ tau_j^alpha) are computed per call (``mode_weights``).

The derivatives with respect to ln(tau_max) and ln(tau_max_R) are carried forward-mode in
``integrate`` (exact): d a/d ln tau = x a, d φ/d ln tau = φ - a.

numba's on-disk cache does not notice changes in a helper imported from another module: modules
whose njit functions call these (reduced_time.py, fused.py) key them on this file (``depend_on``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

try:
    from numba import njit, prange
except ImportError as err:  # pragma: no cover - exercised only without numba
    raise ImportError(
        "bayes_dnlr needs numba for its forward model: pip install 'numba>=0.60' "
        "(or reinstall the package with `make install`)") from err

X_RELAXED = 40.0        # exp(-40) = 4e-18: a mode this fast has no memory of the previous step
TINY = 1.0e-200         # states below this are flushed to zero (denormals are slow)
DT, IDT, DE, DH, H1, RHO = 0, 1, 2, 3, 4, 5    # the columns of Grid.steps (model/grid.py)

# no "contract" (FMA): compiled and cache-loaded code fused differently, so first runs were 1 ulp off
FASTMATH = {"reassoc", "nsz"}

_LOG2E = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01    # 0x3fe62e42fee00000: n·_LN2_HI is exact
_LN2_LO = 1.90821492927058770002e-10
_C = [1.0 / math.factorial(m + 1) for m in range(13)]   # expm1(r)/r = Σ r^m/(m+1)!
_C0, _C1, _C2, _C3, _C4, _C5, _C6, _C7, _C8, _C9, _C10, _C11, _C12 = _C

# Table kinds of _level_tables
_TAB_DECAY = 0      # (a_L, 1 - a_L): integrate
_TAB_EXACT = 1      # (a_L, p tau (1 - a_L)/Δ_L): stress on exact levels
_TAB_QUANT = 2      # (a_L, p tau (1 - a_L), p tau a_L): stress on quantized levels


@njit(cache=True, fastmath=FASTMATH, inline="always")
def decay(x):
    """(exp(-x), 1 - exp(-x)) for 0 <= x <= 40, to 2 and 4 ulp, branch-free (vectorises).

    x = n ln2 - r, |r| <= ln2/2; Q(r) = expm1(r)/r, degree 12 by Estrin; exp(-x) = 2^-n (1 + r Q),
    the power of two put into the exponent bits. For n = 0, 1 - exp(-x) = x Q(-x) keeps full
    relative accuracy for tiny x. floor (not a magic-constant rounding) keeps it correct under
    fastmath reassociation.
    """
    n = np.floor(x * _LOG2E + 0.5)
    r = (n * _LN2_HI - x) + n * _LN2_LO
    r2 = r * r
    r4 = r2 * r2
    q = (((_C0 + _C1 * r) + (_C2 + _C3 * r) * r2) + ((_C4 + _C5 * r) + (_C6 + _C7 * r) * r2) * r4
         + (((_C8 + _C9 * r) + (_C10 + _C11 * r) * r2) + _C12 * r4) * (r4 * r4))
    e = 1.0 + r * q
    ni = np.int64(np.int32(n))
    a = np.int64(np.float64(e).view(np.int64) - (ni << 52)).view(np.float64)
    om = x * q if n == 0.0 else 1.0 - a
    return a, om


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _rho_powers(rho):
    """Coefficients of 1 - exp(-ρ/tau) = Σ_{m=1..6} c_m (1/tau)^m, c_m = -(-ρ)^m/m!."""
    c1 = rho
    c2 = -0.5 * rho * c1
    c3 = -(1.0 / 3.0) * rho * c2
    c4 = -0.25 * rho * c3
    c5 = -0.2 * rho * c4
    c6 = -(1.0 / 6.0) * rho * c5
    return c1, c2, c3, c4, c5, c6


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _one_minus_exp_small(it, c1, c2, c3, c4, c5, c6):
    """1 - exp(-z), z = ρ·it, by Horner in it with the step's coefficients (``_rho_powers``).

    For a step Δ_L + ρ on a level, a = a_L (1 - u): with |z| <= 0.0025 x_L the absolute error
    of a is below e^-x (0.0025 x)^7/7! < 1e-19 for every x (and |z| <= 0.2 for active modes).
    """
    return it * (c1 + it * (c2 + it * (c3 + it * (c4 + it * (c5 + it * c6)))))


@njit(cache=True, fastmath=FASTMATH, inline="always")
def flush_tiny(v):
    return v if abs(v) > TINY else 0.0


@njit(cache=True, fastmath=FASTMATH)
def _level_tables(lev, itau, ptau, kind):
    """Decays of every level for the active modes, x = min(Δ_L/tau_k, X_RELAXED): three (levels,
    modes) tables whose content depends on ``kind`` (_TAB_DECAY, _TAB_EXACT, _TAB_QUANT)."""
    nl = lev.size
    nk = itau.size
    t1 = np.empty((nl, nk))
    t2 = np.empty((nl, nk))
    t3 = np.empty((nl if kind == _TAB_QUANT else 0, nk))
    for m in range(nl):
        d = lev[m]
        for k in range(nk):
            a, om = decay(min(d * itau[k], X_RELAXED))
            t1[m, k] = a
            t2[m, k] = om
        if kind == _TAB_EXACT:
            idl = 1.0 / d
            for k in range(nk):
                t2[m, k] = ptau[k] * t2[m, k] * idl
        elif kind == _TAB_QUANT:
            for k in range(nk):
                t3[m, k] = ptau[k] * t1[m, k]
                t2[m, k] = ptau[k] * t2[m, k]
    return t1, t2, t3


class PhaseTables(NamedTuple):
    """What one phase needs for one time constant: modes 0..j0-1 are always relaxed; the active
    ones have 1/tau_k and p_k tau_k; sums over the relaxed ones; the level tables."""

    j0: int
    tau_max: float
    itau: np.ndarray
    ptau: np.ndarray
    spt: float              # Σ p_j tau_j over the relaxed modes
    sp: float               # Σ p_j over the relaxed modes
    t1: np.ndarray
    t2: np.ndarray
    t3: np.ndarray


@njit(cache=True, fastmath=FASTMATH)
def mode_weights(grid, alpha):
    """p_j = (tau_j/tau_max)^alpha / Σ_k (tau_k/tau_max)^alpha (eq. 12 with the exponent alpha):
    the grid's own p at its exponent alpha0 (so that results at ½ are the paper's bit for bit),
    else computed, the largest term scaled to 1 (no overflow for any alpha)."""
    if alpha == grid.alpha0:
        return grid.p
    ls = grid.log_shape
    top = alpha * ls[0]
    for j in range(ls.size):
        top = max(top, alpha * ls[j])
    w = np.empty(ls.size)
    total = 0.0
    for j in range(ls.size):
        w[j] = math.exp(alpha * ls[j] - top)
        total += w[j]
    for j in range(ls.size):
        w[j] /= total
    return w


@njit(cache=True, fastmath=FASTMATH)
def _phase_tables(grid, p, tau_max, relaxation, for_stress):
    """Relaxed-mode count, active spectrum and level tables of one phase (relaxation: False
    tensile, True relaxation; for_stress: False gives the _TAB_DECAY tables of integrate, True
    those of the stress). p: the weights of the modes.

    Modes with d_min/tau_j > X_RELAXED are relaxed in every step of the phase."""
    shape = grid.shape
    d_min = grid.d_min_r if relaxation else grid.d_min_t
    j0 = 0
    for j in range(shape.size):
        if d_min > X_RELAXED * tau_max * shape[j]:
            j0 = j + 1
    nk = p.size - j0
    itau = np.empty(nk)
    ptau = np.empty(nk)
    for k in range(nk):
        tau = tau_max * shape[j0 + k]
        itau[k] = 1.0 / tau
        ptau[k] = p[j0 + k] * tau
    spt = 0.0
    sp = 0.0
    for j in range(j0):
        spt += p[j] * tau_max * shape[j]
        sp += p[j]
    first = grid.n_levels_t if relaxation else 0
    nl = grid.n_levels_r if relaxation else grid.n_levels_t
    kind = _TAB_DECAY
    if for_stress:
        exact = grid.exact_r if relaxation else grid.exact_t
        kind = _TAB_EXACT if exact else _TAB_QUANT
    t1, t2, t3 = _level_tables(grid.levels[first:first + nl], itau, ptau, kind)
    return PhaseTables(j0, tau_max, itau, ptau, spt, sp, t1, t2, t3)


_BLOCK = 32     # steps whose decays integrate computes in one call
PHASE_FLAGS, FIRST_STEP = np.array([False, True]), np.zeros(1, np.int64)  # not literal (docs/performance.md)


@njit(cache=True, fastmath=FASTMATH)
def _block_decays(i0, i1, grid, itau, ta, tom, a_out, om_out):
    """(a, 1 - a) of steps i0..i1-1 (rows 0.. of a_out, om_out) for the active modes: from the
    step's level m (tables a_L, 1 - a_L, with the ρ correction) or by a full exp (m < 0)."""
    fg = grid.steps
    ig = grid.level
    for i in range(i0, i1):
        b = i - i0
        m = ig[i]
        if m >= 0 and fg[i, RHO] == 0.0:
            for k in range(itau.size):
                a_out[b, k] = ta[m, k]
                om_out[b, k] = tom[m, k]
        elif m >= 0:
            c1, c2, c3, c4, c5, c6 = _rho_powers(fg[i, RHO])
            for k in range(itau.size):
                u = _one_minus_exp_small(itau[k], c1, c2, c3, c4, c5, c6)
                a_l = ta[m, k]
                a_out[b, k] = a_l - a_l * u
                om_out[b, k] = tom[m, k] + a_l * u
        else:
            d = fg[i, DT]
            for k in range(itau.size):
                a, om = decay(min(d * itau[k], X_RELAXED))
                a_out[b, k] = a
                om_out[b, k] = om


# ---------------------------------------------------------------- one parameter set: the stress

@njit(cache=True, fastmath=FASTMATH)
def _stress_phase(grid, i0, i1, exact, tabs, e_mod, g_h, s_base, D, out):
    """Advance the active states D over steps i0..i1-1 and write out[i+1]:
    w = E Δε - g_h Δh, σ = g_h h1 + s_base + spt w/Δ + Σ D, with D <- a D + b w per mode.

    Exact levels (t1 = a_L, t2 = p tau (1 - a_L)/Δ_L): blocks of four steps with D in a register
    (the update is two flops per mode: its latency matters, not its arithmetic). Quantized levels
    (t1 = a_L, t2 = p tau (1 - a_L), t3 = p tau a_L): u = 1 - exp(-ρ/tau), a = a_L (1 - u),
    p tau (1 - a) = t2 + t3 u. Steps without a level: a full exp per mode. States below TINY
    are flushed to zero, once per block of four steps (four steps shrink a state by at most
    e^-160: nothing becomes denormal in between).

    The loops are written out here, not in helpers taking arrays: a helper inlined per step would
    add reference counting on every call.
    """
    fg = grid.steps
    ig = grid.level
    ta = tabs.t1
    tb = tabs.t2
    tc = tabs.t3
    itau = tabs.itau
    ptau = tabs.ptau
    spt = tabs.spt
    nk = D.size
    i = i0
    if exact:
        while i + 4 <= i1:
            w0 = e_mod * fg[i, DE] - g_h * fg[i, DH]
            w1 = e_mod * fg[i + 1, DE] - g_h * fg[i + 1, DH]
            w2 = e_mod * fg[i + 2, DE] - g_h * fg[i + 2, DH]
            w3 = e_mod * fg[i + 3, DE] - g_h * fg[i + 3, DH]
            m0 = ig[i]
            m1 = ig[i + 1]
            m2 = ig[i + 2]
            m3 = ig[i + 3]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            for k in range(nk):
                v = ta[m0, k] * D[k] + tb[m0, k] * w0
                s0 += v
                v = ta[m1, k] * v + tb[m1, k] * w1
                s1 += v
                v = ta[m2, k] * v + tb[m2, k] * w2
                s2 += v
                v = ta[m3, k] * v + tb[m3, k] * w3
                s3 += v
                D[k] = flush_tiny(v)
            out[i + 1] = g_h * fg[i, H1] + s_base + spt * w0 * fg[i, IDT] + s0
            out[i + 2] = g_h * fg[i + 1, H1] + s_base + spt * w1 * fg[i + 1, IDT] + s1
            out[i + 3] = g_h * fg[i + 2, H1] + s_base + spt * w2 * fg[i + 2, IDT] + s2
            out[i + 4] = g_h * fg[i + 3, H1] + s_base + spt * w3 * fg[i + 3, IDT] + s3
            i += 4
    for j in range(i, i1):
        w = e_mod * fg[j, DE] - g_h * fg[j, DH]
        wi = w * fg[j, IDT]
        m = ig[j]
        s = 0.0
        flush = (j & 3) == 0
        if exact:
            for k in range(nk):
                v = flush_tiny(ta[m, k] * D[k] + tb[m, k] * w)
                D[k] = v
                s += v
        elif m >= 0:
            c1, c2, c3, c4, c5, c6 = _rho_powers(fg[j, RHO])
            if flush:
                for k in range(nk):
                    u = _one_minus_exp_small(itau[k], c1, c2, c3, c4, c5, c6)
                    a_l = ta[m, k]
                    v = flush_tiny((a_l - a_l * u) * D[k] + (tb[m, k] + tc[m, k] * u) * wi)
                    D[k] = v
                    s += v
            else:
                for k in range(nk):
                    u = _one_minus_exp_small(itau[k], c1, c2, c3, c4, c5, c6)
                    a_l = ta[m, k]
                    v = (a_l - a_l * u) * D[k] + (tb[m, k] + tc[m, k] * u) * wi
                    D[k] = v
                    s += v
        else:
            d = fg[j, DT]
            for k in range(nk):
                a, om = decay(min(d * itau[k], X_RELAXED))
                v = flush_tiny(a * D[k] + ptau[k] * om * wi)
                D[k] = v
                s += v
        out[j + 1] = g_h * fg[j, H1] + s_base + spt * wi + s


@njit(cache=True, fastmath=FASTMATH)
def stress_into(E, G, sigma_inf, tau_max, tau_max_R, alpha, grid, out):
    """True stress of one parameter set at every sample, written into ``out`` (q,). Returns True,
    or False (``out`` filled with NaN) when tau_max, or tau_max_R with a relaxation phase, is not
    a finite positive number, or alpha is not finite. Callable from Python and from other njit
    code, also inside prange.

    Calling convention: ``stress_into(E, G, sigma_inf, tau_max, tau_max_R, alpha, grid, out)``
    with six floats (MPa, MPa, MPa, s, s, and the spectrum exponent: p_j ∝ tau_j^alpha, ½ in
    eq. 12), ``grid = DNLR.kernel_args`` (the ``Grid`` described in the module docstring; pass it
    through unchanged) and ``out`` a float64 C-contiguous array of length q = DNLR.n_points.
    Without a relaxation phase sigma_inf and tau_max_R are ignored (pass any float). Work memory
    is O(N·levels), independent of q; no reduction crosses calls, so the result of one set never
    depends on others or on the thread count.
    """
    fg = grid.steps
    shape = grid.shape
    n = shape.size
    n_steps = fg.shape[0]
    nt = grid.n_tensile
    relax = nt < n_steps
    if not (tau_max > 0.0 and tau_max < np.inf) or (
            relax and not (tau_max_R > 0.0 and tau_max_R < np.inf)) or not (
            alpha > -np.inf and alpha < np.inf):
        out[:] = np.nan
        return False
    p = mode_weights(grid, alpha)
    out[0] = G * grid.h0
    D = np.zeros(n)
    j0t = 0
    if nt > 0:
        tabs = _phase_tables(grid, p, tau_max, PHASE_FLAGS[0], PHASE_FLAGS[1])
        j0t = tabs.j0
        _stress_phase(grid, FIRST_STEP[0], nt, grid.exact_t, tabs, E, G, 0.0, D[j0t:], out)
    if not relax:
        return True
    # the switch (section 4.1): D_j = σ_j - p_j σ_inf; the always-relaxed tensile modes leave
    # their quasi-static states p_j tau_j w/Δ of the last tensile step
    if nt > 0:
        h_sw = fg[nt - 1, H1]
        w_last = (E * fg[nt - 1, DE] - G * fg[nt - 1, DH]) * fg[nt - 1, IDT]
        for j in range(j0t):
            D[j] = p[j] * tau_max * shape[j] * w_last
    else:
        h_sw = grid.h0
    for j in range(n):
        D[j] += p[j] * (G * h_sw - sigma_inf)
    tabs = _phase_tables(grid, p, tau_max_R, PHASE_FLAGS[1], PHASE_FLAGS[1])
    _stress_phase(grid, nt, n_steps, grid.exact_r, tabs, E, 0.0, sigma_inf, D[tabs.j0:], out)
    return True


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def stress_batch_into(theta, grid, out):
    """``stress_into`` for every row of theta (k, 6) = (E, G, sigma_inf, tau_max, tau_max_R, alpha),
    rows of ``out`` (k, q), in parallel over rows (numba threads). Returns the number of rows
    whose time constants were invalid (those rows hold NaN). Each row is computed on its own by
    the same compiled code: the result is bit-identical whatever the thread count."""
    bad = np.zeros(theta.shape[0], dtype=np.int64)
    for r in prange(theta.shape[0]):
        ok = stress_into(theta[r, 0], theta[r, 1], theta[r, 2], theta[r, 3], theta[r, 4],
                         theta[r, 5], grid, out[r])
        bad[r] = 0 if ok else 1
    return bad.sum()


# ------------------------------------------------ unit responses and their derivatives (basis)

@njit(cache=True, fastmath=FASTMATH)
def _integrate_phase(grid, tabs, relaxation, i0, i1, p, cw, states, want_grad, out, g_own,
                     g_other, g_alpha, av, omv):
    """Advance the unit-response states of the active modes over steps i0..i1-1 of one phase and
    write the sums per sample (module docstring: the updates of A, B, C).

    states = (A, B, C, dA, dB, dC, fA, fB), active slices: dA, dB, dC the derivatives with
    respect to the ln of this phase's time constant (forward mode: d a/d ln tau = x a,
    d(p φ)/d ln tau = p φ - p a), fA, fB those with respect to the other phase's, which only decay
    (the relaxation phase carries the tensile derivatives). Tensile: σ^r = G h drives B, C = 0;
    relaxation: σ^r = σ_inf drives C, B decays. Rows i+1 of out, g_own (this phase's derivative),
    g_other (the other one's) and g_alpha (d/d alpha) are written; the derivatives only when
    ``want_grad``. Every state is proportional to its p_j and dp_j/dα = c_j p_j with
    c_j = ln(tau_j/tau_max) - Σ_k p_k ln(tau_k/tau_max) (``cw``), so d/dα of a sum is Σ c_j X_j.
    """
    fg = grid.steps
    A, B, C, dA, dB, dC, fA, fB = states
    itau = tabs.itau
    ptau = tabs.ptau
    spt = tabs.spt
    sp = tabs.sp
    pk = p[tabs.j0:]
    ck = cw[tabs.j0:]
    nk = itau.size
    cspt = 0.0          # Σ c_j p_j tau_j and Σ c_j p_j over the relaxed modes
    csp = 0.0
    for j in range(tabs.j0):
        cspt += cw[j] * p[j] * tabs.tau_max * grid.shape[j]
        csp += cw[j] * p[j]
    for i in range(i0, i1):
        d = fg[i, DT]
        idt = fg[i, IDT]
        de = fg[i, DE]
        dh = fg[i, DH]
        h1 = fg[i, H1]
        h0 = h1 - dh
        b = (i - i0) % _BLOCK
        if b == 0:
            _block_decays(i, min(i + _BLOCK, i1), grid, itau, tabs.t1, tabs.t2, av, omv)
        # the always-relaxed modes sit at their quasi-static states
        sa = spt * de * idt
        if relaxation:
            sb = 0.0
            sc = sp
        else:
            sb = sp * h1 - spt * dh * idt
            sc = 0.0
        if want_grad:
            ga = sa
            gb = 0.0 if relaxation else -spt * dh * idt
            gc = 0.0
            oa = 0.0
            ob = 0.0
            for k in range(nk):
                a = av[b, k]
                x_a = d * itau[k] * a
                pdphi = ptau[k] * omv[b, k] * idt - pk[k] * a
                dA[k] = flush_tiny(a * dA[k] + x_a * A[k] + pdphi * de)
                ga += dA[k]
                if relaxation:
                    dB[k] = flush_tiny(a * dB[k] + x_a * B[k])
                    dC[k] = flush_tiny(a * dC[k] + x_a * (C[k] - pk[k]))
                    fA[k] = flush_tiny(a * fA[k])
                    fB[k] = flush_tiny(a * fB[k])
                    gc += dC[k]
                    oa += fA[k]
                    ob += fB[k]
                else:
                    dB[k] = flush_tiny(a * dB[k] + x_a * (B[k] - pk[k] * h0) - pdphi * dh)
                gb += dB[k]
            g_own[i + 1, 0] = ga
            g_own[i + 1, 1] = gb
            g_own[i + 1, 2] = gc
            g_other[i + 1, 0] = oa
            g_other[i + 1, 1] = ob
            g_other[i + 1, 2] = 0.0
        if relaxation:
            for k in range(nk):
                a = av[b, k]
                oma = omv[b, k]
                A[k] = flush_tiny(a * A[k] + ptau[k] * oma * idt * de)
                B[k] = flush_tiny(a * B[k])
                C[k] = flush_tiny(a * C[k] + pk[k] * oma)
                sa += A[k]
                sb += B[k]
                sc += C[k]
        else:
            for k in range(nk):
                a = av[b, k]
                c = ptau[k] * omv[b, k] * idt
                A[k] = flush_tiny(a * A[k] + c * de)
                B[k] = flush_tiny(a * B[k] + pk[k] * (h1 - a * h0) - c * dh)
                sa += A[k]
                sb += B[k]
        out[i + 1, 0] = sa
        out[i + 1, 1] = sb
        out[i + 1, 2] = sc
        if want_grad:
            ca = cspt * de * idt
            if relaxation:
                cb = 0.0
                cc = csp
                for k in range(nk):
                    ca += ck[k] * A[k]
                    cb += ck[k] * B[k]
                    cc += ck[k] * C[k]
            else:
                cb = csp * h1 - cspt * dh * idt
                cc = 0.0
                for k in range(nk):
                    ca += ck[k] * A[k]
                    cb += ck[k] * B[k]
            g_alpha[i + 1, 0] = ca
            g_alpha[i + 1, 1] = cb
            g_alpha[i + 1, 2] = cc


@njit(cache=True, fastmath=FASTMATH)
def integrate(tau_max, tau_max_R, alpha, grid, want_grad, out, grad_t, grad_r, grad_a):
    """Integrate all modes over the whole record; write ΣA, ΣB, ΣC per sample into ``out`` (q, 3).

    grad_t, grad_r, grad_a (q, 3): d/d ln tau_max, d/d ln tau_max_R and d/d alpha of the same
    sums, written only when ``want_grad``. Without a relaxation phase tau_max_R is ignored. Time
    constants must be finite and positive, alpha finite (checked by the caller).
    """
    fg = grid.steps
    p = mode_weights(grid, alpha)
    shape = grid.shape
    n = p.size
    n_steps = fg.shape[0]
    n_tensile = grid.n_tensile
    A = np.zeros(n)
    B = p * grid.h0
    C = np.zeros(n)
    gA = np.zeros(n)      # d/d ln tau_max (tensile spectrum)
    gB = np.zeros(n)
    gC = np.zeros(n)
    rA = np.zeros(n)      # d/d ln tau_max_R (relaxation spectrum)
    rB = np.zeros(n)
    rC = np.zeros(n)
    av = np.empty((_BLOCK, n))      # decays of a block of steps (active modes)
    omv = np.empty((_BLOCK, n))
    mean_log = 0.0
    for j in range(n):
        mean_log += p[j] * grid.log_shape[j]
    cw = grid.log_shape - mean_log  # dp_j/dα = cw_j p_j
    out[0, 0] = 0.0
    out[0, 1] = grid.h0
    out[0, 2] = 0.0
    if want_grad:
        for c in range(3):
            grad_t[0, c] = 0.0
            grad_r[0, c] = 0.0
            grad_a[0, c] = 0.0      # Σ c_j p_j h_0 = 0

    # ---- tensile phase (eq. 18)
    j0_t = 0
    if n_tensile > 0:
        tabs = _phase_tables(grid, p, tau_max, PHASE_FLAGS[0], PHASE_FLAGS[0])
        j0_t = tabs.j0
        states = (A[j0_t:], B[j0_t:], C[j0_t:], gA[j0_t:], gB[j0_t:], gC[j0_t:], rA[j0_t:], rB[j0_t:])
        _integrate_phase(grid, tabs, False, 0, n_tensile, p, cw, states, want_grad, out, grad_t,
                         grad_r, grad_a, av, omv)

    if n_tensile >= n_steps:
        return

    # ---- switch to relaxation: the always-relaxed tensile modes take their quasi-static states
    if n_tensile > 0:
        i = n_tensile - 1
        idt = fg[i, IDT]
        rate_e = fg[i, DE] * idt
        rate_h = fg[i, DH] * idt
        h1 = fg[i, H1]
        for j in range(j0_t):
            tau = tau_max * shape[j]
            A[j] = p[j] * tau * rate_e
            B[j] = p[j] * (h1 - tau * rate_h)
            gA[j] = A[j]
            gB[j] = -p[j] * tau * rate_h

    # ---- relaxation phase (section 4.1): same E and weights, spectrum tau_max_R, σ^r = σ_inf
    tabs = _phase_tables(grid, p, tau_max_R, PHASE_FLAGS[1], PHASE_FLAGS[0])
    j0 = tabs.j0
    states = (A[j0:], B[j0:], C[j0:], rA[j0:], rB[j0:], rC[j0:], gA[j0:], gB[j0:])
    _integrate_phase(grid, tabs, True, n_tensile, n_steps, p, cw, states, want_grad, out, grad_r,
                     grad_t, grad_a, av, omv)
