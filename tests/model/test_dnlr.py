"""The forward model against independent truths: closed forms, solve_ivp, step splitting."""

from __future__ import annotations

import numpy as np
import pytest
from support.forking import in_parent_and_forked_child
from support.model import RELAX, TABLE3_5E3, ramp, reference, rel_err

import bayes_dnlr as bd
from bayes_dnlr.data.conversions import haward_thackray_strain as haward_thackray
from bayes_dnlr.model import DNLR, relaxation_times, weights


def test_weights_and_spectrum():
    p = weights(50, 6)
    tau = relaxation_times(5.79, 50, 6)
    assert p.sum() == pytest.approx(1.0, abs=1e-14)                        # eq. 11
    assert tau[-1] == pytest.approx(5.79) and tau[0] == pytest.approx(5.79e-6)   # eq. 13-14
    assert np.allclose(p, np.sqrt(tau) / np.sqrt(tau).sum())                # eq. 12
    assert np.all(np.diff(tau) > 0)


def test_single_mode_ramp_closed_form():
    # one mode, G = 0: σ(t) = E ε̇ tau (1 - exp(-t/tau)), on a non-uniform grid
    rng = np.random.default_rng(1)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 0.5, 400))])
    rate, tau, E = 4e-3, 3.0, 2000.0
    s = bd.simulate(t, rate * t, {"E": E, "G": 0.0, "tau_max": tau}, modes=1)
    exact = E * rate * tau * (1.0 - np.exp(-t / tau))
    assert np.max(np.abs(s - exact)) < 1e-11 * E * rate * tau


def test_single_mode_relaxation_closed_form():
    # after the switch: σ = σ_inf + (σ_s - σ_inf) exp(-(t - t_s)/tau_R) while the strain is held
    t, e = ramp(5e-3, 0.5, 201, hold=100.0, n_hold=300)
    ts = 100.0
    params = {"E": 1500.0, "G": 3.0, "tau_max": 4.0, "sigma_inf": 10.0, "tau_max_R": 25.0}
    s = bd.simulate(t, e, params, modes=1, relaxation_start=ts)
    s_switch = s[200]
    after = t > ts
    exact = 10.0 + (s_switch - 10.0) * np.exp(-(t[after] - ts) / 25.0)
    assert np.max(np.abs(s[after] - exact)) < 1e-12 * s_switch


def test_relaxed_state_is_stationary():
    # strain held from the start: the initial state is the relaxed state (G ε_HT) and stays
    t = np.linspace(0, 50, 101)
    e = np.full_like(t, 0.3)
    s = bd.simulate(t, e, TABLE3_5E3)
    assert np.allclose(s, TABLE3_5E3["G"] * haward_thackray(0.3), rtol=1e-13)


@pytest.mark.parametrize("jitter", [0.0, 0.15])
def test_ramp_against_radau(jitter):
    t, e = ramp(5e-3, 1.9, 150)
    if jitter:
        rng = np.random.default_rng(3)
        dt = np.diff(t) * (1 + rng.uniform(-jitter, jitter, t.size - 1))
        t = np.concatenate([[0.0], np.cumsum(dt)])
        e = 5e-3 * t
    s = bd.simulate(t, e, TABLE3_5E3)
    assert rel_err(s[1:], reference(t, e, TABLE3_5E3)[1:]) < 1e-8


@pytest.mark.parametrize("tau_r", [0.5, 40.0, 2000.0])
def test_ramp_then_hold_against_radau(tau_r):
    # tau_max_R below, near and above tau_max: the fast-mode bookkeeping differs in each case
    t, e = ramp(5e-3, 2.0, 120, hold=300.0, n_hold=90)
    params = {**RELAX, "tau_max_R": tau_r}
    s = bd.simulate(t, e, params, relaxation_start=400.0)
    ref = reference(t, e, params, relaxation_start=400.0)
    assert rel_err(s[1:], ref[1:]) < 1e-8


def test_smooth_input_converges_to_ode():
    # the exact ODE with ε_HT(ε(t)) (not linear between samples): agreement to 1e-6 relative
    t, e = ramp(5e-3, 1.9, 2000)
    s = bd.simulate(t, e, TABLE3_5E3)
    ref = reference(t[::20], e[::20], TABLE3_5E3, smooth_h=True)
    assert rel_err(s[::20][1:], ref[1:]) < 1e-6


def test_splitting_steps_changes_nothing_for_piecewise_linear_input():
    t, e = ramp(5e-3, 2.0, 101, hold=200.0, n_hold=40)
    rng = np.random.default_rng(0)
    e = e + np.cumsum(rng.normal(0, 1e-4, e.size))      # any piecewise-linear history
    tm = np.sort(np.concatenate([t, 0.5 * (t[1:] + t[:-1])]))
    coarse = DNLR(t, e, relaxation_start=400.0)
    fine = DNLR(tm, np.interp(tm, t, e), relaxation_start=400.0)
    object.__setattr__(fine, "h", np.interp(tm, t, coarse.h))   # same piecewise-linear ε_HT
    for tau in (0.3, 5.79, 300.0):
        bc = coarse.basis(tau, 40.0, grad=True)
        bf = fine.basis(tau, 40.0, grad=True)
        np.testing.assert_allclose(bf.values[::2], bc.values, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(bf.grad_tau_max[::2], bc.grad_tau_max, rtol=1e-9, atol=1e-11)
        np.testing.assert_allclose(bf.grad_tau_max_R[::2], bc.grad_tau_max_R, rtol=1e-9, atol=1e-11)


def test_paper_curve_shape_table3():
    # Table 3 parameters at 5e-3 1/s: first Considère point (nominal stress maximum) near
    # true strain 0.1 with a true stress of 30-35 MPa; true stress above 100 MPa at strain 1.9
    t, e = ramp(5e-3, 1.9, 2000)
    s = bd.simulate(t, e, TABLE3_5E3)
    nominal = s * np.exp(-e)
    first = e < 0.5
    k = np.argmax(nominal[first])
    assert 0.06 < e[k] < 0.14
    assert 30.0 < s[k] < 35.0
    assert s[-1] > 100.0


@pytest.mark.parametrize("relax", [False, True])
def test_gradient_matches_finite_differences(relax):
    t, e = ramp(5e-3, 2.0, 300, hold=200.0 if relax else 0.0, n_hold=100 if relax else 0)
    m = DNLR(t, e, relaxation_start=400.0 if relax else None)
    lt, lr = np.log(5.79), np.log(40.0)
    b = m.basis(5.79, 40.0, grad=True)
    step = 1e-5

    def vals(a, c):
        return m.basis(np.exp(a), np.exp(c)).values

    fd_t = (vals(lt + step, lr) - vals(lt - step, lr)) / (2 * step)
    scale = np.abs(b.values).max(axis=0) + 1e-30
    assert np.max(np.abs(b.grad_tau_max - fd_t) / scale) < 1e-7
    if relax:
        fd_r = (vals(lt, lr + step) - vals(lt, lr - step)) / (2 * step)
        assert np.max(np.abs(b.grad_tau_max_R - fd_r) / scale) < 1e-7


def test_batch_equals_single_evaluations():
    t, e = ramp(5e-3, 2.0, 200, hold=100.0, n_hold=50)
    m = DNLR(t, e, relaxation_start=400.0)
    names = ["E", "G", "tau_max", "sigma_inf", "tau_max_R"]
    rng = np.random.default_rng(2)
    theta = np.column_stack([rng.uniform(2000, 3000, 5), rng.uniform(1, 3, 5),
                             rng.uniform(2, 10, 5), rng.uniform(50, 100, 5), rng.uniform(10, 50, 5)])
    batch = m.stress_batch(theta, names)
    for k in range(5):
        np.testing.assert_array_equal(batch[k], m.stress(dict(zip(names, theta[k], strict=True))))


def test_a_forked_child_computes_a_batch_in_one_thread_with_the_same_values():
    """numba terminates a forked child that starts a parallel region when its parent used GNU
    OpenMP: after a parallel batch here, a forked child (multiprocessing's fork, the crash tests'
    zygote) computes the batch row by row, and gets the same stress."""
    t, e = ramp(5e-3, 2.0, 200, hold=100.0, n_hold=50)
    m = DNLR(t, e, relaxation_start=400.0)
    names = ["E", "G", "tau_max", "sigma_inf", "tau_max_R"]
    theta = np.tile([2500.0, 2.0, 5.0, 70.0, 20.0], (7, 1)) * np.linspace(0.9, 1.1, 7)[:, None]
    parent, child = in_parent_and_forked_child(lambda: m.stress_batch(theta, names))
    np.testing.assert_array_equal(child, parent)


def test_stress_is_continuous_at_the_switch():
    t, e = ramp(5e-3, 2.0, 801, hold=10.0, n_hold=100)
    s = bd.simulate(t, e, RELAX, relaxation_start=400.0)
    k = 800   # the kink sample
    # a hold step of 0.1 s cannot move the stress by more than the fastest relaxation allows
    assert abs(s[k + 1] - s[k]) < 0.2 * abs(s[k] - RELAX["sigma_inf"])


@pytest.mark.parametrize(("time", "strain", "message"), [
    ([0.0, 1.0, 1.0], [0.0, 0.1, 0.2], r"increase strictly: t\[1\]"),
    ([0.0, 1.0, 2.0], [0.0, np.nan, 0.2], "finite"),
    ([0.0, 1.0], [0.0, 0.1, 0.2], "differ in length"),
    ([0.0], [0.0], "at least two"),
])
def test_bad_grid_is_refused(time, strain, message):
    with pytest.raises(ValueError, match=message):
        bd.simulate(np.array(time), np.array(strain), TABLE3_5E3)


def test_bad_parameters_are_refused():
    t, e = ramp(5e-3, 1.0, 50)
    with pytest.raises(ValueError, match="missing parameter"):
        bd.simulate(t, e, {"E": 1.0, "G": 1.0})
    with pytest.raises(ValueError, match="tau_max must be a positive"):
        bd.simulate(t, e, {**TABLE3_5E3, "tau_max": -1.0})
    with pytest.raises(ValueError, match="missing parameter"):
        bd.simulate(t, e, TABLE3_5E3, relaxation_start=100.0)


def test_clear_message_without_numba():
    import subprocess
    import sys

    code = ("import sys; sys.modules['numba'] = None\n"
            "try:\n    import bayes_dnlr.model\nexcept ImportError as err:\n    print(err)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "bayes_dnlr needs numba for its forward model: pip install" in out
