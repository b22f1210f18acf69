"""The optional real curves measured by others (never part of the project): where they are, and the
marks of the tests that read them.

The folder is ``$BAYES_DNLR_REAL_DATA`` when set, else the first ``shared/data/real`` beside the
clone or above it (``../shared/data/real`` for a clone next to ``shared``). Tests that read it carry
``REAL_MARKS``: the ``real_data`` mark (counted in the summary by conftest.py) and a skip when the
files are absent.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

RHDPE_NAME = "rHDPE_Resin19_specimen3_tensile_50mm_per_min.csv"
ETFE_NAME = "ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens.csv"
ENV = "BAYES_DNLR_REAL_DATA"


def real_folder() -> Path:
    """$BAYES_DNLR_REAL_DATA, else the nearest shared/data/real among the clone's ancestors."""
    given = os.environ.get(ENV)
    if given:
        return Path(given)
    repo = Path(__file__).resolve().parents[2]
    for up in repo.parents:
        folder = up / "shared" / "data" / "real"
        if (folder / ETFE_NAME).is_file():
            return folder
    return repo.parent / "shared" / "data" / "real"


REAL = real_folder()
RHDPE = REAL / RHDPE_NAME
ETFE = REAL / ETFE_NAME
PRESENT = RHDPE.is_file() and ETFE.is_file()
REASON = f"the real curves are absent ({REAL}; set {ENV} to their folder)"
REAL_MARKS = (pytest.mark.real_data, pytest.mark.skipif(not PRESENT, reason=REASON))


def real(test):
    """Decorate a test that reads the real curves."""
    for mark in REAL_MARKS:
        test = mark(test)
    return test


# more real exports of the same ETFE film (fbosi/ETFENLVEconstitutivemodel, rawData/): a ramp then a
# hold whose header is shifted against its data, and loading-unloading cycles with an engineering
# stress only and repeated time stamps. The folder is $BAYES_DNLR_REAL_EXPORTS when set, else the
# first scratch/real beside the clone or above it.
EXPORTS_ENV = "BAYES_DNLR_REAL_EXPORTS"
RELAX_NAME = "OUTRaw_MD_Rel_9MPa_T20.csv"
CYCLES_NAME = "OUTRaw_MD_CYC_CSR_01_T20.csv"


def exports_folder() -> Path:
    """$BAYES_DNLR_REAL_EXPORTS, else the nearest scratch/real among the clone's ancestors."""
    given = os.environ.get(EXPORTS_ENV)
    if given:
        return Path(given)
    repo = Path(__file__).resolve().parents[2]
    for up in repo.parents:
        folder = up / "scratch" / "real"
        if (folder / RELAX_NAME).is_file() or (folder / CYCLES_NAME).is_file():
            return folder
    return repo.parent / "scratch" / "real"


EXPORTS = exports_folder()
RELAX = EXPORTS / RELAX_NAME
CYCLES = EXPORTS / CYCLES_NAME


def export_marks(path: Path) -> tuple:
    """The marks of a test that reads one of the exports: real_data, and a skip naming the file
    when it is absent."""
    reason = f"the real export {path.name} is absent from {path.parent} (set {EXPORTS_ENV} to its folder)"
    return pytest.mark.real_data, pytest.mark.skipif(not path.is_file(), reason=reason)


def reads_export(path: Path):
    """Decorate a test that reads the real export ``path``."""
    def decorate(test):
        for mark in export_marks(path):
            test = mark(test)
        return test
    return decorate
