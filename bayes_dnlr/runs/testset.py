"""The tests of a run, loaded: one (a config with ``data:``) or several (``tests:``), with one
fingerprint of their data files and the config sections a result depends on.

This is where a run with one test is told from a run with several: a config with ``data:`` keeps
the plain parameter names and its outputs' one-test layout (``TestSet.plain``); everything
downstream reads ``plain`` (or ``Layout.plain``) instead of looking at the config again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from bayes_dnlr.config import Config
from bayes_dnlr.digests import digest
from bayes_dnlr.runs.layout import SMOOTHING_CACHE

SECTIONS = ("data", "model", "parameters", "noise", "fit")
REFERENCES = "reference_moduli"      # a result depends on the entries with use: data (identity.py)


def sections(cfg: Config, base: tuple[str, ...] = SECTIONS) -> tuple[str, ...]:
    """The config sections a result depends on: ``base``, ``tests`` when the config has them, and
    ``reference_moduli`` when some of its entries are data (``use: data``)."""
    out = (*base, "tests") if cfg.tests is not None else base
    if any(r.use == "data" for r in cfg.reference_moduli or []):
        out = (*out, REFERENCES)
    return out


def plain_names(cfg: Config) -> bool:
    """A run with one test under ``data:``: plain parameter names, one-test outputs."""
    return not cfg.is_joint


@dataclass(frozen=True)
class TestSet:
    """The tests of a run, loaded, in config order, with one fingerprint."""

    __test__ = False  # not a pytest test class despite its name

    tests: dict[str, Any]        # name -> TestData
    plain: bool = False          # one test under plain names (``plain_names``)

    def keep_smoothings(self) -> None:
        """Keep each test's smoothed strain in the run folder's cache, now that the folder exists
        (``TestData.keep_smoothing``)."""
        for data in self.tests.values():
            data.keep_smoothing()

    @property
    def sha256(self) -> str:
        """The data file's sha256 for one test, a digest of the tests' for several."""
        if self.plain:
            return next(iter(self.tests.values())).sha256
        return digest({t: d.sha256 for t, d in self.tests.items()})

    @property
    def n_points(self) -> int:
        return int(sum(d.n_points for d in self.tests.values()))

    @property
    def path(self) -> str:
        """The data files, for the record."""
        return ", ".join(str(d.path) for d in self.tests.values())


def load_tests(cfg: Config) -> TestSet:
    """The tests of a config, loaded (``data.load_test`` of each test's view)."""
    from bayes_dnlr.data import load_test

    cache = cfg.run_dir / SMOOTHING_CACHE
    return TestSet({t: load_test(cfg.for_test(t), cache) for t in cfg.test_names}, plain_names(cfg))
