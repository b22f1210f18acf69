"""Frozen copy of the forward model before the compiled kernel (commit 1186b15): the baseline of forward.py.

``integrate`` is the old kernel verbatim; ``OldDNLR`` reproduces the old ``DNLR._phase`` (a full
distinct-steps x modes decay table built with numpy on every call), ``basis`` and ``stress``.
Do not edit: the benchmark measures the new model against exactly this.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bayes_dnlr.data.conversions import haward_thackray_strain as haward_thackray
from bayes_dnlr.model.spectrum import tau_scale, weights

X_RELAXED = 40.0      # exp(-40) = 4e-18: a mode this fast has no memory of the previous step
X_SERIES = 1.0e-4     # below this, φ = (1 - a)/x loses digits: use its series
TINY = 1.0e-250       # states below this are flushed to zero (denormals are slow)

_FASTMATH = {"reassoc", "contract", "nsz"}


@njit(cache=True, fastmath=_FASTMATH, inline="always")
def _flush(v: float) -> float:
    return v if abs(v) > TINY else 0.0


@njit(cache=True, fastmath=_FASTMATH, inline="always")
def _one_minus(a: float, x: float) -> float:
    """1 - a with a = exp(-x), accurate also for tiny x (series)."""
    if x > X_SERIES:
        return 1.0 - a
    return x * (1.0 - x * (0.5 - x * (1.0 / 6.0)))


@njit(cache=True, fastmath=_FASTMATH)
def integrate(dt, eps, h, n_tensile, p,
              tau_t, j0_t, dtu_t, row_t, dec_t,
              tau_r, j0_r, dtu_r, row_r, dec_r,
              want_grad, out, grad_t, grad_r):
    """Integrate all modes over the whole record; write ΣA, ΣB, ΣC per sample into ``out``.

    dt (q-1,) steps; eps, h (q,) strain and ε_HT; the first ``n_tensile`` steps are tensile.
    Per phase: tau (N,) relaxation times, j0 the number of always-relaxed fast modes, dtu the
    distinct step lengths, row (steps of the phase,) the index of each step in dtu, and dec
    (len(dtu), N - j0) the decays exp(-min(dtu/tau, X_RELAXED)) of the active modes.
    out, grad_t, grad_r: (q, 3) arrays; the gradients (d/d ln tau_max, d/d ln tau_max_R) are
    written only when ``want_grad``.
    """
    n = p.shape[0]
    q = eps.shape[0]
    A = np.zeros(n)
    B = p * h[0]
    C = np.zeros(n)
    gA = np.zeros(n)      # d/d ln tau_max (tensile spectrum)
    gB = np.zeros(n)
    rA = np.zeros(n)      # d/d ln tau_max_R (relaxation spectrum)
    rB = np.zeros(n)
    rC = np.zeros(n)
    out[0, 0] = 0.0
    out[0, 1] = h[0]
    out[0, 2] = 0.0
    if want_grad:
        for c in range(3):
            grad_t[0, c] = 0.0
            grad_r[0, c] = 0.0

    # sums over the always-relaxed modes of each phase
    sp_t = 0.0
    spt_t = 0.0
    for j in range(j0_t):
        sp_t += p[j]
        spt_t += p[j] * tau_t[j]
    sp_r = 0.0
    spt_r = 0.0
    for j in range(j0_r):
        sp_r += p[j]
        spt_r += p[j] * tau_r[j]

    # ---- tensile phase (eq. 18)
    if n_tensile > 0:
        pt = p[j0_t:]
        ptau = p[j0_t:] * tau_t[j0_t:]
        itau = 1.0 / tau_t[j0_t:]
        At = A[j0_t:]
        Bt = B[j0_t:]
        gAt = gA[j0_t:]
        gBt = gB[j0_t:]
        nk = n - j0_t
    for i in range(n_tensile):
        d = dt[i]
        u = row_t[i]
        de = eps[i + 1] - eps[i]
        h0 = h[i]
        h1 = h[i + 1]
        dh = h1 - h0
        xs = dtu_t[u]
        idt = 1.0 / xs
        sa = spt_t * de * idt
        sb = sp_t * h1 - spt_t * dh * idt
        if want_grad:
            ga = sa
            gb = -spt_t * dh * idt
            for k in range(nk):
                a = dec_t[u, k]
                x = xs * itau[k]
                x_a = x * a
                pdphi = ptau[k] * _one_minus(a, x) * idt - pt[k] * a
                gAt[k] = _flush(a * gAt[k] + x_a * At[k] + pdphi * de)
                gBt[k] = _flush(a * gBt[k] + x_a * (Bt[k] - pt[k] * h0) - pdphi * dh)
                ga += gAt[k]
                gb += gBt[k]
            grad_t[i + 1, 0] = ga
            grad_t[i + 1, 1] = gb
            grad_t[i + 1, 2] = 0.0
            grad_r[i + 1, 0] = 0.0
            grad_r[i + 1, 1] = 0.0
            grad_r[i + 1, 2] = 0.0
        for k in range(nk):
            a = dec_t[u, k]
            c = ptau[k] * _one_minus(a, xs * itau[k]) * idt
            At[k] = _flush(a * At[k] + c * de)
            Bt[k] = _flush(a * Bt[k] + pt[k] * (h1 - a * h0) - c * dh)
            sa += At[k]
            sb += Bt[k]
        out[i + 1, 0] = sa
        out[i + 1, 1] = sb
        out[i + 1, 2] = 0.0

    if n_tensile >= q - 1:
        return

    # ---- switch to relaxation: the always-relaxed tensile modes take their quasi-static states
    if n_tensile > 0:
        i = n_tensile - 1
        d = dt[i]
        rate_e = (eps[i + 1] - eps[i]) / d
        rate_h = (h[i + 1] - h[i]) / d
        for j in range(j0_t):
            A[j] = p[j] * tau_t[j] * rate_e
            B[j] = p[j] * (h[i + 1] - tau_t[j] * rate_h)
            gA[j] = A[j]
            gB[j] = -p[j] * tau_t[j] * rate_h

    # ---- relaxation phase (section 4.1): same E and weights, spectrum tau_max_R, σ^r = σ_inf
    pr = p[j0_r:]
    ptau = p[j0_r:] * tau_r[j0_r:]
    itau = 1.0 / tau_r[j0_r:]
    Ar = A[j0_r:]
    Br = B[j0_r:]
    Cr = C[j0_r:]
    gAr = gA[j0_r:]
    gBr = gB[j0_r:]
    rAr = rA[j0_r:]
    rBr = rB[j0_r:]
    rCr = rC[j0_r:]
    nk = n - j0_r
    for i in range(n_tensile, q - 1):
        d = dt[i]
        u = row_r[i - n_tensile]
        de = eps[i + 1] - eps[i]
        xs = dtu_r[u]
        idt = 1.0 / xs
        sa = spt_r * de * idt
        sb = 0.0
        sc = sp_r
        if want_grad:
            ga = 0.0
            gb = 0.0
            ra = sa
            rb = 0.0
            rc = 0.0
            for k in range(nk):
                a = dec_r[u, k]
                x = xs * itau[k]
                x_a = x * a
                pdphi = ptau[k] * _one_minus(a, x) * idt - pr[k] * a
                gAr[k] = _flush(a * gAr[k])
                gBr[k] = _flush(a * gBr[k])
                rAr[k] = _flush(a * rAr[k] + x_a * Ar[k] + pdphi * de)
                rBr[k] = _flush(a * rBr[k] + x_a * Br[k])
                rCr[k] = _flush(a * rCr[k] + x_a * (Cr[k] - pr[k]))
                ga += gAr[k]
                gb += gBr[k]
                ra += rAr[k]
                rb += rBr[k]
                rc += rCr[k]
            grad_t[i + 1, 0] = ga
            grad_t[i + 1, 1] = gb
            grad_t[i + 1, 2] = 0.0
            grad_r[i + 1, 0] = ra
            grad_r[i + 1, 1] = rb
            grad_r[i + 1, 2] = rc
        for k in range(nk):
            a = dec_r[u, k]
            oma = _one_minus(a, xs * itau[k])
            Ar[k] = _flush(a * Ar[k] + ptau[k] * oma * idt * de)
            Br[k] = _flush(a * Br[k])
            Cr[k] = _flush(a * Cr[k] + pr[k] * oma)
            sa += Ar[k]
            sb += Br[k]
            sc += Cr[k]
        out[i + 1, 0] = sa
        out[i + 1, 1] = sb
        out[i + 1, 2] = sc


class OldDNLR:
    """The old DNLR model: time, strain (s, Hencky), optional relaxation start."""

    def __init__(self, time, strain, modes=50, decades=6.0, relaxation_start=None):
        self.time = np.ascontiguousarray(time, dtype=float)
        self.strain = np.ascontiguousarray(strain, dtype=float)
        self.h = haward_thackray(self.strain)
        self.dt = np.diff(self.time)
        self.p = weights(modes, decades)
        self.shape = tau_scale(modes, decades)
        if relaxation_start is None:
            self.n_tensile = self.dt.size
        else:
            self.n_tensile = int(np.searchsorted(self.time[1:], relaxation_start, "right"))
        self._phase_t = np.unique(self.dt[: self.n_tensile], return_inverse=True)
        self._phase_r = np.unique(self.dt[self.n_tensile:], return_inverse=True)

    @property
    def has_relaxation(self):
        return self.n_tensile < self.dt.size

    def _phase(self, tau_max, steps):
        dtu, row = steps
        tau = tau_max * self.shape
        if dtu.size == 0:
            return tau, 0, np.ones(1), np.zeros(1, dtype=np.int64), np.ones((1, 1))
        j0 = int(np.searchsorted(tau, dtu[0] / X_RELAXED, "left"))
        x = np.multiply.outer(dtu, -1.0 / tau[j0:])
        np.maximum(x, -X_RELAXED, out=x)
        np.exp(x, out=x)
        return tau, j0, dtu, row.astype(np.int64, copy=False), x

    def basis(self, tau_max, tau_max_R=None, grad=False):
        if not self.has_relaxation:
            tau_max_R = tau_max
        q = self.time.size
        out = np.empty((q, 3))
        gt = np.empty((q, 3)) if grad else np.empty((1, 3))
        gr = np.empty((q, 3)) if grad else np.empty((1, 3))
        tt, j0t, dtut, rowt, dect = self._phase(float(tau_max), self._phase_t)
        tr, j0r, dtur, rowr, decr = self._phase(float(tau_max_R), self._phase_r)
        integrate(self.dt, self.strain, self.h, self.n_tensile, self.p,
                  tt, j0t, dtut, rowt, dect, tr, j0r, dtur, rowr, decr, grad, out, gt, gr)
        return out

    def stress(self, params):
        b = self.basis(params["tau_max"], params.get("tau_max_R"))
        s = params["E"] * b[:, 0] + params["G"] * b[:, 1]
        if self.has_relaxation:
            s = s + params["sigma_inf"] * b[:, 2]
        return s

    def stress_batch(self, theta, names):
        col = {k: list(names).index(k) for k in names}
        out = np.empty((theta.shape[0], self.time.size))
        for k, row in enumerate(theta):
            tau_r = row[col["tau_max_R"]] if self.has_relaxation else None
            b = self.basis(row[col["tau_max"]], tau_r)
            s = row[col["E"]] * b[:, 0] + row[col["G"]] * b[:, 1]
            if self.has_relaxation:
                s += row[col["sigma_inf"]] * b[:, 2]
            out[k] = s
        return out
