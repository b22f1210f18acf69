"""The shipped examples: the posterior recovers the truth, has converged, and (3 parameters, close to
Gaussian) agrees with the linearized Gauss-Newton analysis (sd within 15 %, correlations within 0.05)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from support import REPO

from bayes_dnlr.config import load_config
from bayes_dnlr.runs.sample import sample

RUNS = REPO / "runs"
EXAMPLES = ["hdpe-a-2.5e-3", "hdpe-a-5e-3", "hdpe-a-1e-2", "hdpe-b-relax-5e-3"]
DEMO = "hdpe-a-5e-3"        # `make demo`'s example: checked in the default suite too


def _slow_but_demo(names: list[str]) -> list:
    """The statistical checks of long chains are slow tests (each example sampled to ESS 1000, as
    test_joint.py's recovery is), except on the example `make demo` runs (about 2 s)."""
    return [pytest.param(n, marks=() if n == DEMO else pytest.mark.slow) for n in names]


@pytest.fixture(scope="module")
def sampled(tmp_path_factory):
    """Sample each example once per module (a copy in a temporary folder)."""
    cache: dict[str, tuple] = {}

    def get(name: str):
        if name not in cache:
            cache[name] = _sample_copy(name, tmp_path_factory.mktemp(name))
        return cache[name]

    return get


def _sample_copy(name: str, tmp: Path):
    src = RUNS / name
    if not (src / "config.yaml").is_file():
        pytest.skip(f"example {name} is not in runs/")
    dst = tmp / name
    dst.mkdir()
    for f in src.iterdir():
        if f.suffix in (".yaml", ".csv"):
            shutil.copy(f, dst / f.name)
    cfg = load_config(dst / "config.yaml")
    return cfg, sample(cfg, progress=False)


@pytest.mark.parametrize("name", _slow_but_demo(EXAMPLES))
def test_example_recovers_truth_and_converges(sampled, name: str) -> None:
    cfg, post = sampled(name)
    s = post.summary
    truth = cfg.truth.params
    assert s["stop_reason"] == "converged"
    expected = ["E", "G", "tau_max"] + (["sigma_inf", "tau_max_R"] if cfg.has_relaxation else [])
    assert s["parameters"] == expected
    print(f"\n{name}: {s['steps']} steps, burn-in {s['burn_in']}")
    for k in s["parameters"]:
        p = s["posterior"][k]
        z = (p["mean"] - truth[k]) / p["sd"]
        print(f"  {k:<10} truth {truth[k]:<8.6g} mean {p['mean']:<10.6g} sd {p['sd']:<9.4g} "
              f"z {z:+.2f}  ESS bulk {p['ess_bulk']:.0f} tail {p['ess_tail']:.0f} "
              f"(tau: {s['ess_autocorr'][k]:.0f})  R-hat {p['r_hat']:.4f}")
        assert abs(z) <= 3.0, k
        assert p["r_hat"] <= 1.01, k
        assert min(p["ess_bulk"], p["ess_tail"], s["ess_autocorr"][k]) >= 1000, k


@pytest.mark.parametrize("name", _slow_but_demo(EXAMPLES[:3]))
def test_three_parameter_posterior_matches_linearized(sampled, name: str) -> None:
    _, post = sampled(name)
    s = post.summary
    gn = s["gauss_newton"]
    names = s["parameters"]
    assert gn["parameters"] == names
    print(f"\n{name}: posterior sd vs linearized (Gauss-Newton) sd")
    for k in names:
        ratio = s["posterior"][k]["sd"] / gn["sd"][k]
        print(f"  {k:<8} posterior {s['posterior'][k]['sd']:.5g}  linearized {gn['sd'][k]:.5g}  "
              f"ratio {ratio:.3f}")
        assert abs(ratio - 1.0) <= 0.15, k
    rho_post = np.asarray(s["posterior_correlation"])
    rho_gn = np.asarray(gn["correlation"])
    for i in range(3):
        for j in range(i + 1, 3):
            print(f"  rho({names[i]}, {names[j]}): posterior {rho_post[i, j]:+.4f}  "
                  f"linearized {rho_gn[i, j]:+.4f}")
    assert np.max(np.abs(rho_post - rho_gn)) <= 0.05
