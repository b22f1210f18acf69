"""``kernel: auto`` (the default): fit compares exp and matern32 and takes the one with the higher
maximum likelihood, unless matern32 moves a parameter by more than 2 combined sd (it absorbs the
model's response); sample, resume and the report use the kernel fit chose."""

from __future__ import annotations

import json
import math

import h5py
import pytest
from support.sampling import write_case

from bayes_dnlr.config import load_config, parse_config
from bayes_dnlr.inference.discrepancy.gls import SAME_ESTIMATE_SD, choose_kernel
from bayes_dnlr.report import build_report
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.runs.sample import sample


def _pair(exp: dict, matern32: dict) -> tuple[str, dict]:
    return choose_kernel({"exp": exp, "matern32": matern32})


def _analysis(ll: float, E: float, sd_E: float, *, evidence: bool = True, G: float = 2.3) -> dict:
    return {"log_likelihood": ll, "estimate": {"E": E, "G": G}, "sd": {"E": sd_E, "G": 0.1},
            "hyperparameters": {"sigma0": 0.3, "amplitude": 1.0, "length": 50.0}, "evidence": evidence}


def test_the_higher_likelihood_wins_when_the_estimates_agree() -> None:
    kernel, record = _pair(_analysis(-100.0, 2850, 40), _analysis(-90.0, 2870, 40))
    assert kernel == "matern32"
    assert record["log_likelihood_gain_matern32"] == pytest.approx(10.0)
    assert record["move_in_sd"]["E"] == pytest.approx(20 / math.hypot(40, 40))
    assert "warning" not in record
    kernel, record = _pair(_analysis(-90.0, 2850, 40), _analysis(-100.0, 2850, 40))
    assert kernel == "exp" and "exp has the higher" in record["reason"]


def test_matern32_that_moves_E_too_far_is_refused_with_a_warning() -> None:
    far = 2850 - 1.01 * SAME_ESTIMATE_SD * math.hypot(40, 50)
    kernel, record = _pair(_analysis(-100.0, 2850, 40), _analysis(+500.0, far, 50))
    assert kernel == "exp"
    assert "moves E from 2850" in record["reason"] and "absorbs" in record["reason"]
    assert "kernel auto kept exp" in record["warning"]
    near = 2850 - 0.99 * SAME_ESTIMATE_SD * math.hypot(40, 50)
    kernel, _ = _pair(_analysis(-100.0, 2850, 40), _analysis(+500.0, near, 50))
    assert kernel == "matern32"


def test_no_linearized_sd_or_no_evidence_keeps_exp() -> None:
    kernel, record = choose_kernel({"exp": _analysis(-100.0, 2850, 40),
                                    "matern32": _analysis(-90.0, 2850, math.nan)})
    assert kernel == "exp" and "no linearized sd" in record["reason"]
    kernel, record = choose_kernel({"exp": _analysis(-100.0, 2850, 40, evidence=False),
                                    "matern32": _analysis(-99.0, 2850, 40, evidence=False)})
    assert kernel == "exp" and "no evidence" in record["reason"]


def test_auto_is_the_default_and_named_in_the_error_for_an_unknown_kernel() -> None:
    raw = {"name": "x", "data": {"file": "d.csv", "columns": {"time": 1, "strain": 2, "stress": 3},
                                 "observable": "stress"}}
    assert parse_config(raw).noise.discrepancy.kernel == "auto"
    with pytest.raises(ValueError, match=r"noise.discrepancy.kernel: .*'auto', 'exp' or 'matern32'"):
        parse_config(raw | {"noise": {"discrepancy": {"kernel": "gauss"}}})
    with pytest.raises(ValueError, match=r"noise.discrepancy: unknown form .*kernels: auto, exp, matern32"):
        parse_config(raw | {"noise": {"discrepancy": "gaussian"}})


@pytest.fixture(scope="module")
def smooth_error_run(tmp_path_factory):
    """A test with a smooth (Matérn-3/2) model error, default config, fitted and briefly sampled."""
    path = write_case(tmp_path_factory.mktemp("auto"), "smooth", n=600, seed=30_001,
                      error=("matern32", 1.0, 50.0), noise="residuals", discrepancy="default",
                      sampler={"walkers": 16, "max_steps": 600, "target_ess": 100, "checkpoint_every": 50})
    cfg = load_config(path)
    sample(cfg, progress=False)
    return path.parent


def test_a_smooth_error_gets_matern32_in_fit_sample_and_report(smooth_error_run) -> None:
    run = smooth_error_run
    disc = json.loads((run / "fit.json").read_text())["discrepancy"]
    assert disc["kernel"] == "matern32"
    choice = disc["kernel_choice"]
    assert choice["log_likelihood_gain_matern32"] > 0
    assert max(abs(m) for m in choice["move_in_sd"].values()) <= SAME_ESTIMATE_SD
    assert set(choice["candidates"]) == {"exp", "matern32"}
    with h5py.File(run / "chains.h5", "r") as f:
        assert json.loads(f.attrs["discrepancy_kernel"]) == "matern32"
    noise = json.loads((run / "summary.json").read_text())["noise"]
    assert noise["kernel"] == "matern32" and "higher maximum likelihood" in noise["kernel_choice"]["reason"]
    page = build_report(run).read_text()
    assert "kernel: auto; matern32 has the higher maximum likelihood" in page


def test_a_rough_error_keeps_exp(tmp_path) -> None:
    path = write_case(tmp_path, "rough", n=600, seed=30_000, error=("exp", 1.0, 20.0),
                      noise="residuals", discrepancy="default")
    disc = fit(load_config(path)).discrepancy
    assert disc["kernel"] == "exp"
    assert disc["kernel_choice"]["log_likelihood_gain_matern32"] < 0


def test_a_resumed_chain_keeps_the_kernel_it_started_with() -> None:
    """fit.json may be re-made with another choice; the chain's own record wins, per test too."""
    from types import SimpleNamespace

    from bayes_dnlr.runs.target import stored_per_test

    assert stored_per_test(None, "discrepancy_kernel", True, ["t"]) == {}      # fresh: fit.json's
    stored = SimpleNamespace(attrs={"discrepancy_kernel": json.dumps("matern32")})
    assert stored_per_test(stored, "discrepancy_kernel", True, ["t"]) == {"t": "matern32"}
    joint = SimpleNamespace(attrs={"discrepancy_kernel": json.dumps({"a": "matern32", "b": "exp"})})
    assert stored_per_test(joint, "discrepancy_kernel", False, ["a", "b"]) == {"a": "matern32",
                                                                            "b": "exp"}
