"""Pulse-echo (eq. 38-39), CSM nanoindentation (eq. 40-44) and De_max (eq. 45) against hand values."""

from __future__ import annotations

import math

import pytest

from bayes_dnlr.config import ConfigError, CrossCheckConfig, parse_config
from bayes_dnlr.crosscheck import (
    DIAMOND_E_MPA,
    apparent_modulus,
    contact_depth,
    crosscheck_values,
    deborah_max,
    nanoindentation_modulus,
    pulse_echo_modulus,
    pulse_echo_poisson,
    wave_speed,
)


def test_wave_speed_eq38_by_hand():
    # V = 2e/T: e = 4.6 mm, T = 4.0 µs -> 2 * 0.0046 m / 4.0e-6 s = 2300 m/s
    assert wave_speed(4.6, 4.0) == pytest.approx(2300.0, rel=1e-12)
    # T = 9.2 µs -> 0.0092 / 9.2e-6 = 1000 m/s
    assert wave_speed(4.6, 9.2) == pytest.approx(1000.0, rel=1e-12)
    with pytest.raises(ValueError):
        wave_speed(0.0, 4.0)


def test_pulse_echo_modulus_eq39_by_hand():
    # ρ = 950 kg/m³, V_L = 2300 m/s, V_T = 1000 m/s:
    # V_L² = 5.29e6, V_T² = 1e6; 3 V_L² - 4 V_T² = 11.87e6; V_L² - V_T² = 4.29e6
    # E = 950 * 1e6 * 11.87 / 4.29 Pa = 2.62855478e9 Pa = 2628.5548 MPa
    assert pulse_echo_modulus(950.0, 2300.0, 1000.0) == pytest.approx(2628.5547785547787, rel=1e-12)
    # ν = (5.29 - 2) / (2 * 4.29) = 0.383450
    assert pulse_echo_poisson(2300.0, 1000.0) == pytest.approx(3.29 / 8.58, rel=1e-12)
    # the isotropic identity E = 2 ρ V_T² (1 + ν)
    nu = pulse_echo_poisson(2300.0, 1000.0)
    assert pulse_echo_modulus(950.0, 2300.0, 1000.0) == pytest.approx(2 * 950 * 1e6 * (1 + nu) / 1e6)
    with pytest.raises(ValueError):
        pulse_echo_modulus(950.0, 1100.0, 1000.0)   # V_L < 2 V_T / sqrt(3): E would be negative


def test_nanoindentation_eq40_44_by_hand():
    S, h, F = 80000.0, 5.0e-6, 0.05          # N/m, m, N
    # h_c = h - 0.72 F/S = 5e-6 - 0.72 * 0.05 / 80000 = 5e-6 - 4.5e-7 = 4.55e-6 m
    assert contact_depth(h, F, S) == pytest.approx(4.55e-6, rel=1e-12)
    # A = 24.56 h_c² = 5.084534e-10 m², √A = 2.2548911e-5 m
    # E' = S √π / (2 η √A) = 80000 * 1.7724539 / (2 * 1.034 * 2.2548911e-5) = 3.0408067e9 Pa
    assert apparent_modulus(S, 4.55e-6) == pytest.approx(3040.8066826, rel=1e-9)
    # eq. 43: E = (1 - 0.5²) E' = 0.75 * 3040.8067 = 2280.6050 MPa
    e = nanoindentation_modulus(S, h, F, nu=0.5)
    assert e == pytest.approx(2280.6050120, rel=1e-9)
    # eq. 44 written out: E = S / (2 h_c sqrt(24.56/π) η / (1 - ν²))
    assert e == pytest.approx(S / (2 * 4.55e-6 * math.sqrt(24.56 / math.pi) * 1.034 / 0.75) / 1e6)
    # eq. 42 with a diamond indenter (E_i = 1040 GPa, ν_i = 0.07):
    # E = 0.75 / (1/3040.8067 - (1 - 0.0049)/1.04e6) = 2287.2599 MPa, 0.3 % above eq. 43
    e42 = nanoindentation_modulus(S, h, F, nu=0.5, indenter_E_MPa=DIAMOND_E_MPA)
    assert e42 == pytest.approx(2287.2598533, rel=1e-9)
    # a phase lag multiplies E' by cos φ (eq. 40)
    assert nanoindentation_modulus(S, h, F, phase_rad=math.radians(60)) == pytest.approx(e / 2)
    with pytest.raises(ValueError, match="units"):
        contact_depth(5e-6, 50.0, 80000.0)   # F in mN by mistake: h_c < 0


def test_deborah_eq45_table5():
    # Table 5, specimen A//: tau_max 6.01 s at 5e-3 1/s -> De_max = 0.03005 (the paper prints 0.0301)
    assert deborah_max(6.01, 5e-3) == pytest.approx(0.03005, rel=1e-12)
    assert deborah_max(11.02, 2.5e-3) == pytest.approx(0.02755, rel=1e-12)


def _cfg(crosscheck: dict) -> dict:
    return {"name": "x", "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                                  "observable": "stress"},
            "crosscheck": crosscheck}


def test_config_crosscheck_section_and_values():
    cfg = parse_config(_cfg({
        "manufacturer": 1200,
        "pulse_echo": {"density": 950, "thickness": 4.6, "period_l": 4.0, "period_t": 9.2, "sd": 40},
        "nanoindentation": {"S_m": 80000, "h": 5e-6, "F": 0.05}}))
    assert isinstance(cfg.crosscheck, CrossCheckConfig)
    vals = crosscheck_values(cfg.crosscheck)
    assert [v.technique for v in vals] == ["Manufacturer", "Pulse-echo", "Nanoindentation"]
    assert vals[1].modulus == pytest.approx(2628.5548, rel=1e-7) and vals[1].sd == 40
    assert vals[2].modulus == pytest.approx(2280.6050, rel=1e-7)
    assert vals[1].ratio_to(2830.0) == pytest.approx((2628.5548 - 2830) / 2830, rel=1e-6)
    given = parse_config(_cfg({"pulse_echo": {"modulus": 2780, "sd": 40}}))
    assert crosscheck_values(given.crosscheck)[0].modulus == 2780
    assert crosscheck_values(None) == []


@pytest.mark.parametrize("section, words", [
    ({"pulse_echo": {"density": 950, "v_l": 2300}}, "v_l and v_t"),
    ({"pulse_echo": {"modulus": 2780, "density": 950}}, "not both"),
    ({"nanoindentation": {"S_m": 1e5}}, "S_m (N/m), h (m) and F (N)"),
    ({"pulse_echo": {"modulus": 2780, "colour": "red"}}, "unknown key"),
])
def test_config_crosscheck_errors_name_the_key(section, words):
    with pytest.raises(ConfigError) as err:
        parse_config(_cfg(section))
    assert words in str(err.value)
    assert "crosscheck" in str(err.value)
