"""The package's words in one place: names, units, the compiled model's parameter order."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.vocabulary import (
    KERNEL_ORDER,
    PARAMETER_NAMES,
    SHIFT_PARAMETERS,
    Z90,
    base_name,
    in_canonical_order,
    pack_theta,
    unit,
)


def test_names_and_units_of_joint_names() -> None:
    assert base_name("tau_max[r5e-3]") == "tau_max" and base_name("E") == "E"
    assert unit("E") == "MPa" and unit("tau_max[r5e-3]") == "s" and unit("nonsense") == ""
    assert in_canonical_order(["sigma0", "tau_max", "E"]) == ["E", "tau_max", "sigma0"]
    # the shift's parameters act through the time constants and the reduced-time kernel (model/dnlr.py)
    assert set(KERNEL_ORDER) == set(PARAMETER_NAMES) - set(SHIFT_PARAMETERS)


def test_pack_theta_puts_each_parameter_in_the_kernels_column() -> None:
    values = {"E": np.array([1.0, 2.0]), "G": np.array([3.0, 4.0]), "tau_max": np.array([5.0, 6.0]),
              "sigma_inf": np.array([7.0, 8.0]), "tau_max_R": np.array([9.0, 10.0]),
              "alpha": np.array([0.4, 0.6])}
    sets = pack_theta(values.get, 2, has_relaxation=True)
    for c, name in enumerate(KERNEL_ORDER):
        np.testing.assert_array_equal(sets[:, c], values[name])
    tensile = pack_theta({k: values[k] for k in ("E", "G", "tau_max")}.get, 2, has_relaxation=False)
    np.testing.assert_array_equal(tensile[:, KERNEL_ORDER.index("sigma_inf")], 0.0)     # unused: 0
    np.testing.assert_array_equal(tensile[:, 4], tensile[:, 3])      # no relaxation: tau_max twice
    np.testing.assert_array_equal(tensile[:, KERNEL_ORDER.index("alpha")], 0.5)  # eq. 12 unless given


def test_z90_is_the_two_sided_90_percent_quantile() -> None:
    from scipy.stats import norm

    assert abs(Z90 - norm.ppf(0.95)) < 1e-15
