"""Large files: a 1 kHz test of 1000 s (1e6 rows, 40 MB) is read with the default
settings and its strain smoothed (the GCV spline failed as 'ill-posed' at 1e6 samples before), and
fitted (data.reduce: auto, bins of 50 rows). Both are slow tests (a 1e6-row file: tests/README.md);
the default suite smooths 1e6 samples in tests/data/test_testdata.py. Time and peak memory per
size: benchmarks/large_files.py."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from support import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
from large_files import write_test  # noqa: E402

from bayes_dnlr.config import load_config  # noqa: E402
from bayes_dnlr.data import load_test  # noqa: E402

ROWS = 1_000_000


@pytest.fixture(scope="module")
def million(tmp_path_factory) -> Path:
    """The config of a 1e6-row test (default settings but sigma0), as the benchmark writes it."""
    return write_test(tmp_path_factory.mktemp("large"), ROWS)


@pytest.mark.slow
def test_a_million_rows_load_and_the_smoothing_succeeds(million: Path) -> None:
    cfg = load_config(million)
    cfg.data.reduce = "none"
    test = load_test(cfg)
    assert test.time.size == ROWS
    assert test.window.sum() == ROWS                       # the default window: the whole test
    note = next(n for n in test.notes if n.startswith("strain_input: smoothed"))
    assert "GCV" in note
    # the written strain is 1.9e-3 t plus noise of sd 1e-4: the spline recovers the ramp
    truth = 1.9e-3 * test.time
    rms = float(np.sqrt(np.mean((test.strain_input - truth) ** 2)))
    assert rms < 1e-5, rms
    assert np.all(np.isfinite(test.stress))


@pytest.mark.slow
def test_a_million_rows_fit_with_the_default_config(million: Path) -> None:
    from bayes_dnlr.runs.fit import fit

    result = fit(load_config(million), write=False).only
    assert result.converged
    assert result.n_points == 1 + -(-(ROWS - 1) // 50)        # data.reduce: auto, bins of 50 rows
    assert any(n.startswith("data.reduce (auto)") for n in result.data_notes)
    assert result.estimate["E"] == pytest.approx(2854.0, rel=0.01)
