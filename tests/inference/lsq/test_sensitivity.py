"""Sensitivities (eq. 22, 37) and the paper's stochastic analysis (eq. 32-35, Table 2)."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.lsq.sensitivity import (
    analyse,
    correlation,
    covariance,
    delta_tilde,
    identifiability_warnings,
    normalised,
    relative_errors,
    sensitivity_matrix,
)
from bayes_dnlr.model import DNLR

RATE = 5e-3
TABLE3 = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}        # paper Table 3, 5e-3 1/s, interval II
RELAX = {**TABLE3, "sigma_inf": 25.0, "tau_max_R": 60.0}


def ramp(n: int = 2000, strain_max: float = 1.9) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, strain_max / RATE, n)
    return t, RATE * t


def ramp_hold(n_ramp: int = 600, n_hold: int = 200, hold: float = 200.0):
    t1 = np.linspace(0.0, 1.9 / RATE, n_ramp)
    t = np.r_[t1, t1[-1] + np.linspace(0.0, hold, n_hold + 1)[1:]]
    return t, np.minimum(RATE * t, 1.9), float(t1[-1])


def model_stress(model: DNLR, params: dict[str, float]) -> np.ndarray:
    return model.stress(params)


def central_differences(model: DNLR, params: dict[str, float], names: list[str]) -> np.ndarray:
    cols = []
    for k in names:
        h = 1e-4 * params[k]
        up = dict(params, **{k: params[k] + h})
        dn = dict(params, **{k: params[k] - h})
        cols.append((model_stress(model, up) - model_stress(model, dn)) / (2 * h))
    return np.column_stack(cols)


def table2(strain_max: float, names: list[str]):
    t, e = ramp()
    model = DNLR(t, e)
    b = model.basis(TABLE3["tau_max"], grad=True)
    mask = e <= strain_max
    X = sensitivity_matrix(b, TABLE3, names, mask)
    return analyse(X, names, [TABLE3[k] for k in names], sigma0=0.3)


def test_sensitivities_match_central_differences_tensile():
    t, e = ramp()
    model = DNLR(t, e)
    names = ["E", "G", "tau_max"]
    X = sensitivity_matrix(model.basis(TABLE3["tau_max"], grad=True), TABLE3, names)
    Xfd = central_differences(model, TABLE3, names)
    rel = np.max(np.abs(X - Xfd), axis=0) / np.max(np.abs(X), axis=0)
    print("max relative difference to central differences:", dict(zip(names, rel, strict=True)))
    assert np.all(rel < 1e-5)


def test_sensitivities_match_central_differences_with_relaxation():
    t, e, t_r = ramp_hold()
    model = DNLR(t, e, relaxation_start=t_r)
    names = ["E", "G", "tau_max", "sigma_inf", "tau_max_R"]
    b = model.basis(RELAX["tau_max"], RELAX["tau_max_R"], grad=True)
    X = sensitivity_matrix(b, RELAX, names)
    Xfd = central_differences(model, RELAX, names)
    rel = np.max(np.abs(X - Xfd), axis=0) / np.max(np.abs(X), axis=0)
    print("max relative difference to central differences:", dict(zip(names, rel, strict=True)))
    assert np.all(rel < 1e-5)
    # the relaxation parameters act only after the switch
    before = t <= t_r
    assert np.all(X[before, 3] == 0) and np.all(X[before, 4] == 0)


def test_table2_interval_II_bands():
    names = ["E", "G", "tau_max"]
    a = table2(1.9, names)
    rho, err = a.correlation, a.err
    print(f"interval II: rho(E,tau_max) = {rho[0, 2]:.4f} (paper -0.9988), rho(E,G) = {rho[0, 1]:.3f} "
          f"(paper -0.18), rho(G,tau_max) = {rho[1, 2]:.3f} (paper 0.147); Err % E {100 * err[0]:.3f}, "
          f"G {100 * err[1]:.4f}, tau_max {100 * err[2]:.3f} at sigma0 0.3 MPa")
    assert rho[0, 2] <= -0.99
    assert -0.30 <= rho[0, 1] <= -0.12
    assert 0.10 <= rho[1, 2] <= 0.25
    assert err[1] < err[0] / 5
    assert 0.8 < err[0] / err[2] < 1.25


def test_table2_interval_I_bands():
    a = table2(0.13, ["E", "tau_max"])
    rho = a.correlation[0, 1]
    print(f"interval I (G fixed): rho(E,tau_max) = {rho:.4f} (paper -0.9667); "
          f"Err % E {100 * a.err[0]:.3f}, tau_max {100 * a.err[1]:.3f}")
    assert -0.995 <= rho <= -0.95


def test_correlations_do_not_depend_on_sigma0_and_err_scales_with_it():
    names = ["E", "G", "tau_max"]
    t, e = ramp()
    b = DNLR(t, e).basis(TABLE3["tau_max"], grad=True)
    X = sensitivity_matrix(b, TABLE3, names)
    v = [TABLE3[k] for k in names]
    a1, a2 = analyse(X, names, v, 0.3), analyse(X, names, v, 3.0)
    np.testing.assert_allclose(a1.correlation, a2.correlation, rtol=1e-12)
    np.testing.assert_allclose(a2.err, 10 * a1.err, rtol=1e-12)
    np.testing.assert_allclose(a2.covariance, 100 * a1.covariance, rtol=1e-12)


def test_covariance_agrees_with_the_direct_inverse_and_eq35_layout():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(200, 3)) * np.array([1.0, 50.0, 0.01])
    values = np.array([2.0, -3.0, 400.0])
    delta = covariance(X, 0.5, values)
    np.testing.assert_allclose(delta, 0.25 * np.linalg.inv(X.T @ X), rtol=1e-10)
    dt = delta_tilde(delta, values)
    sd = np.sqrt(np.diag(delta))
    np.testing.assert_allclose(np.diag(dt), sd / np.abs(values))            # eq. 33 on the diagonal
    np.testing.assert_allclose(dt[0, 1], delta[0, 1] / (sd[0] * sd[1]))       # eq. 34 off it
    np.testing.assert_allclose(dt, dt.T)
    np.testing.assert_allclose(np.diag(correlation(delta)), 1.0)
    np.testing.assert_allclose(relative_errors(delta, values), np.diag(dt))
    np.testing.assert_allclose(normalised(X, values), X * values)             # eq. 37


def test_rank_deficient_x_raises():
    X = np.ones((50, 2))
    with pytest.raises(np.linalg.LinAlgError):
        covariance(X, 1.0)


def test_identifiability_warnings_name_the_problem():
    a2 = table2(1.9, ["E", "G", "tau_max"])
    w2 = identifiability_warnings(a2)
    assert any("ρ(E, tau_max)" in m and "-0.9988" in m for m in w2)
    assert not any("negligible" in m for m in w2)
    # G free on interval I: its normalised sensitivity is a few % of the largest (paper 4.2: 5 %)
    a1 = table2(0.13, ["E", "G", "tau_max"])
    ratio = a1.max_normalised[1] / a1.max_normalised.max()
    print(f"interval I: max |X̃_G| / max |X̃| = {100 * ratio:.2f} %")
    w1 = identifiability_warnings(a1)
    assert any("sensitivity to G is negligible" in m for m in w1)
    assert not any("sensitivity to E" in m or "sensitivity to tau_max" in m for m in w1)
    # the advice gives the config line with the value, never a literal "..." to fill in
    (g,) = [m for m in w1 if "sensitivity to G" in m]
    assert f"parameters.G: {{value: {a1.values[1]:.4g}}}" in g and "..." not in g
