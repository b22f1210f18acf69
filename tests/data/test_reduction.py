"""``data.reduce``: long files averaged in bins of consecutive rows (data/reduction.py) - the bins,
the switch as docs/data-input.md states it, the note, σ0 per point, and E kept within its tolerance."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from support import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
from large_files import write_test  # noqa: E402

from bayes_dnlr.config import ConfigError, load_config  # noqa: E402
from bayes_dnlr.data import load_test  # noqa: E402
from bayes_dnlr.data.reduction import REDUCE_POINTS, bin_means, bins, rows_per_point  # noqa: E402
from bayes_dnlr.inference.lsq.sigma0 import resolve_sigma0  # noqa: E402


def test_the_bins_keep_the_first_rows_alone_and_never_straddle_a_break() -> None:
    cuts = bins(12, 4, 1, [7])
    assert cuts.tolist() == [0, 1, 5, 7, 11, 12]
    v = np.arange(12.0)
    assert bin_means(v, cuts).tolist() == [0.0, 2.5, 5.5, 8.5, 11.0]
    assert bins(5, 4, 2, []).tolist() == [0, 1, 2, 5]       # a virtual start and the first row


def test_auto_reduces_only_long_files_with_a_smoothed_strain() -> None:
    assert rows_per_point("auto", REDUCE_POINTS) == 1
    assert rows_per_point("auto", REDUCE_POINTS + 1) == 2
    assert rows_per_point("auto", 1_000_000) == 50
    assert rows_per_point("auto", 1_000_000, "measured") == 1   # would change the estimator
    assert rows_per_point("none", 1_000_000) == 1
    assert rows_per_point(7, 100) == 7


@pytest.fixture(scope="module")
def long_test(tmp_path_factory) -> Path:
    return write_test(tmp_path_factory.mktemp("reduce"), 30_000)


def _config(path: Path, reduce):
    cfg = load_config(path)
    cfg.data.reduce = reduce
    return cfg


def test_the_switch_does_what_the_docs_say(long_test: Path) -> None:
    full = load_test(_config(long_test, "none"))
    auto = load_test(_config(long_test, "auto"))
    four = load_test(_config(long_test, 4))
    assert full.time.size == 30_000 and full.rows_per_point == 1
    assert not any("data.reduce" in n for n in full.notes)
    assert auto.rows_per_point == 2 and auto.time.size == 1 + 29_999 // 2 + 1
    assert four.rows_per_point == 4 and four.time.size == 1 + -(-29_999 // 4)
    note = next(n for n in four.notes if n.startswith("data.reduce"))
    assert "bins of 4" in note and "σ0/√4" in note
    # the first row as read, then bin means of every column, the smoothed strain included
    assert four.time[0] == full.time[0] and four.stress[0] == full.stress[0]
    assert four.time[1] == pytest.approx(full.time[1:5].mean(), rel=1e-12)
    assert four.stress[1] == pytest.approx(full.stress[1:5].mean(), rel=1e-12)
    assert four.strain_input[1] == pytest.approx(full.strain_input[1:5].mean(), rel=1e-12)
    assert four.window.all()
    # a numeric sigma0 is one row's: sigma0/√k per point
    assert resolve_sigma0(_config(long_test, 4), four)[0] == pytest.approx(0.3 / 2.0)
    assert resolve_sigma0(_config(long_test, "none"), full)[0] == 0.3
    from bayes_dnlr.runs.target import resolve_sigma0 as sampled_sigma0  # what sample's likelihood uses

    assert sampled_sigma0(_config(long_test, 4), None, four)[0] == pytest.approx(0.3 / 2.0)
    assert sampled_sigma0(_config(long_test, "none"), None, full)[0] == 0.3


def test_auto_counts_the_rows_to_the_window_end(long_test: Path) -> None:
    """A short window of a long file: the points the fit compares are few, nothing is averaged."""
    cfg = _config(long_test, "auto")
    cfg.data.window.strain_max = 0.5                # 263 s of the 1000 s test: 7900 rows
    test = load_test(cfg)
    assert test.rows_per_point == 1 and test.time.size == 30_000
    cfg.data.window.strain_max = 1.5                # 789 s: 23 700 rows
    assert load_test(cfg).rows_per_point == 2


def test_rows_per_bin_below_one_is_a_config_error(long_test: Path) -> None:
    text = long_test.read_text().replace("  area0: 24.0\n", "  area0: 24.0\n  reduce: 0\n")
    bad = long_test.with_name("bad.yaml")
    bad.write_text(text)
    with pytest.raises(ConfigError, match="data.reduce"):
        load_config(bad)


@pytest.mark.slow
def test_the_reduced_fit_keeps_e_within_a_tenth_of_its_sd(long_test: Path) -> None:
    """Bins of 10 rows (0.33 s of a 1000 s test): E and its sd as with every row (an accuracy
    check of two fits of 30 000 rows: the slow suite)."""
    from bayes_dnlr.runs.fit import fit

    full = fit(_config(long_test, "none"), write=False).only
    red = fit(_config(long_test, 10), write=False).only
    assert red.n_points == 1 + -(-29_999 // 10)
    assert abs(red.estimate["E"] - full.estimate["E"]) < 0.1 * full.sd["E"]
    assert red.sd["E"] == pytest.approx(full.sd["E"], rel=0.02)
    assert any(n.startswith("data.reduce (10)") for n in red.data_notes)
