"""Independent measurements of the instantaneous modulus (paper section 5.1, Table 4) and De (eq. 45).

Units are in the argument names: density kg/m³, speeds m/s, thickness mm, period µs, stiffness N/m,
depth m, force N; every modulus is returned in MPa.

- Pulse-echo (ultrasound): wave speed V = 2e/T from the thickness e and the period T between two
  echoes (eq. 38); E = ρ V_T² (3 V_L² - 4 V_T²) / (V_L² - V_T²) (eq. 39).
- Nanoindentation, continuous stiffness method (CSM): contact depth h_c = h - 0.72 F/S_m, projected
  area A = 24.56 h_c² (Berkovich, eq. 41), apparent modulus E' = S_m √π cos φ / (2 η √A) with
  η = 1.034 (eq. 40), and the sample's modulus from E' by eq. 43, E = (1 - ν²) E', or, with the
  indenter's compliance (eq. 42, diamond E_i = 1040 GPa), 1/E' = (1 - ν²)/E + (1 - ν_i²)/E_i.
  With cos φ = 1 and eq. 43 this is eq. 44.
- Deborah number De_max = tau_max · ε̇ (eq. 45).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

BERKOVICH_AREA = 24.56      # A = 24.56 h_c² (eq. 41)
BERKOVICH_ETA = 1.034       # η of eq. 40
CONTACT_EPSILON = 0.72      # ε in h_c = h - ε F/S_m (conical indenter, eq. 41)
DIAMOND_E_MPA = 1.04e6      # E_i = 1040 GPa (eq. 42)
DIAMOND_NU = 0.07           # Poisson ratio of diamond (not given in the paper; the usual value)


def wave_speed(thickness_mm: float, period_us: float) -> float:
    """Wave speed (m/s) from the sample thickness e (mm) and the echo period T (µs): V = 2e/T (eq. 38)."""
    if not (thickness_mm > 0 and period_us > 0):
        raise ValueError(f"thickness and period must be positive, got {thickness_mm} mm, {period_us} µs")
    return 2.0 * thickness_mm * 1e-3 / (period_us * 1e-6)


def pulse_echo_modulus(density_kg_m3: float, v_l_m_s: float, v_t_m_s: float) -> float:
    """Young's modulus (MPa) from density and longitudinal/transverse wave speeds (eq. 39)."""
    if not (density_kg_m3 > 0 and v_t_m_s > 0):
        raise ValueError("density and wave speeds must be positive")
    if not v_l_m_s > v_t_m_s * 2.0 / math.sqrt(3.0):
        # 3 V_L² > 4 V_T² is needed for E > 0 (Poisson ratio above -1); V_L > V_T always holds
        raise ValueError(f"longitudinal speed {v_l_m_s} m/s too small for transverse speed "
                         f"{v_t_m_s} m/s (need V_L > 2 V_T / sqrt(3))")
    vl2, vt2 = v_l_m_s**2, v_t_m_s**2
    return density_kg_m3 * vt2 * (3.0 * vl2 - 4.0 * vt2) / (vl2 - vt2) / 1e6


def pulse_echo_poisson(v_l_m_s: float, v_t_m_s: float) -> float:
    """Poisson ratio ν = (V_L² - 2 V_T²) / (2 (V_L² - V_T²)) of an isotropic solid (companion of eq. 39)."""
    vl2, vt2 = v_l_m_s**2, v_t_m_s**2
    return (vl2 - 2.0 * vt2) / (2.0 * (vl2 - vt2))


def contact_depth(h_m: float, F_N: float, S_m_N_per_m: float, epsilon: float = CONTACT_EPSILON) -> float:
    """Contact depth h_c = h - ε F/S_m (m), ε = 0.72 (text of eq. 41)."""
    hc = h_m - epsilon * F_N / S_m_N_per_m
    if not hc > 0:
        raise ValueError(f"contact depth h_c = h - {epsilon} F/S_m = {hc:.3g} m is not positive: "
                         "check the units (h in m, F in N, S_m in N/m)")
    return hc


def apparent_modulus(S_m_N_per_m: float, h_c_m: float, eta: float = BERKOVICH_ETA,
                     phase_rad: float = 0.0, area_factor: float = BERKOVICH_AREA) -> float:
    """Apparent (storage) modulus E' (MPa) = S_m √π cos φ / (2 η √A), A = 24.56 h_c² (eq. 40-41)."""
    area = area_factor * h_c_m**2
    return S_m_N_per_m * math.sqrt(math.pi) * math.cos(phase_rad) / (2.0 * eta * math.sqrt(area)) / 1e6


def nanoindentation_modulus(S_m_N_per_m: float, h_m: float, F_N: float, nu: float = 0.5,
                            eta: float = BERKOVICH_ETA, epsilon: float = CONTACT_EPSILON,
                            phase_rad: float = 0.0, indenter_E_MPa: float | None = None,
                            indenter_nu: float = DIAMOND_NU) -> float:
    """Sample modulus E (MPa) by CSM nanoindentation (eq. 40-44).

    ``indenter_E_MPa`` None uses eq. 43 (rigid indenter: E = (1 - ν²) E', i.e. eq. 44 with cos φ = 1);
    a value (e.g. ``DIAMOND_E_MPA``) applies the indenter correction of eq. 42.
    """
    hc = contact_depth(h_m, F_N, S_m_N_per_m, epsilon)
    e_app = apparent_modulus(S_m_N_per_m, hc, eta, phase_rad)
    if indenter_E_MPa is None:
        return (1.0 - nu**2) * e_app
    inv = 1.0 / e_app - (1.0 - indenter_nu**2) / indenter_E_MPa
    if not inv > 0:
        raise ValueError("the apparent modulus exceeds the indenter's: check the inputs")
    return (1.0 - nu**2) / inv


def deborah_max(tau_max_s: float, strain_rate_per_s: float) -> float:
    """Maximal Deborah number De_max = tau_max · ε̇ (eq. 45), dimensionless."""
    return float(tau_max_s) * float(strain_rate_per_s)


@dataclass(frozen=True)
class CrossCheckValue:
    """A modulus measured by another technique, for the report's Table 4."""

    technique: str            # "Pulse-echo (eq. 39)", ...
    modulus: float            # MPa
    sd: float | None          # MPa, as given (None when not given)
    detail: str               # how it was computed

    def ratio_to(self, e_model: float) -> float:
        """The paper's discrepancy in Table 4: (E_x - E_MBM) / E_MBM."""
        return (self.modulus - e_model) / e_model


def crosscheck_values(spec: Any) -> list[CrossCheckValue]:
    """The moduli of a config's ``crosscheck:`` section (``config.CrossCheck``), in Table 4 order."""
    out: list[CrossCheckValue] = []
    if spec is None:
        return out
    if spec.manufacturer is not None:
        out.append(CrossCheckValue("Manufacturer", spec.manufacturer, None, "data sheet value"))
    pe = spec.pulse_echo
    if pe is not None:
        if pe.modulus is not None:
            out.append(CrossCheckValue("Pulse-echo", pe.modulus, pe.sd, "as given"))
        else:
            v_l, v_t = pe.v_l, pe.v_t
            how = ""
            if v_l is None or v_t is None:
                v_l = wave_speed(pe.thickness, pe.period_l)
                v_t = wave_speed(pe.thickness, pe.period_t)
                how = (f"V = 2e/T (eq. 38) with e = {pe.thickness:g} mm, T_L = {pe.period_l:g} µs, "
                       f"T_T = {pe.period_t:g} µs; ")
            e = pulse_echo_modulus(pe.density, v_l, v_t)
            how += (f"eq. 39 with ρ = {pe.density:g} kg/m³, V_L = {v_l:.0f} m/s, V_T = {v_t:.0f} m/s "
                    f"(ν = {pulse_echo_poisson(v_l, v_t):.3f})")
            out.append(CrossCheckValue("Pulse-echo", e, pe.sd, how))
    ni = spec.nanoindentation
    if ni is not None:
        if ni.modulus is not None:
            out.append(CrossCheckValue("Nanoindentation", ni.modulus, ni.sd, "as given"))
        else:
            e_i = DIAMOND_E_MPA if ni.indenter_correction else None
            e = nanoindentation_modulus(ni.S_m, ni.h, ni.F, ni.nu, phase_rad=math.radians(ni.phase_deg),
                                        indenter_E_MPa=e_i)
            hc = contact_depth(ni.h, ni.F, ni.S_m)
            how = (f"CSM eq. 40-44: S_m = {ni.S_m:g} N/m, h = {ni.h * 1e6:g} µm, F = {ni.F * 1e3:g} mN, "
                   f"h_c = {hc * 1e6:.3f} µm, ν = {ni.nu:g}"
                   + (", indenter correction eq. 42" if ni.indenter_correction else ""))
            out.append(CrossCheckValue("Nanoindentation", e, ni.sd, how))
    return out
