"""The package's words, each spelled once: the parameter names in their one order, their units and
display forms, how the compiled model takes them, the noise parameters, the 90 % normal quantile.

Nothing here imports anything of the package.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

# The model parameters in the canonical (config) order: tensile, then relaxation (paper eq. 17-18),
# the spectrum's exponent, then the shift factor's (model/shift.py): Ea (Arrhenius), C1 and C2
# (WLF), sigma_s (Eyring).
SHIFT_PARAMETERS = ("Ea", "C1", "C2", "sigma_s")
SHIFT_LAW_PARAMETERS = {"arrhenius": ("Ea",), "wlf": ("C1", "C2"), "eyring": ("sigma_s",), "none": ()}
PARAMETER_NAMES = ("E", "G", "tau_max", "sigma_inf", "tau_max_R", "alpha", *SHIFT_PARAMETERS)
TENSILE_PARAMETERS = ("E", "G", "tau_max")
RELAXATION_PARAMETERS = ("sigma_inf", "tau_max_R")
# The spectrum's exponent, p_j ∝ tau_j^alpha (model/spectrum.py): ½ (eq. 12) unless a config gives
# it; a model-form parameter, not one of the paper's.
SPECTRUM_EXPONENT = "alpha"
UNIVERSAL_EXPONENT = 0.5
SPECTRUM_PARAMETERS = (SPECTRUM_EXPONENT,)
# The parameters the model is nonlinear in: the time constants (fitted in log space) and the
# spectrum's exponent (as it is).
NONLINEAR = ("tau_max", "tau_max_R", SPECTRUM_EXPONENT)
# The model is linear in E, G and sigma_inf: each is the weight of one column of the basis
# (model.Basis); the time constants set the spectrum and are fitted in log space.
LINEAR_COLUMN = {"E": 0, "G": 1, "sigma_inf": 2}
TIME_CONSTANTS = ("tau_max", "tau_max_R")
# the parameters optimisers move in log space (they span decades)
LOG_COORDINATES = (*TIME_CONSTANTS, "sigma_s")

# The noise parameters of one test: the measurement noise and the model discrepancy's amplitude
# and correlation length (docs/model-error.md).
DISCREPANCY_PARAMETERS = ("disc_amplitude", "disc_length")
NOISE_NAMES = ("sigma0", *DISCREPANCY_PARAMETERS)


@dataclass(frozen=True)
class Quantity:
    """A named quantity with its unit and display forms (HTML for tables, LaTeX for figures)."""

    unit: str
    html: str
    symbol: str          # matplotlib mathtext


QUANTITIES = {
    "E": Quantity("MPa", "E", r"$E$"),
    "G": Quantity("MPa", "G", r"$G$"),
    "tau_max": Quantity("s", "τ<sub>max</sub>", r"$\tau_{max}$"),
    "sigma_inf": Quantity("MPa", "σ<sub>∞</sub>", r"$\sigma_\infty$"),
    "tau_max_R": Quantity("s", "τ<sup>R</sup><sub>max</sub>", r"$\tau^R_{max}$"),
    "alpha": Quantity("-", "α", r"$\alpha$"),
    "Ea": Quantity("kJ/mol", "E<sub>a</sub>", r"$E_a$"),
    "C1": Quantity("-", "C<sub>1</sub>", r"$C_1$"),
    "C2": Quantity("K", "C<sub>2</sub>", r"$C_2$"),
    "sigma_s": Quantity("MPa", "σ<sub>s</sub>", r"$\sigma_s$"),
    "sigma0": Quantity("MPa", "σ<sub>0</sub>", r"$\sigma_0$"),
    "disc_amplitude": Quantity("MPa", "δ amplitude", r"$a_\delta$"),
    "disc_length": Quantity("s", "δ length", r"$\ell_\delta$"),
}
UNITS = {k: q.unit for k, q in QUANTITIES.items()}


def base_name(name: str) -> str:
    """The quantity of a run's parameter name: ``tau_max[r5e-3]`` -> ``tau_max``."""
    return name.split("[", 1)[0]


def fixing(name: str, value: float) -> str:
    """The config line that holds ``name`` at ``value``: what a message that says "fix it" writes,
    so that no advice leaves the value to guess."""
    return f"parameters.{base_name(name)}: {{value: {float(value):.4g}}}"


def unit(name: str) -> str:
    """The unit of a parameter name, a joint run's ``tau_max[r5e-3]`` included ('' when unknown)."""
    return UNITS.get(base_name(name), "")


# The compiled model takes each parameter set as one row of six numbers in this order
# (model/kernel.py); a test without a relaxation phase repeats tau_max in the fifth column, and
# alpha is ½ unless given.
KERNEL_ORDER = ("E", "G", "sigma_inf", "tau_max", "tau_max_R", SPECTRUM_EXPONENT)


def pack_theta(column: Callable[[str], np.ndarray | None], k: int, has_relaxation: bool) -> np.ndarray:
    """The (k, 6) rows the compiled model takes, in ``KERNEL_ORDER``; ``column(name)`` gives the
    k values of a parameter, or None for a parameter the model does not use (then 0; alpha ½)."""
    sets = np.zeros((k, len(KERNEL_ORDER)))
    sets[:, 5] = UNIVERSAL_EXPONENT
    for c, name in enumerate(KERNEL_ORDER):
        values = column(name)
        if values is not None:
            sets[:, c] = values
    if not has_relaxation:
        sets[:, 4] = sets[:, 3]
    return sets


def in_canonical_order(names: Sequence[str]) -> list[str]:
    """Model parameter names in the canonical order, the others after them as given."""
    model = [k for k in PARAMETER_NAMES if k in names]
    return model + [k for k in names if k not in PARAMETER_NAMES]


Z90 = 1.6448536269514722     # two-sided 90 % quantile of the standard normal
