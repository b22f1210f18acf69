"""The paper's parameters, an ideal ramp (and hold), and the model's independent reference: the
modal stresses integrated by Radau (the ODE of eq. 10-14), for the model's and the kernel's tests."""

from __future__ import annotations

import numpy as np
from scipy.integrate import Radau, solve_ivp

from bayes_dnlr.data.conversions import haward_thackray_strain as haward_thackray
from bayes_dnlr.model import relaxation_times, weights

TABLE3_5E3 = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}   # paper Table 3, interval II, 5e-3 1/s
RELAX = {**TABLE3_5E3, "sigma_inf": 90.0, "tau_max_R": 40.0}


def ramp(rate: float, strain_max: float, n: int, hold: float = 0.0, n_hold: int = 0):
    """Ideal ramp (and hold) with the kink on a sample."""
    t_ramp = strain_max / rate
    t = np.linspace(0.0, t_ramp, n)
    if hold > 0:
        t = np.concatenate([t, t_ramp + np.linspace(0.0, hold, n_hold + 1)[1:]])
    return t, np.minimum(rate * t, strain_max)


# Radau's tolerances: its solution then agrees with the model to 2e-12 relative (rtol 1e-11 gave
# 1e-14 for three times the solver steps), far inside the 1e-8 the tests ask of the model
RTOL, ATOL = 1e-9, 1e-11


class _DecoupledRadau(Radau):
    """scipy's Radau, its Newton matrices (c/h I - J) solved as the diagonal matrices they are: the
    modes are decoupled, so J is diagonal, and a diagonal LU is its diagonal. The same steps and
    the same numbers (4e-16 relative from the dense LU's), at 40 % of the CPU: scipy's dense
    lu_factor and lu_solve of a 50 x 50 matrix cost more in their checks than in arithmetic. (Were
    scipy to rename these two attributes, the dense LU would be used again: slower, as right.)"""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)

        def lu(a):
            d = np.diagonal(a).copy()
            assert np.count_nonzero(a - np.diag(d)) == 0, "the Jacobian is not diagonal"
            self.nlu += 1
            return d

        self.lu = lu
        self.solve_lu = lambda d, b: b / d


# Radau's end state of a segment, by everything it was computed from (its start state included):
# the three ramp-then-hold tests of test_dnlr.py share their ramp, which is integrated once (the
# same numbers: the same computation); the second and third take 0.4-0.7 s instead of 4
_SEGMENTS: dict[tuple, np.ndarray] = {}


def reference(time, eps, params, modes=50, decades=6.0, relaxation_start=None, smooth_h=False):
    """Sum of the modal stresses by Radau, segment by segment, with the same piecewise-linear
    input as the model (or the exact ε_HT(ε(t)) when smooth_h)."""
    tau_t = relaxation_times(params["tau_max"], modes, decades)
    p = weights(modes, decades)
    h = haward_thackray(eps)
    y = p * params["G"] * h[0]
    out = [y.sum()]
    for i in range(time.size - 1):
        t0, t1 = time[i], time[i + 1]
        rate = (eps[i + 1] - eps[i]) / (t1 - t0)
        relax = relaxation_start is not None and t1 > relaxation_start
        tau = relaxation_times(params["tau_max_R"], modes, decades) if relax else tau_t
        key = (t0, t1, eps[i], eps[i + 1], h[i], h[i + 1], relax, smooth_h, modes, decades,
               params["E"], params["sigma_inf"] if relax else params["G"], tau.tobytes(), y.tobytes())
        if key in _SEGMENTS:
            y = _SEGMENTS[key]
            out.append(y.sum())
            continue

        def hr(t, t0=t0, t1=t1, i=i, rate=rate):
            if smooth_h:
                return haward_thackray(eps[i] + rate * (t - t0))
            return h[i] + (h[i + 1] - h[i]) * (t - t0) / (t1 - t0)

        def rhs(t, s, tau=tau, rate=rate, relax=relax, hr=hr):
            target = params["sigma_inf"] if relax else params["G"] * hr(t)
            return p * params["E"] * rate - (s - p * target) / tau

        sol = solve_ivp(rhs, (t0, t1), y, method=_DecoupledRadau, rtol=RTOL, atol=ATOL,
                        jac=lambda t, s, tau=tau: np.diag(-1.0 / tau))
        assert sol.success, sol.message
        y = sol.y[:, -1]
        _SEGMENTS[key] = y
        out.append(y.sum())
    return np.array(out)


def rel_err(a, b):
    return np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-3))


def jittered(n: int, jitter: float, seed: int = 3, hold: float = 0.0, n_hold: int = 0):
    """A ramp (then hold) whose steps are scaled by 1 ± jitter at random."""
    t, e = ramp(5e-3, 1.9, n, hold=hold, n_hold=n_hold)
    rng = np.random.default_rng(seed)
    dt = np.diff(t) * (1 + rng.uniform(-jitter, jitter, t.size - 1))
    t = np.concatenate([[0.0], np.cumsum(dt)])
    return t, np.minimum(5e-3 * t, 1.9)
