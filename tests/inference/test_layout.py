"""The run's parameter vector: one test keeps the plain names and collapses to its one value; with
several tests a per-test parameter and each test's noise are named with the test, a shared one is
one column that every test reads."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference import layout
from bayes_dnlr.inference.layout import Layout, joint_name


def test_one_test_is_the_plain_layout() -> None:
    lay = Layout.build({"a": ["G", "E", "sigma0", "tau_max"]}, per_test=["tau_max"], plain=True)
    assert lay.names == ["E", "G", "tau_max", "sigma0"]              # canonical order, noise last
    assert lay.name("tau_max", "a") == "tau_max" and lay.name("sigma0", "a") == "sigma0"
    theta = np.array([[10.0, 20.0, 30.0, 40.0]])
    np.testing.assert_array_equal(lay.for_test(theta, "a"), [[20.0, 10.0, 40.0, 30.0]])   # its own order
    assert lay.collapse({"a": 0.3}) == 0.3 and lay.expand(0.3) == {"a": 0.3}


def test_shared_per_test_and_noise_columns_of_two_tests() -> None:
    lay = Layout.build({"r1": ["E", "G", "tau_max", "sigma0"], "r2": ["E", "G", "tau_max"]},
                       per_test=["tau_max"])
    assert lay.names == ["E", "G", "tau_max[r1]", "tau_max[r2]", "sigma0[r1]"]
    assert lay.columns == {"r1": [0, 1, 2, 4], "r2": [0, 1, 3]}
    theta = np.arange(10.0).reshape(2, 5)
    np.testing.assert_array_equal(lay.for_test(theta, "r2"), theta[:, [0, 1, 3]])   # E shared
    assert lay.name("E", "r2") == "E" and lay.name("tau_max", "r2") == joint_name("tau_max", "r2")
    # layout.test_of, not imported by name: pytest would collect it as a test
    assert [layout.test_of(n) for n in lay.names] == [None, None, "r1", "r2", "r1"]
    per = {"r1": 1, "r2": 2}
    assert lay.collapse(per) == per and lay.expand(lay.collapse(per)) == per


def test_plain_names_need_exactly_one_test() -> None:
    with pytest.raises(ValueError, match="exactly one test"):
        Layout.build({"a": ["E"], "b": ["E"]}, per_test=[], plain=True)
