"""fit.json as typed records, for every stage downstream of ``fit`` (sample, report, export).

fit.json has two layouts: a run with one test writes that test's fit (``parameters``, ``estimate``,
... at the top), a run with several tests writes the run's fit at the top (``"joint": true``) and
each test's own fit under ``single_fits``. ``FitRecord.from_dict`` reads both into one shape: the
run's analyses and, per test, the test's own fit, so that no stage asks which layout it has.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

FIT_LAYOUT_VERSION = 1      # fit.json's ``layout_version``; files without it are read as version 1


def _matrix(obj: Any, p: int) -> np.ndarray | None:
    if obj is None:
        return None
    a = np.asarray(obj, dtype=float)
    return a if a.shape == (p, p) else None


def _floats(obj: Any, names: Sequence[str]) -> dict[str, float]:
    if not obj:
        return {}
    return {k: float(obj[k]) for k in names if k in obj and obj[k] is not None}


@dataclass(frozen=True)
class Analysis:
    """A linearized analysis of the free parameters (paper eq. 32-35): the white (paper) one, or the
    generalized one under the model discrepancy."""

    names: list[str]
    estimate: dict[str, float]          # the free parameters (and fixed ones, when recorded)
    sd: dict[str, float]
    err: dict[str, float | None]        # None where fit.json has null (an estimate of zero)
    covariance: np.ndarray | None
    correlation: np.ndarray | None
    delta_tilde: np.ndarray | None

    @classmethod
    def from_dict(cls, block: Mapping[str, Any] | None, names: Sequence[str]) -> Analysis | None:
        if not block or block.get("estimate") is None:
            return None
        names = list(names)
        est = {k: float(v) for k, v in block["estimate"].items() if v is not None}
        err = block.get("err") or {}
        return cls(names, est, _floats(block.get("sd"), names),
                   {k: None if err[k] is None else float(err[k]) for k in names if k in err},
                   _matrix(block.get("covariance"), len(names)),
                   _matrix(block.get("correlation"), len(names)),
                   _matrix(block.get("delta_tilde"), len(names)))

    def restrict(self, names: Mapping[str, str]) -> Analysis:
        """The analysis of some of the parameters under other names: ``names`` maps each new name
        to this analysis' name (a test's own names to the run's). The covariance of a subset is
        the sub-block (eq. 32), and so are the correlations and Δ̃ (eq. 35)."""
        idx = [self.names.index(g) for g in names.values()]

        def sub(m: np.ndarray | None) -> np.ndarray | None:
            return None if m is None else m[np.ix_(idx, idx)]

        def pick(d: Mapping[str, Any]) -> dict[str, Any]:
            return {k: d[g] for k, g in names.items() if g in d}

        return Analysis(list(names), pick(self.estimate), pick(self.sd), pick(self.err),
                        sub(self.covariance), sub(self.correlation), sub(self.delta_tilde))


@dataclass(frozen=True)
class TestFit:
    """One test's own fit: its white analysis, noise, residuals and discrepancy analysis."""

    __test__ = False  # not a pytest test class despite its name

    name: str
    white: Analysis | None
    discrepancy: dict[str, Any] | None   # the GLS block of the test (docs/fit.md), as written
    sigma0: float | None
    sigma0_source: str
    residuals: dict[str, Any]            # the residual diagnostics and their verdict
    warnings: list[str]
    strain_rate: float | None
    deborah_max: float | None
    n_points: int | None
    raw: dict[str, Any] = field(repr=False, default_factory=dict)
    rms_alone: float | None = None       # rms at the test's own estimate, when the run's is another

    @classmethod
    def from_dict(cls, name: str, d: Mapping[str, Any], names: Sequence[str]) -> TestFit:
        def num(k: str) -> float | None:
            v = d.get(k)
            return float(v) if isinstance(v, int | float) and math.isfinite(v) else None

        return cls(name=name, white=Analysis.from_dict(d, names), discrepancy=d.get("discrepancy") or None,
                   sigma0=num("sigma0"), sigma0_source=str(d.get("sigma0_source") or ""),
                   residuals=dict(d.get("residuals") or {}), warnings=list(d.get("warnings") or []),
                   strain_rate=num("strain_rate"), deborah_max=num("deborah_max"),
                   n_points=int(d["n_points"]) if d.get("n_points") is not None else None, raw=dict(d))

    @property
    def generalized(self) -> Analysis | None:
        """The test's GLS analysis, when its fit made one with an estimate."""
        names = self.white.names if self.white is not None else []
        return Analysis.from_dict(self.discrepancy, names)


@dataclass(frozen=True)
class FitRecord:
    """The run's fit: its white analysis, its generalized one (when any test has model error), and
    each test's own fit."""

    names: list[str]                     # the run's free parameters
    white: Analysis | None
    generalized: Analysis | None
    tests: dict[str, TestFit]
    plain: bool                          # one test: the run's analyses are the test's
    warnings: list[str]
    per_test: list[str]
    raw: dict[str, Any] = field(repr=False, default_factory=dict)
    at_run: dict[str, dict[str, Any]] = field(default_factory=dict)   # per test, at the run's estimate
    data_sha256: str | None = None       # the data file(s) the fit was made from

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], test_names: Sequence[str]) -> FitRecord:
        """Either layout of fit.json (``test_names``: the run's tests, in config order)."""
        names = list(d.get("parameters") or [])
        plain = not d.get("joint")
        at_run: dict[str, dict[str, Any]] = {}
        if plain:
            tests = {test_names[0]: TestFit.from_dict(test_names[0], d, names)}
        else:
            singles, info = d.get("single_fits") or {}, d.get("tests") or {}
            tests = {}
            for t in test_names:
                own = dict(singles.get(t) or {})
                own.setdefault("n_points", (info.get(t) or {}).get("n_points"))
                own_names = [k for k in own.get("sd") or {}] or names
                tests[t] = TestFit.from_dict(t, own, own_names)
                at_run[t] = dict(info.get(t) or {})
        return cls(names=names, white=Analysis.from_dict(d, names),
                   generalized=Analysis.from_dict(d.get("discrepancy"), names), tests=tests, plain=plain,
                   warnings=list(d.get("warnings") or []), per_test=list(d.get("per_test") or []),
                   raw=dict(d), at_run=at_run, data_sha256=d.get("data_sha256"))

    def for_test(self, test: str, names: Mapping[str, str]) -> FitRecord:
        """One test of the run read as a run with one test: the run's analyses restricted to the
        test's own parameters (``names``: its own name -> the run's), its residuals at the run's
        estimate, its own σ0, warnings and discrepancy analysis. A run with one test is its own."""
        if self.plain:
            return self
        own = self.tests[test]
        white = self.white.restrict(names) if self.white is not None else None
        generalized = self.generalized.restrict(names) if self.generalized is not None else None
        at = self.at_run.get(test) or {}
        rms = at.get("rms_single_fit")
        seen = replace(own, white=white, residuals=dict(at.get("residuals") or own.residuals),
                       rms_alone=float(rms) if isinstance(rms, int | float) else None)
        return FitRecord(names=list(names), white=white, generalized=generalized, tests={test: seen},
                         plain=True, warnings=list(own.warnings), per_test=[])

    @property
    def sigma0(self) -> float | None:
        """The white analysis' σ0 of a run with one test (None for several: one σ0 per test)."""
        return self.tests[next(iter(self.tests))].sigma0 if self.plain else None

    def start_analysis(self, uses_discrepancy: bool) -> Analysis | None:
        """Where the walkers start: the generalized analysis when the likelihood has a discrepancy
        (and the fit made one), else the white one."""
        return (self.generalized if uses_discrepancy else None) or self.white


def held_parameters(fit: Mapping[str, Any] | None) -> dict[str, float]:
    """The parameters fit.json holds because the window cannot identify them (its
    ``identifiability`` block): name -> the value held at."""
    held = ((fit or {}).get("identifiability") or {}).get("held") or {}
    return {k: float(v["value"]) for k, v in held.items()}


def held_config(cfg, fit: Mapping[str, Any] | None):
    """The config as the run fits and samples it: ``cfg`` with fit.json's held parameters fixed
    (``Config.with_holds``). Identity and staleness stay with ``cfg`` itself: the holds follow
    from it and the data."""
    return cfg.with_holds(held_parameters(fit))
