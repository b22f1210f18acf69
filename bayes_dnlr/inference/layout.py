"""The parameter vector of a run: its names, and which of them each test uses.

A run fits one or several tests with one parameter vector. A model parameter is *shared* (one value,
named ``E``) unless its config entry says ``per: test`` (one value per test); the noise of each test
(a sampled σ0, the discrepancy's amplitude and length) always belongs to that test. In a run with
several tests a test's own parameter is named with the test, ``tau_max[r5e-3]``; a run with one
test keeps the plain names (``plain``), so that the one-test case is this layout with N = 1 and
every quantity kept per test collapses to its one value (``collapse``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from bayes_dnlr.vocabulary import NOISE_NAMES, PARAMETER_NAMES


def joint_name(name: str, test: str) -> str:
    return f"{name}[{test}]"


def test_of(name: str) -> str | None:
    """``tau_max[r5e-3]`` -> ``r5e-3``; None for a shared or plain name."""
    return name[name.index("[") + 1:-1] if "[" in name else None


@dataclass(frozen=True)
class Layout:
    """The run's names, and for each test the run column of each of its own (local) names."""

    names: list[str]
    tests: list[str]
    local: dict[str, list[str]]          # test -> its own parameter names, its own order
    columns: dict[str, list[int]]        # test -> run column of each local name
    per_test: tuple[str, ...] = ()       # the model parameters with one value per test
    plain: bool = False                  # one test: the run's names are the test's own

    @classmethod
    def build(cls, local: Mapping[str, Sequence[str]], per_test: Sequence[str],
              plain: bool = False) -> Layout:
        """``local``: each test's own free (or sampled) names; ``per_test``: the model parameters
        that are one per test; ``plain``: a run with one test. Order: the canonical model order
        (shared, then each test's own), then each test's noise parameters."""
        tests = list(local)
        if plain and len(tests) != 1:
            raise ValueError(f"plain names need exactly one test, got {tests}")
        per_test = tuple(per_test)

        def name(k: str, t: str) -> str:
            return k if plain or not (k in per_test or k in NOISE_NAMES) else joint_name(k, t)

        names: list[str] = []
        for k in PARAMETER_NAMES:
            users = [t for t in tests if k in local[t]]
            if not users:
                continue
            names += list(dict.fromkeys(name(k, t) for t in users))
        for t in tests:
            names += [name(k, t) for k in NOISE_NAMES if k in local[t]]
        columns = {t: [names.index(name(k, t)) for k in local[t]] for t in tests}
        return cls(names, tests, {t: list(v) for t, v in local.items()}, columns, per_test, plain)

    def name(self, k: str, test: str) -> str:
        """The run's name of a test's parameter ``k``."""
        shared = k not in self.per_test and k not in NOISE_NAMES
        return k if self.plain or shared else joint_name(k, test)

    def for_test(self, theta: np.ndarray, test: str) -> np.ndarray:
        """Columns of a (k, run) array that are the test's own parameters, in its own order."""
        return theta[..., self.columns[test]]

    def collapse(self, per_test: Mapping[str, Any]) -> Any:
        """A quantity kept per test as the run writes it: its one value in a run with one test,
        else the mapping test -> value."""
        return per_test[self.tests[0]] if self.plain else dict(per_test)

    def expand(self, value: Any) -> dict[str, Any]:
        """The inverse of ``collapse``: test -> value."""
        return {self.tests[0]: value} if self.plain else dict(value or {})
