"""The report's curves kept by ``sample`` (runs/curve_cache.py): the same arrays the report would
compute, made again when an output changes, and not made when asked not to. That a report from
them loads no compiled code is checked with what every command imports (tests/cli/test_lazy_imports.py)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from support.sampling import write_case

from bayes_dnlr.config import load_config
from bayes_dnlr.runs.curve_cache import report_curves
from bayes_dnlr.runs.curves import compute_curves
from bayes_dnlr.runs.results import load_run
from bayes_dnlr.runs.sample import sample

# a short chain: these tests check the curves sample keeps beside it (from 200 of its 1300 kept
# draws), not the chain
SAMPLER = {"walkers": 16, "max_steps": 100, "target_ess": 100, "checkpoint_every": 100}
FIELDS = ("x", "data", "window", "strain", "median", "gn_curve", "white_curve")


@pytest.fixture(scope="module")
def disc_run(tmp_path_factory):
    """A synthetic test with a correlated model error, sampled under the discrepancy."""
    path = write_case(tmp_path_factory.mktemp("curves"), "disc", n=250, seed=3, error=("exp", 1.0, 40.0),
                      noise="residuals", discrepancy="default", sampler=SAMPLER)
    sample(load_config(path), progress=False)
    return path.parent


def _kept(run_dir):
    return sorted((run_dir / ".cache").glob("curves-*.npz"))


def _same(a, b) -> None:
    for k in FIELDS:
        assert np.array_equal(getattr(a, k), getattr(b, k)), k
    assert a.xlabel == b.xlabel
    for k in ("band", "predictive"):
        assert all(np.array_equal(u, v) for u, v in zip(getattr(a, k), getattr(b, k), strict=True)), k
    assert list(a.sensitivities) == list(b.sensitivities)
    for k in a.sensitivities:
        assert np.array_equal(a.sensitivities[k], b.sensitivities[k]), k


def test_sample_keeps_the_curves_the_report_would_compute(disc_run) -> None:
    assert len(_kept(disc_run)) == 1
    view = load_run(disc_run).tests["disc"]
    assert view.uses_discrepancy
    kept, kept_disc = report_curves(view, "disc")
    fresh, fresh_disc = compute_curves(view)
    _same(kept, fresh)
    assert kept.median is not None and kept.predictive is not None
    assert fresh_disc is not None and kept_disc is not None
    for k in ("residuals", "mean", "whitened"):
        assert np.array_equal(getattr(kept_disc, k), getattr(fresh_disc, k)), k
    assert (kept_disc.kernel, kept_disc.hyper) == (fresh_disc.kernel, fresh_disc.hyper)
    assert np.array_equal(kept_disc.axis.values, fresh_disc.axis.values)
    assert len(_kept(disc_run)) == 1                   # read, not made again


def test_a_changed_output_makes_the_curves_again(disc_run, tmp_path) -> None:
    run_dir = shutil.copytree(disc_run, tmp_path / "disc")
    before = _kept(run_dir)
    summary = json.loads((run_dir / "summary.json").read_text())
    summary["noise"]["amplitude"]["mean"] *= 2.0         # another discrepancy: another δ
    (run_dir / "summary.json").write_text(json.dumps(summary))
    view = load_run(run_dir).tests["disc"]
    _, disc = report_curves(view, "disc")
    after = _kept(run_dir)
    assert len(after) == 1 and after != before           # the stale set is replaced, not kept beside
    _, fresh = compute_curves(view)
    assert np.array_equal(disc.mean, fresh.mean)


def test_sample_asked_not_to_keeps_no_curves(tmp_path) -> None:
    path = write_case(tmp_path, "white", n=200, seed=1, sampler=SAMPLER)
    sample(load_config(path), progress=False, report_curves=False)
    assert (path.parent / "summary.json").is_file()
    assert _kept(path.parent) == []
