"""Conversions of the paper, section 2 (eq. 1-8): Hencky/nominal strain, true and nominal stress."""

from __future__ import annotations

import numpy as np


def hencky_from_nominal(nominal: np.ndarray) -> np.ndarray:
    """Hencky (true) strain from nominal strain e = Δl/l0: ε = ln(l/l0) = ln(1 + e) (eq. 1, 8)."""
    return np.log1p(np.asarray(nominal, dtype=float))


def nominal_from_hencky(strain: np.ndarray) -> np.ndarray:
    """Nominal strain from Hencky strain: e = λ - 1 = exp(ε) - 1 (eq. 1, 8)."""
    return np.expm1(np.asarray(strain, dtype=float))


def true_stress(force: np.ndarray, area0: float, eps22: np.ndarray) -> np.ndarray:
    """True stress with the measured transverse strain, ε33 = ε22 (eq. 2): σ = F/S0·exp(-2ε22).

    force in N, area0 in mm², result in MPa.
    """
    return np.asarray(force, dtype=float) / area0 * np.exp(-2.0 * np.asarray(eps22, dtype=float))


def sigma_star(force: np.ndarray, area0: float, eps11: np.ndarray) -> np.ndarray:
    """Isovolumic true stress σ* = F/S0·exp(ε11) (eq. 4-6: ν = 0.5, ε22* = ε33* = -ε11/2).

    force in N, area0 in mm², result in MPa.
    """
    return np.asarray(force, dtype=float) / area0 * np.exp(np.asarray(eps11, dtype=float))


def nominal_stress(force: np.ndarray, area0: float) -> np.ndarray:
    """Nominal (engineering) stress F/S0 in MPa (force in N, area0 in mm²)."""
    return np.asarray(force, dtype=float) / area0


def nominal_from_true_stress(stress: np.ndarray, eps11: np.ndarray) -> np.ndarray:
    """Nominal stress from a true stress under the isovolumic hypothesis (eq. 4-6): F/S0 = σ·exp(-ε11).

    Used when a test gives only a true-stress column; exact only for ν = 0.5.
    """
    return np.asarray(stress, dtype=float) * np.exp(-np.asarray(eps11, dtype=float))


def haward_thackray_strain(strain: np.ndarray) -> np.ndarray:
    """ε_HT = λ² - 1/λ = exp(2ε) - exp(-ε), λ = exp(ε) (eq. 7-8): the Haward-Thackray strain
    measure that drives the model's relaxed state (eq. 17)."""
    strain = np.asarray(strain, dtype=float)
    return np.exp(2.0 * strain) - np.exp(-strain)
