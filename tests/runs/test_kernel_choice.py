"""``kernel: auto`` (the default): fit analyses exp and matern32 on the orthogonal discrepancy and
weighs them by their maximum likelihood; the estimate is the projection θ* whatever the weights,
so no kernel choice can move it; sample, resume and the report use the kernel of highest weight."""

from __future__ import annotations

import json
import math

import h5py
import numpy as np
import pytest
from support.drawing import figures_not_drawn
from support.sampling import write_case

from bayes_dnlr.config import load_config, parse_config
from bayes_dnlr.inference.discrepancy.orthogonal import kernel_weights
from bayes_dnlr.report import build_report
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.runs.sample import sample


def test_the_weights_follow_the_likelihood_continuously() -> None:
    """Equal likelihoods: equal weights; the weight of matern32 is the logistic function of the
    likelihood difference, so a small change of the data changes it a little (no threshold)."""
    gaps = np.linspace(-6.0, 6.0, 121)
    w = np.array([kernel_weights({"exp": 0.0, "matern32": g})["matern32"] for g in gaps])
    np.testing.assert_allclose(w, 1.0 / (1.0 + np.exp(-gaps)), rtol=1e-12)
    assert np.max(np.diff(w)) <= 0.25 * (gaps[1] - gaps[0]) + 1e-12     # the logistic's slope
    assert kernel_weights({"exp": 1e4, "matern32": 0.0}) == {"exp": 1.0, "matern32": 0.0}


def test_auto_is_the_default_and_named_in_the_error_for_an_unknown_kernel() -> None:
    raw = {"name": "x", "data": {"file": "d.csv", "columns": {"time": 1, "strain": 2, "stress": 3},
                                 "observable": "stress"}}
    assert parse_config(raw).noise.discrepancy.kernel == "auto"
    with pytest.raises(ValueError, match=r"noise.discrepancy.kernel: .*'auto', 'exp' or 'matern32'"):
        parse_config(raw | {"noise": {"discrepancy": {"kernel": "gauss"}}})
    with pytest.raises(ValueError, match=r"noise.discrepancy: unknown form .*kernels: auto, exp, matern32"):
        parse_config(raw | {"noise": {"discrepancy": "gaussian"}})


def _smooth_case(folder, target: str | None = None, max_steps: int = 600):
    disc = "default" if target is None else {"target": target}
    path = write_case(folder, "smooth", n=600, seed=30_001, error=("matern32", 1.0, 50.0),
                      noise="residuals", discrepancy=disc,
                      sampler={"walkers": 16, "max_steps": max_steps, "target_ess": 100,
                               "checkpoint_every": 50})
    sample(load_config(path), progress=False)
    return path.parent


@pytest.fixture(scope="module")
def smooth_error_run(tmp_path_factory):
    """A test with a smooth (Matérn-3/2) model error, default config, fitted and briefly sampled."""
    return _smooth_case(tmp_path_factory.mktemp("auto"))


def test_a_smooth_error_weighs_matern32_in_fit_sample_and_report(smooth_error_run, monkeypatch) -> None:
    run = smooth_error_run
    fit_json = json.loads((run / "fit.json").read_text())
    disc = fit_json["discrepancy"]
    assert disc["kernel"] == "exp" and disc["target"] == "generalized"     # the sampled working model
    choice = disc["kernel_choice"]
    w = choice["weights"]["matern32"]
    assert w > 0.5 and choice["log_likelihood_gain_matern32"] > 0
    assert set(choice["candidates"]) == {"exp", "matern32"}
    with h5py.File(run / "chains.h5", "r") as f:
        assert json.loads(f.attrs["discrepancy_kernel"]) == "exp"
        assert json.loads(f.attrs["discrepancy_projection"]) == "generalized"
        chain_sd = float(np.std(f["chain"][-200:, :, 0]))
    summary = json.loads((run / "summary.json").read_text())
    noise = summary["noise"]
    assert noise["kernel"] == "exp" and "matern32" in noise["kernel_choice"]["reason"]
    proj = noise["projection"]
    assert proj["kernel_weights"]["matern32"] == pytest.approx(w)
    # the draws of E were mapped onto the mixture covariance: their sd is the chain's times the factor
    factor = proj["sd_factor"]["E"]
    assert factor == pytest.approx(disc["projection"]["widening"]["E"], rel=1e-9)
    assert summary["posterior"]["E"]["sd"] == pytest.approx(factor * chain_sd, rel=0.25)
    assert summary["posterior"]["E"]["sd"] == pytest.approx(disc["sd"]["E"], rel=0.3)
    figures_not_drawn(monkeypatch)          # the page's text is read, not its figures
    page = build_report(run).read_text()
    assert "kernel: auto: the kernels&#x27; models of the error weighed by their likelihood" in page


def test_target_l2_samples_the_orthogonal_discrepancy_and_offsets_the_draws(tmp_path) -> None:
    # 300 steps: the last 200 measure θ*'s spread (the offsets are 15 times it at 300 steps as at 600)
    run = _smooth_case(tmp_path, "l2", max_steps=300)
    fit_json = json.loads((run / "fit.json").read_text())
    disc = fit_json["discrepancy"]
    assert disc["target"] == "l2"
    assert disc["estimate"] == fit_json["estimate"]          # an even grid: the least-squares estimate
    with h5py.File(run / "chains.h5", "r") as f:
        assert json.loads(f.attrs["discrepancy_projection"]) == "l2"
        theta_star_sd = float(np.std(f["chain"][-200:, :, 0]))
    summary = json.loads((run / "summary.json").read_text())
    proj = summary["noise"]["projection"]
    assert sum(proj["kernel_draws"].values()) == summary["draws"]
    # θ* is pinned at the noise level; the offsets make E's interval
    assert proj["sd_offset_u"]["E"] > 5 * theta_star_sd
    assert summary["posterior"]["E"]["sd"] > 5 * theta_star_sd


def test_the_estimate_does_not_depend_on_the_kernel(tmp_path) -> None:
    """exp, matern32 and auto give the same estimate (the projection) and differ only in width."""
    path = write_case(tmp_path, "rough", n=600, seed=30_000, error=("exp", 1.0, 20.0),
                      noise="residuals", discrepancy="default")
    raw = load_config(path).model_dump(mode="json", exclude_none=True)
    out = {}
    for kernel in ("auto", "exp", "matern32"):
        raw["noise"]["discrepancy"] = {"kernel": kernel}
        out[kernel] = fit(parse_config(raw, source=path), write=False).discrepancy
    assert out["auto"]["kernel_choice"]["weights"]["exp"] > 0.5
    for kernel in ("exp", "matern32"):
        assert out[kernel]["estimate"] == out["auto"]["estimate"]
        assert list(out[kernel]["kernel_choice"]["weights"]) == [kernel]
    assert out["exp"]["sd"]["E"] != out["matern32"]["sd"]["E"]
    w = out["auto"]["kernel_choice"]["weights"]
    mixed = math.sqrt(w["exp"] * out["exp"]["sd"]["E"] ** 2 + w["matern32"] * out["matern32"]["sd"]["E"] ** 2)
    assert out["auto"]["sd"]["E"] == pytest.approx(mixed, rel=1e-6)


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


def test_the_noise_floor_keeps_sigma0_at_the_measurement_noise(tmp_path) -> None:
    """A smooth misfit much larger than the noise (a matern32 error of 2 MPa, noise 0.02 MPa): σ0 is
    never below the high-frequency scatter of the residuals, which measures the noise."""
    from bayes_dnlr.inference.lsq.sigma0 import high_frequency_sd

    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 300.0, 3000)
    smooth = 2.0 * np.sin(t / 40.0) + np.cos(t / 13.0)
    assert high_frequency_sd(smooth + rng.normal(0.0, 0.3, t.size)) == pytest.approx(0.3, rel=0.08)
    assert high_frequency_sd(smooth) < 1e-3
    path = write_case(tmp_path, "floor", n=800, seed=30_002, sigma=0.02, error=("matern32", 2.0, 40.0),
                      noise="residuals", discrepancy="default")
    disc = fit(load_config(path)).discrepancy
    floor = disc["projection"]["sigma0_floor"]
    assert floor == pytest.approx(0.02, rel=0.15)
    assert disc["hyperparameters"]["sigma0"] >= floor
    for k in disc["kernel_choice"]["candidates"].values():
        assert k["hyperparameters"]["sigma0"] >= floor


def test_the_generalized_sd_is_the_weighted_sandwich(tmp_path) -> None:
    """fit.json's sd under model error is the weights' mixture of the kernels' covariances of the
    estimate; the exp kernel's is the exp model's own (Σ_w)."""
    path = write_case(tmp_path, "mix", n=600, seed=30_003, error=("matern32", 1.0, 50.0),
                      noise="residuals", discrepancy="default")
    disc = fit(load_config(path)).discrepancy
    proj = disc["projection"]
    mix = sum(v["weight"] * np.asarray(v["covariance_u"]) for v in proj["kernels"].values())
    np.testing.assert_allclose(np.asarray(proj["covariance_u"]), mix, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(proj["kernels"]["exp"]["covariance_u"]),
                               np.asarray(proj["sampled_covariance_u"]), rtol=1e-6)
    j = proj["u_names"].index("E")
    assert disc["sd"]["E"] == pytest.approx(math.sqrt(mix[j, j]), rel=1e-12)
