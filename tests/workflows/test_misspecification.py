"""The misspecification benchmark at reduced size (benchmarks/misspecification.py runs 30 replicates
of every kind): synthetic tests from richer models than the fitted one, through fit and sample
from config keys only.

For a calibrated 90 % interval the number of covering replicates out of 10 is Binomial(10, 0.9):
P(fewer than 7) = 0.013.
"""

from __future__ import annotations

import sys
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from misspecification import replicate  # noqa: E402

from bayes_dnlr.config import ALPHA_PRIOR  # noqa: E402

TARGET_ESS = 400.0


def run(folder: Path, kind: str, strength: str, reps: int, per_rep=lambda r: [],
        fit_only: bool = False) -> list[dict]:
    work = [(str(folder), kind, strength, "default", r, per_rep(r), TARGET_ESS, fit_only)
            for r in range(reps)]
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        out = list(pool.map(replicate, work))
    assert not [r["error"] for r in out if "error" in r]
    return out


@pytest.mark.slow
def test_clean_data_are_covered_with_the_default_config(tmp_path: Path) -> None:
    res = run(tmp_path, "clean", "mild", 10)
    print([round(r["z"], 2) for r in res])
    assert sum(r["covered"] for r in res) >= 7
    # no model error: the score test of alpha = ½ stays quiet (|z| > 3 has probability 0.003)
    assert all(abs(r["score_white_z"]) < 3 for r in res)


@pytest.mark.slow
def test_alpha_sampled_is_calibrated_when_the_truth_is_drawn_from_its_prior(tmp_path: Path) -> None:
    """Each replicate's true spectrum exponent is a draw from ALPHA_PRIOR, the prior the posterior
    uses: E's interval then holds the truth at its nominal rate."""
    rng = np.random.default_rng(2026)
    alphas = np.clip(rng.normal(ALPHA_PRIOR["mean"], ALPHA_PRIOR["sd"], 10), 0.0, 1.0)

    def keys(r: int) -> list:
        return [("truth.params.alpha", float(alphas[r])), ("parameters.alpha", dict(ALPHA_PRIOR))]

    res = run(tmp_path, "clean", "mild", 10, keys)
    print([(round(r["z"], 2), round(r["posterior"]["alpha"]["mean"], 3)) for r in res])
    assert all("alpha" in r["posterior"] for r in res)
    assert sum(r["covered"] for r in res) >= 7


@pytest.mark.slow
def test_the_alpha_score_signals_a_toe_and_a_second_relaxation_process(tmp_path: Path) -> None:
    """A strain toe and a tensile-then-relaxation test with a second, slower process move E out of
    its interval (docs/model-form.md); the score test of the spectrum's exponent under the
    discrepancy (fit.json discrepancy.alpha_score) is the signal a check can read: |z| > 2 in 30
    of 30 and 29 of 30 replicates of the benchmark."""
    for kind in ("strain-toe", "two-process-hold"):
        res = run(tmp_path / kind, kind, "strong", 6, fit_only=True)
        z = [r["score_gls_z"] for r in res]
        print(kind, [round(v, 1) for v in z])
        assert sum(abs(v) > 2 for v in z) >= 5, kind


def test_the_stress_shift_kind_is_an_eyring_truth_into_the_nonlinear_range(tmp_path: Path) -> None:
    """The held-out ``stress-shift`` kind: an Eyring truth (truth.shift) whose ramp flows far below
    the stress-blind model's stress, E(t) asked at 10× the first resolved time, and the fitted
    model named in the record's label."""
    from misspecification import at_resolved, fitted_model, row_label, write_config

    from bayes_dnlr.config import load_config
    from bayes_dnlr.data import load_test
    from bayes_dnlr.inference.modulus_window import test_window
    from bayes_dnlr.model import simulate
    from bayes_dnlr.workflows.simulate import simulate_test

    path = write_config(tmp_path, "stress-shift", "mild", "default", 0,
                        [("model.shift", {"stress": "eyring"})], 400.0)
    cfg = load_config(path)
    assert cfg.truth.shift.stress == "eyring" and 1.0 < cfg.truth.params["sigma_s"] < 4.0
    sim = simulate_test(cfg)
    blind = simulate(sim.time, sim.strain, cfg.truth.params | {"sigma_s": np.inf}, modes=50,
                     decades=6, relaxation_start=None)
    assert sim.stress.max() < 0.5 * blind.max()          # flow: far into the nonlinear range
    early = sim.strain < 5e-4                            # σ ≪ sigma_s: the linear start
    assert np.allclose(sim.stress[early], blind[early], rtol=0.1, atol=0.05)
    at_resolved(path, [10.0])
    cfg = load_config(path)
    first = test_window(load_test(cfg)).shortest
    assert cfg.output.modulus_at == [pytest.approx(10 * first, rel=1e-5)]
    assert fitted_model(cfg) == "eyring"
    assert row_label({"kind": "stress-shift", "fitted": "eyring"}) == "stress-shift+eyring"
    assert row_label({"kind": "stress-shift"}) == "stress-shift"


def test_read_checks_names_each_physical_check_that_fired() -> None:
    from misspecification import read_checks

    checks = {"trust_interval": False, "adequate": True, "model_form": {"ok": True},
              "plausibility": {"tau_max": {"ok": False, "median": 2e4}, "E_chord": {"ok": True}},
              "bound_limited": [{"parameter": "G"}]}
    trust, fired = read_checks({"checks": checks})
    assert trust is False and fired == ["bound_limited", "plausibility.tau_max"]
