"""The shifted model's compiled stress (model/shift.py): the DNLR modes relax in reduced time.

Each mode j obeys dD_j/dt = p_j dw/dt − D_j / (tau_j a_T(T) a_σ(s)), D_j = σ_j − p_j σ^r, with w the
input E ε − σ^r (model/kernel.py). Over one step the shift a = a_T a_σ is taken constant: the
step's reduced length is g = Δ/a, the input linear in reduced time, and the update is exact
(kernel.py's, with x_j = g/tau_j). a_T comes per step from the test's temperature; a_σ = x/sinh x
from the driving stress s at the step's middle, extrapolated from the two last samples, second
order in Δ (docs/theory.md measures its error against a fine-step reference).

No level tables: the reduced step changes with the stress. The decays come from one lattice per
spectrum (model/grid.py ``decay_lattice``) on which a step places every mode by one offset, with
an exact correction of the step's distance to the lattice (``_shift_phase``).

numba's cache keys these functions on this file only: ``numba_cache.depend_on`` adds kernel.py,
whose helpers they inline (module end).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from bayes_dnlr.model import kernel
from bayes_dnlr.model.kernel import (
    DE,
    DH,
    DT,
    FASTMATH,
    FIRST_STEP,
    H1,
    PHASE_FLAGS,
    X_RELAXED,
    decay,
    flush_tiny,
    mode_weights,
)
from bayes_dnlr.numba_cache import depend_on

_LN2 = 0.6931471805599453
_LN_XR = math.log(X_RELAXED)
LOG_SHIFT_LIMIT = 700.0     # |ln(g/tau_max)| is clipped here (e^700: every mode relaxed, or none)
DRIVE_STRESS, DRIVE_PEAK, DRIVE_OVERSTRESS = 0, 1, 2    # shift.DRIVING_CODE
LATTICE_BITS = 8            # K = 256 lattice points per mode spacing (model/grid.py decay_lattice)


EYRING_STEP = 1.0 / 32.0    # node spacing of the table of ln(x/sinh x) (model/grid.py)
EYRING_END = 128.0          # the table's end; beyond it ln(x/sinh x) = ln(2x) - x to 1e-111


@njit(cache=True, fastmath=FASTMATH, inline="always")
def _log_eyring(x, table):
    """ln(x / sinh x) for x >= 0 (model/shift.py ``log_stress_shift``): cubic Hermite between the
    nodes of ``table`` (values and slopes at k·EYRING_STEP; error below 1e-11), ln(2x) - x beyond
    EYRING_END."""
    if x >= EYRING_END:
        return math.log(2.0 * x) - x
    u = x * (1.0 / EYRING_STEP)
    k = np.int64(u)
    t = u - k
    f0 = table[k, 0]
    f1 = table[k + 1, 0]
    d0 = table[k, 1] * EYRING_STEP
    d1 = table[k + 1, 1] * EYRING_STEP
    # Hermite: f0 + t d0 + t² (3Δ - 2 d0 - d1) + t³ (d0 + d1 - 2Δ), Δ = f1 - f0
    df = f1 - f0
    return f0 + t * (d0 + t * ((3.0 * df - 2.0 * d0 - d1) + t * (d0 + d1 - 2.0 * df)))


@njit(cache=True, fastmath=FASTMATH)
def _shift_phase(grid, i0, i1, ps, cps, ish, tm, relax, e_mod, g_h, s_base, inv_ss, driving,
                 ln_at, D, peak, out):
    """Advance the states D over steps i0..i1-1 of one phase in reduced time; write out[i+1].

    Step i has the reduced length g = Δ / (a_T a_σ): ln a_T from ``ln_at`` (per step; none when
    empty: a constant temperature is folded into tm by the caller), ln a_σ = ln(x/sinh x) of the
    driving stress at the step's middle, x = |s| inv_ss, extrapolated from the two last samples
    (``stress_shift_into``). Each mode takes the exact update of a step whose input is linear in
    reduced time, D <- a D + p tau (1 - a) w/g with a = exp(-x_j), x_j = g/tau_j (ps = p·tau/tau_max).

    Decays from the grid's lattice (model/grid.py ``decay_lattice``): tabulated at
    x = X_RELAXED e^{-k h}, h = ln(tau_{j+1}/tau_j)/K, so that one offset k_0 places every mode
    (k_j = k_0 + K j) and the modes read one contiguous row. The step's x_j lie e^{-ε} off the
    lattice by the same |ε| <= h/2 for every mode; a = a_L (1 - t), t = 1 - e^{-δx} with
    δx = x_j (1 - e^{-ε}) (|δx| <= X_RELAXED h/2), by its cubic (absolute error of a below 1e-13).
    Modes past the lattice's slow end (x < 1e-9) take a = 1 - x + x²/2. Modes j < j1
    (x_j > X_RELAXED) are quasi-static, D_j = p_j tau_j w/g, summed by the prefix sums cps in
    O(1); a mode that leaves that set starts from its quasi-static state of the step before. On
    return every D_j holds its state. Returns (ok, the peak driving stress); not ok when the stress
    stopped being finite.
    """
    fg = grid.steps
    ldt = grid.log_dt
    eyring = grid.eyring
    tab_a = grid.lattice_a
    tab_o = grid.lattice_om
    kk_n = tab_a.shape[0]           # K = 2^LATTICE_BITS lattice points per mode spacing
    n_cols = tab_a.shape[1]
    h = grid.lattice_step
    inv_h = 1.0 / h
    ls0 = grid.log_shape[0]
    n = ps.size
    have_at = ln_at.size > 0
    ln_tm = math.log(tm)
    j0 = 0
    w_prev = 0.0
    g_prev = 1.0
    for i in range(i0, i1):
        dt = fg[i, DT]
        if relax:
            w = e_mod * fg[i, DE]
        else:
            w = e_mod * fg[i, DE] - g_h * fg[i, DH]
        # the driving stress at the step's middle, from samples i-1 and i (same relaxed state)
        cur = out[i]
        if driving == DRIVE_OVERSTRESS:
            cur -= s_base if relax else g_h * (fg[i, H1] - fg[i, DH])
        mid = cur
        if i > 0:
            before = out[i - 1]
            if driving == DRIVE_OVERSTRESS:
                before -= s_base if relax else g_h * (fg[i - 1, H1] - fg[i - 1, DH])
            mid = cur + 0.5 * (cur - before) * dt / fg[i - 1, DT]
        if driving == DRIVE_PEAK:
            peak = max(peak, abs(mid))
            mid = peak
        ln_a = _log_eyring(abs(mid) * inv_ss, eyring) if inv_ss > 0.0 else 0.0
        if have_at:
            ln_a += ln_at[i]
        lgt = ldt[i] - ln_tm - ln_a          # ln(g/tau_max); x_j = (g/tau_max)/shape_j
        if not (lgt > -np.inf and lgt < np.inf):
            return False, peak
        lgt = min(max(lgt, -LOG_SHIFT_LIMIT), LOG_SHIFT_LIMIT)
        gt = decay(-lgt)[0]
        g = gt * tm
        # the lattice: mode j at k_j = k0 + K j, u_j = ln(X_RELAXED/x_j) = u0 + j K h
        u0 = _LN_XR - lgt + ls0
        k0 = math.floor(u0 * inv_h + 0.5)
        eps = k0 * h - u0
        m = eps * (1.0 - eps * (0.5 - eps * ((1.0 / 6.0) - eps * (1.0 / 24.0))))   # 1 - e^{-ε}
        ki = np.int64(k0)
        j1 = 0 if ki >= 0 else min(n, (kk_n - 1 - ki) >> LATTICE_BITS)
        kf = ki + kk_n * j1                  # >= 0: the first active mode's lattice index
        n1 = kf >> LATTICE_BITS
        kap = kf & (kk_n - 1)
        j2 = min(n, j1 + max(0, n_cols - n1))
        if j1 < j0:     # modes that leave the quasi-static set: their state of the step before
            c = tm * w_prev / g_prev
            for j in range(j1, j0):
                D[j] = ps[j] * c
        c = tm * w / g
        s = 0.0
        # unsigned indices: numba then tests no negative index (wraparound) and the loops vectorise
        ju1 = np.uint64(j1)
        ju2 = np.uint64(j2)
        off = np.uint64(n1) - ju1       # (mod 2^64) the lattice column of mode j is off + j
        row = np.uint64(kap)
        for j in range(ju1, ju2):
            a_l = tab_a[row, off + j]
            dx = gt * ish[j] * m
            t = dx * (1.0 - dx * (0.5 - dx * (1.0 / 6.0)))
            v = flush_tiny((a_l - a_l * t) * D[j] + ps[j] * (tab_o[row, off + j] + a_l * t) * c)
            D[j] = v
            s += v
        for j in range(ju2, np.uint64(n)):
            x = gt * ish[j]
            om = x - 0.5 * x * x
            v = flush_tiny((1.0 - om) * D[j] + ps[j] * om * c)
            D[j] = v
            s += v
        j0 = j1
        w_prev = w
        g_prev = g
        out[i + 1] = (s_base if relax else g_h * fg[i, H1]) + cps[j1] * c + s
    c = tm * w_prev / g_prev
    for j in range(j0):
        D[j] = ps[j] * c
    return True, peak


@njit(cache=True, fastmath=FASTMATH)
def stress_shift_into(E, G, sigma_inf, tau_max, tau_max_R, alpha, sigma_s, driving, ln_at, grid,
                      out):
    """True stress of one parameter set of the shifted model (model/shift.py), into ``out`` (q,).

    Each mode relaxes in reduced time, dψ = dt/(a_T a_σ): ``ln_at`` (q-1,) holds ln a_T of each
    step (a temperature logged per row), or is empty (no temperature shift, or a constant one that
    the caller folds into tau_max and tau_max_R); a_σ = x/sinh x with x = |s|/sigma_s, s the driving
    stress (``driving``: DRIVE_STRESS the true stress, DRIVE_PEAK the largest so far, DRIVE_OVERSTRESS
    σ − σ^r); sigma_s = inf switches it off. a_σ is taken at the middle of each step from the
    two last samples' stress, extrapolated (s_{i+½} = s_i + ½ (s_i − s_{i−1}) Δ_i/Δ_{i−1}): the step
    stays an exact exponential in reduced time and the lag's error is second order in Δ.

    Returns True, or False (``out`` NaN) for invalid time constants, alpha or sigma_s. Without a
    relaxation phase sigma_inf and tau_max_R are ignored. Same grid as ``stress_into``; every step
    takes its own decays (no level tables: the reduced step depends on the stress).
    """
    fg = grid.steps
    shape = grid.shape
    n = shape.size
    n_steps = fg.shape[0]
    nt = grid.n_tensile
    relax = nt < n_steps
    if not (tau_max > 0.0 and tau_max < np.inf) or (
            relax and not (tau_max_R > 0.0 and tau_max_R < np.inf)) or not (
            alpha > -np.inf and alpha < np.inf) or not (sigma_s > 0.0) or (
            ln_at.size > 0 and ln_at.size != n_steps):
        out[:] = np.nan
        return False
    if ln_at.size > 0:
        for i in range(n_steps):
            if not (ln_at[i] > -np.inf and ln_at[i] < np.inf):
                out[:] = np.nan
                return False
    p = mode_weights(grid, alpha)
    ps = np.empty(n)
    ish = np.empty(n)
    cps = np.zeros(n + 1)       # prefix sums of p_j tau_j / tau_max
    for j in range(n):
        ps[j] = p[j] * shape[j]
        ish[j] = 1.0 / shape[j]
        cps[j + 1] = cps[j] + ps[j]
    inv_ss = 1.0 / sigma_s if sigma_s < np.inf else 0.0
    out[0] = G * grid.h0
    D = np.zeros(n)
    peak = 0.0
    ok = True
    if nt > 0:
        # run-time flag and first step (kernel.PHASE_FLAGS): one compile serves both phases
        ok, peak = _shift_phase(grid, FIRST_STEP[0], nt, ps, cps, ish, tau_max, PHASE_FLAGS[0], E,
                                G, 0.0, inv_ss, driving, ln_at, D, peak, out)
    if not ok:
        out[:] = np.nan
        return False
    if not relax:
        return True
    # the switch (section 4.1): D_j = σ_j - p_j σ_inf (every state is held by _shift_phase)
    h_sw = fg[nt - 1, H1] if nt > 0 else grid.h0
    for j in range(n):
        D[j] += p[j] * (G * h_sw - sigma_inf)
    ok, peak = _shift_phase(grid, nt, n_steps, ps, cps, ish, tau_max_R, PHASE_FLAGS[1], E, 0.0,
                            sigma_inf, inv_ss, driving, ln_at, D, peak, out)
    if not ok:
        out[:] = np.nan
    return ok


@njit(cache=True, fastmath=FASTMATH, parallel=True)
def stress_shift_batch_into(sets, ln_at, driving, grid, out):
    """``stress_shift_into`` for every row of sets (k, 7) = (E, G, sigma_inf, tau_max, tau_max_R,
    alpha, sigma_s) with ln_at (k, q-1) (or (k, 0): no per-step temperature shift), rows of
    ``out`` (k, q), in parallel over rows. Returns the number of invalid rows (NaN)."""
    bad = np.zeros(sets.shape[0], dtype=np.int64)
    for r in prange(sets.shape[0]):
        ok = stress_shift_into(sets[r, 0], sets[r, 1], sets[r, 2], sets[r, 3], sets[r, 4],
                               sets[r, 5], sets[r, 6], driving, ln_at[r], grid, out[r])
        bad[r] = 0 if ok else 1
    return bad.sum()


for _f in (_log_eyring, _shift_phase, stress_shift_into, stress_shift_batch_into):
    depend_on(_f, kernel)
