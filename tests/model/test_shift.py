"""The shift factor (model/shift.py) and the shifted model (model/reduced_time.py, DNLR with a shift):
the laws against their formulas, the reduced-time kernel against an independent Radau integration of
the coupled modal equations, the folding of a constant temperature into tau_max, and the
central-difference sensitivities against the exact ones."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from bayes_dnlr.data.conversions import haward_thackray_strain
from bayes_dnlr.model import DNLR, relaxation_times, weights
from bayes_dnlr.model.shift import (
    Shift,
    log_stress_shift,
    log_temperature_shift,
    stress_shift,
    temperature_shift,
)

ARRHENIUS = Shift(temperature="arrhenius", reference_temperature=20.0)
EYRING = Shift(stress="eyring")
PARAMS = {"E": 1500.0, "G": 5.0, "tau_max": 30.0}


# ------------------------------------------------------------------------------ the laws

def test_arrhenius_and_wlf_follow_their_formulas():
    # Arrhenius: ln a_T = Ea/R (1/T - 1/T_ref), T in K; slower below T_ref
    ln_a = log_temperature_shift(0.0, "arrhenius", 20.0, Ea=100.0)
    assert ln_a == pytest.approx(100e3 / 8.314462618 * (1 / 273.15 - 1 / 293.15), rel=1e-14)
    assert ln_a > 0 and log_temperature_shift(40.0, "arrhenius", 20.0, Ea=100.0) < 0
    # WLF with the universal constants: log10 a_T = -17.44 ΔT / (51.6 + ΔT)
    assert np.log10(temperature_shift(30.0, "wlf", 20.0, C1=17.44, C2=51.6)) == pytest.approx(
        -17.44 * 10 / 61.6, rel=1e-13)
    assert log_temperature_shift(20.0, "wlf", 20.0, C1=17.44, C2=51.6) == 0.0
    assert log_temperature_shift(-40.0, "wlf", 20.0, C1=17.44, C2=51.6) == math.inf  # below T_ref - C2
    # broadcasting: temperatures (1, m) against parameters (k, 1)
    grid = log_temperature_shift(np.array([[10.0, 30.0]]), "arrhenius", 20.0,
                                 Ea=np.array([[50.0], [100.0]]))
    assert grid.shape == (2, 2) and grid[1, 0] == pytest.approx(2 * grid[0, 0], rel=1e-14)
    with pytest.raises(ValueError, match="reference_temperature"):
        log_temperature_shift(30.0, "arrhenius", None, Ea=100.0)


def test_eyring_is_x_over_sinh_x_without_overflow():
    x = np.array([0.0, 1e-9, 1e-3, 0.5, 3.0, 40.0])
    expected = np.array([1.0, *(v / np.sinh(v) for v in x[1:])])
    assert np.allclose(stress_shift(2.0 * x, 2.0), expected, rtol=1e-14, atol=0)
    assert stress_shift(-3.0, 1.0) == stress_shift(3.0, 1.0)            # |σ|
    big = log_stress_shift(2000.0, 1.0)                                  # sinh(2000) overflows
    assert big == pytest.approx(math.log(4000.0) - 2000.0, rel=1e-15)
    assert log_stress_shift(1.0, math.inf) == 0.0


# ------------------------------------------------------- the kernel against an independent ODE

MODES, DECADES = 8, 3.0


def radau_reference(time, eps, params, shift: Shift, temperature=None):
    """The coupled modal equations dD_j/dt = p_j (E ε' - G h') - D_j/(tau_j a_T a_σ(s)),
    σ = G h + Σ D_j, s the driving stress, integrated by Radau sample to sample (ε and h linear in
    between, as the model takes them): the reduced time without any lag or step."""
    tau = relaxation_times(params["tau_max"], MODES, DECADES)
    p = weights(MODES, DECADES)
    h = haward_thackray_strain(eps)
    E, G = params["E"], params["G"]
    sigma_s = params.get("sigma_s", math.inf)
    ln_at = 0.0
    if shift.temperature != "none":
        ln_at = log_temperature_shift(temperature, shift.temperature, shift.reference_temperature,
                                      Ea=params.get("Ea"))
    D = np.zeros(MODES)
    out = [G * h[0]]
    for i in range(time.size - 1):
        t0, t1 = time[i], time[i + 1]
        de, dh = (eps[i + 1] - eps[i]) / (t1 - t0), (h[i + 1] - h[i]) / (t1 - t0)

        def driving(t, d, t0=t0, i=i, dh=dh):
            hr = G * (h[i] + dh * (t - t0))
            return d.sum() + (0.0 if shift.driving == "overstress" else hr)

        def rhs(t, d, de=de, dh=dh):
            s = driving(t, d)
            la = ln_at + (log_stress_shift(s, sigma_s) if shift.stress != "none" else 0.0)
            return p * (E * de - G * dh) - d * np.exp(-la) / tau

        def jac(t, d):
            # -1/(tau a) on the diagonal, and every mode's rate depends on s = Σ D (+ G h):
            # d(1/a)/ds = -(1/a) d ln a/ds, d ln a/ds = (1/x - coth x) sign(s)/sigma_s
            s = driving(t, d)
            la = ln_at + (log_stress_shift(s, sigma_s) if shift.stress != "none" else 0.0)
            x = abs(s) / sigma_s
            dla = (1.0 / x - 1.0 / math.tanh(x)) * np.sign(s) / sigma_s if x > 1e-8 else 0.0
            return np.diag(-np.exp(-la) / tau) + np.outer(d * np.exp(-la) / tau * dla, np.ones(MODES))

        # rtol 1e-7: the stress agrees with rtol 1e-9 to 1e-11 relative, 1e-5 of the errors measured
        sol = solve_ivp(rhs, (t0, t1), D, method="Radau", rtol=1e-7, atol=1e-9, jac=jac)
        assert sol.success, sol.message
        D = sol.y[:, -1]
        out.append(G * h[i + 1] + D.sum())
    return np.array(out)


def smooth_ramp(n: int):
    """A loading to 3 % strain at 1e-3 1/s, smoothly unloading after it (a cosine in time)."""
    t = np.linspace(0.0, 60.0, n)
    return t, 0.015 * (1.0 - np.cos(np.pi * t / 30.0))


@pytest.mark.parametrize("driving", ["stress", "overstress"])
def test_stress_shift_converges_to_the_ode_at_second_order(driving):
    shift = Shift(stress="eyring", driving=driving)
    params = {**PARAMS, "sigma_s": 2.0}
    errors = []
    for n in (41, 81):
        t, e = smooth_ramp(n)
        model = DNLR(t, e, modes=MODES, decades=DECADES, shift=shift)
        ref = radau_reference(t, e, params, shift)
        errors.append(np.max(np.abs(model.stress(params) - ref)) / np.max(np.abs(ref)))
    # the shift of each step from the stress extrapolated to its middle: second order in Δ
    assert errors[1] < errors[0] / 3.0
    assert errors[1] < 2e-3


def test_temperature_per_row_is_exact_in_reduced_time():
    # a_T per step from the temperature at the step's middle: exact for a temperature that is
    # linear in time up to the midpoint rule of 1/a_T over a step (second order)
    shift = ARRHENIUS
    params = {**PARAMS, "Ea": 150.0}
    errors = []
    for n in (61, 121):
        t, e = smooth_ramp(n)
        temp = 25.0 + 0.5 * t
        model = DNLR(t, e, modes=MODES, decades=DECADES, shift=shift, temperature=temp)
        mid = np.concatenate([[temp[0]], 0.5 * (temp[:-1] + temp[1:])])
        # the reference with a_T constant over each step at its middle temperature: the same
        # reduced time, so it agrees to the integrator's tolerance
        ref = np.empty(n)
        ref[0] = 0.0
        tau = relaxation_times(params["tau_max"], MODES, DECADES)
        p = weights(MODES, DECADES)
        h = haward_thackray_strain(e)
        D = np.zeros(MODES)
        for i in range(n - 1):
            a = temperature_shift(mid[i + 1], "arrhenius", 20.0, Ea=params["Ea"])
            dt = t[i + 1] - t[i]
            w = params["E"] * (e[i + 1] - e[i]) - params["G"] * (h[i + 1] - h[i])
            x = dt / (a * tau)
            D = np.exp(-x) * D + p * (-np.expm1(-x)) / x * w
            ref[i + 1] = params["G"] * h[i + 1] + D.sum()
        errors.append(np.max(np.abs(model.stress(params) - ref)) / np.max(np.abs(ref)))
    assert max(errors) < 1e-12


def test_a_constant_temperature_folds_into_tau_max_bit_for_bit():
    t, e = smooth_ramp(200)
    at = temperature_shift(40.0, "arrhenius", 20.0, Ea=150.0)
    folded = DNLR(t, e, shift=ARRHENIUS, temperature=40.0).stress({**PARAMS, "Ea": 150.0})
    plain = DNLR(t, e).stress({**PARAMS, "tau_max": PARAMS["tau_max"] * at})
    assert np.array_equal(folded, plain)
    # the same temperature logged per row takes the reduced-time kernel: the same stress
    per_row = DNLR(t, e, shift=ARRHENIUS, temperature=np.full(t.size, 40.0))
    assert np.max(np.abs(per_row.stress({**PARAMS, "Ea": 150.0}) - plain)) < 1e-12 * np.abs(plain).max()


def test_an_infinite_sigma_s_is_the_unshifted_model():
    t, e = smooth_ramp(300)
    plain = DNLR(t, e).stress(PARAMS)
    shifted = DNLR(t, e, shift=EYRING).stress({**PARAMS, "sigma_s": math.inf})
    assert np.max(np.abs(shifted - plain)) < 1e-13 * np.abs(plain).max()


def test_peak_driving_holds_the_shift_while_the_stress_falls():
    t, e = smooth_ramp(241)
    params = {**PARAMS, "sigma_s": 2.0}
    stress = DNLR(t, e, shift=Shift(stress="eyring", driving="stress")).stress(params)
    peak = DNLR(t, e, shift=Shift(stress="eyring", driving="peak")).stress(params)
    top = int(np.argmax(stress))
    assert np.array_equal(stress[:top], peak[:top])     # loading: the peak is the stress
    # unloading, while the stress is positive: the modes keep relaxing as fast as at the peak,
    # so the stress falls faster than the stress-driven model's, which stiffens as it unloads
    falling = np.arange(t.size) > top + 5
    falling &= stress > 0
    assert falling.sum() > 20 and np.all(peak[falling] < stress[falling])


# ------------------------------------------------------------------ central-difference Jacobian

def test_jacobian_matches_the_exact_basis_derivatives():
    t, e = smooth_ramp(300)
    model = DNLR(t, e, shift=ARRHENIUS, temperature=20.0)     # a_T = 1: the unshifted model
    J = model.jacobian({**PARAMS, "Ea": 150.0}, ["E", "G", "tau_max"])
    b = DNLR(t, e).basis(PARAMS["tau_max"], grad=True)
    exact = np.column_stack([b.values[:, 0], b.values[:, 1],
                             PARAMS["E"] * b.grad_tau_max[:, 0] + PARAMS["G"] * b.grad_tau_max[:, 1]])
    err = np.max(np.abs(J - exact), axis=0) / np.max(np.abs(exact), axis=0)
    assert np.all(err < 1e-8)


def test_jacobian_of_the_stress_shift_passes_a_taylor_test():
    t, e = smooth_ramp(300)
    model = DNLR(t, e, shift=EYRING)
    names = ["E", "G", "tau_max", "sigma_s"]
    p0 = {**PARAMS, "sigma_s": 2.0}
    J = model.jacobian(p0, names)          # ∂σ/∂u, u = ln tau_max and ln sigma_s
    direction = np.array([30.0, 0.2, 0.05, 0.05])
    f0 = model.stress(p0)
    gaps = []
    for step in (1e-2, 5e-3):
        p = dict(p0)
        for k, d in zip(names, direction, strict=True):
            p[k] = p0[k] * math.exp(step * d) if k in ("tau_max", "sigma_s") else p0[k] + step * d
        gaps.append(np.max(np.abs(model.stress(p) - f0 - step * J @ direction)))
    # the remainder of a correct first-order term is O(step²): halving the step quarters it
    assert gaps[1] < gaps[0] / 3.0


def test_a_shifted_model_has_no_basis_and_checks_its_inputs():
    t, e = smooth_ramp(50)
    with pytest.raises(ValueError, match="no basis"):
        DNLR(t, e, shift=EYRING).basis(10.0)
    with pytest.raises(ValueError, match="needs the test's temperature"):
        DNLR(t, e, shift=ARRHENIUS)
    with pytest.raises(ValueError, match="50 samples"):
        DNLR(t, e, shift=ARRHENIUS, temperature=np.full(3, 20.0))
    with pytest.raises(ValueError, match="sigma_s"):
        DNLR(t, e, shift=EYRING).stress({**PARAMS, "sigma_s": -1.0})
    assert DNLR(t, e, shift=EYRING).parameter_names() == ["E", "G", "tau_max", "sigma_s"]


def test_relaxation_modulus_at_another_temperature_is_the_shifted_curve():
    from bayes_dnlr.model.modulus import relaxation_modulus

    at = temperature_shift(40.0, "arrhenius", 20.0, Ea=200.0)     # faster at 40 °C
    t = np.array([2.0, 20.0, 100.0])
    hot = relaxation_modulus(t, 1000.0, 5.0, 300.0, shift_factor=at)
    assert np.allclose(hot, relaxation_modulus(t / at, 1000.0, 5.0, 300.0), rtol=1e-13)
    assert np.array_equal(relaxation_modulus(t, 1000.0, 5.0, 300.0, shift_factor=1.0),
                          relaxation_modulus(t, 1000.0, 5.0, 300.0))


def test_design_sensitivities_of_the_shifted_model_are_the_exact_ones_without_stress():
    from bayes_dnlr.workflows.design import fisher

    t, e = smooth_ramp(200)
    params = {**PARAMS, "sigma_s": 1e12}               # x = |σ|/sigma_s ~ 1e-11: a_σ = 1
    mask = np.ones(t.size, dtype=bool)
    names = ["E", "G", "tau_max"]
    shifted = fisher._sensitivities(DNLR(t, e, shift=EYRING), params, names, mask, False)
    exact = fisher._sensitivities(DNLR(t, e), PARAMS, names, mask, False)
    assert np.max(np.abs(shifted - exact), axis=0).max() < 1e-7 * np.abs(exact).max()
