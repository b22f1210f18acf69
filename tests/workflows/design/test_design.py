"""design: the prediction is the paper's a-priori analysis (eq. 32-35) of the planned test, with the
discrepancy it is the dense GLS covariance, the posterior average, the recommendation within the
constraints, the outputs, the errors that name the key; a slow check that the prediction comes true."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from support.finished_run import make_finished_run

from bayes_dnlr.cli import main
from bayes_dnlr.config import ConfigError, parse_config
from bayes_dnlr.data import TestData
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.discrepancy import gp
from bayes_dnlr.inference.lsq.identify import stochastic_analysis
from bayes_dnlr.inference.lsq.sensitivity import sensitivity_matrix
from bayes_dnlr.model import DNLR
from bayes_dnlr.workflows.design.candidates import expand, planned_protocol
from bayes_dnlr.workflows.design.config import load_design, parse_design
from bayes_dnlr.workflows.design.fisher import Draws, NoiseDraw, predict
from bayes_dnlr.workflows.design.run import run_design
from bayes_dnlr.workflows.design.validate import discrepancy_draws, validate_design

GUESS = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}


def design(**over) -> dict:
    raw = {"name": "d", "parameters": dict(GUESS), "noise": {"sigma0": 0.3},
           "conditions": {"strain_rate": {"low": 2.5e-3, "high": 2e-2, "n": 4},
                          "strain_max": [0.13, 0.5, 1.9], "sample_rate": 5}}
    for k, v in over.items():
        if k in raw["conditions"] or k in ("windows", "hold", "n_points"):
            raw["conditions"][k] = v
        else:
            raw[k] = v
    return raw


def _draws(cfg) -> tuple[Draws, list[str]]:
    from bayes_dnlr.workflows.design.run import resolve_draws

    d, free, _ = resolve_draws(cfg)
    return d, free


# ------------------------------------------------------------------ the prediction

def test_prediction_is_the_papers_analysis_of_the_planned_test():
    """White noise: Err, ρ and Δ̃ of the design equal lsq.stochastic_analysis (eq. 32-35) on the test
    simulate would make, for the whole curve and for interval I with G fixed (paper Table 2)."""
    cfg = parse_design(design(strain_rate=5e-3, strain_max=1.9, sample_rate=None, n_points=2000,
                              windows={"II": {}, "I": {"strain_max": 0.13, "fixed": ["G"]}}))
    draws, free = _draws(cfg)
    for c in expand(cfg):
        pred = predict(c, draws, free, 50, 6.0)
        prot = planned_protocol(c, GUESS)
        fixed = {"G": {"value": GUESS["G"]}} if "G" in c.window_spec.fixed else {}
        run_cfg = parse_config({"name": "x", "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e",
                                                                                  "stress": "s"},
                                                      "observable": "stress",
                                                      "window": c.window_spec.model_dump(exclude={"fixed"},
                                                                                        exclude_none=True)},
                                "parameters": fixed})
        m = np.ones(prot.time.size, bool) if c.window == "II" else prot.strain <= 0.13
        test = TestData(Path("x.csv"), "0" * 64, prot.time, prot.strain, prot.strain, prot.strain * 0,
                        np.expm1(prot.strain), None, m, None, 5e-3, "stress")
        sa = stochastic_analysis(run_cfg, test, GUESS, 0.3)
        assert pred.names == sa.names
        np.testing.assert_allclose([pred.sd[k] for k in sa.names], sa.sd, rtol=1e-8)
        np.testing.assert_allclose(pred.delta_tilde, sa.delta_tilde, rtol=1e-8, atol=1e-12)
        assert pred.A == pytest.approx(float(np.sum(sa.err**2)), rel=1e-8)
        assert pred.D == pytest.approx(np.linalg.slogdet(sa.covariance / np.outer(sa.values, sa.values))[1],
                                       rel=1e-8)
    # the paper's Table 2 pattern: ρ(E, tau_max) close to -1 on the whole curve
    whole = predict(expand(cfg)[0], draws, free, 50, 6.0)
    assert whole.correlation[0, 2] < -0.99


def test_discrepancy_prediction_is_the_dense_gls_covariance():
    """(XᵀK⁻¹X)⁻¹ with K = k(x, x) + σ0² I formed densely equals the O(n) whitened prediction."""
    for kernel, axis, length, start in (("matern32", "time", 8.0, "stationary"),
                                        ("exp", "strain", 0.05, "stationary"),
                                        ("matern32", "strain", 0.05, "pinned")):
        cfg = parse_design(design(strain_rate=1e-2, strain_max=1.0, sample_rate=None, n_points=400,
                                  noise={"sigma0": 0.3, "discrepancy": {"kernel": kernel, "axis": axis,
                                                                       "amplitude": 0.7, "length": length,
                                                                       "start": start}}))
        draws, free = _draws(cfg)
        c = expand(cfg)[0]
        pred = predict(c, draws, free, 50, 6.0)
        prot = planned_protocol(c, GUESS)
        X = sensitivity_matrix(DNLR(prot.time, prot.strain).basis(GUESS["tau_max"], grad=True), GUESS, free)
        x = prot.time if axis == "time" else prot.strain
        K = gp.covariance(x, 0.7, length, kernel, 0.3, start=0.0 if start == "pinned" else None)
        cov = np.linalg.inv(X.T @ np.linalg.solve(K, X))
        np.testing.assert_allclose([pred.sd[k] for k in free], np.sqrt(np.diag(cov)), rtol=1e-6)
        white = predict(c, Draws(draws.params, [NoiseDraw(0.3)]), free, 50, 6.0)
        assert pred.sd["E"] > 1.5 * white.sd["E"]          # model error: less information


def test_posterior_average_over_draws():
    """With several draws: predicted variances and relative variances are means over the draws,
    D is the mean log det (Bayesian design)."""
    cfg = parse_design(design(strain_rate=5e-3, strain_max=1.0, sample_rate=None, n_points=500))
    c = expand(cfg)[0]
    sets = [dict(GUESS, E=e, tau_max=t) for e, t in ((2700.0, 6.2), (2854.0, 5.79), (3000.0, 5.4))]
    noise = [NoiseDraw(0.3), NoiseDraw(0.25), NoiseDraw(0.4)]
    both = predict(c, Draws(sets, noise), ["E", "G", "tau_max"], 50, 6.0)
    each = [predict(c, Draws([p], [n]), ["E", "G", "tau_max"], 50, 6.0) for p, n in zip(sets, noise,
                                                                                         strict=True)]
    assert both.sd["E"] == pytest.approx(math.sqrt(np.mean([e.sd["E"] ** 2 for e in each])), rel=1e-10)
    assert both.err["G"] == pytest.approx(math.sqrt(np.mean([e.err["G"] ** 2 for e in each])), rel=1e-10)
    assert both.D == pytest.approx(np.mean([e.D for e in each]), rel=1e-10)


def test_discrepancy_draws_have_the_kernels_covariance():
    x = np.array([0.0, 0.3, 1.0, 2.5, 2.6])
    rng = np.random.default_rng(1)
    for kind, start in (("exp", None), ("matern32", None), ("matern32", -0.2)):
        d = discrepancy_draws(x[::-1].copy(), 1.5, 1.0, kind, 40000, rng, start)[:, ::-1]
        np.testing.assert_allclose(np.cov(d, rowvar=False), gp.covariance(x, 1.5, 1.0, kind, start=start),
                                   atol=0.06)


# ------------------------------------------------------------------ the command

def test_design_command_outputs_and_recommendation(tmp_path, capsys):
    path = tmp_path / "design.yaml"
    path.write_text(yaml.safe_dump(design(constraints={"max_duration": 300})))
    assert main(["design", str(path)]) == 0
    out = capsys.readouterr().out
    assert "recommended:" in out and "Err(E)" in out
    res_dir = tmp_path / "d"
    result = json.loads((res_dir / "design.json").read_text())
    cands = result["candidates"]
    assert len(cands) == 12 and len((res_dir / "design.csv").read_text().splitlines()) == 13
    ok = [c for c in cands if c["feasible"] and c["criterion"] is not None]
    assert all(c["duration_s"] <= 300 for c in ok)
    assert {c["feasible"] for c in cands} == {True, False}            # 2.5e-3 1/s to 1.9 lasts 760 s
    best = min(ok, key=lambda c: c["criterion"])
    assert result["recommended"]["candidate"] == best["candidate"]
    assert best["criterion"] == pytest.approx(best["sd"]["E"])
    assert "**Recommended:**" in (res_dir / "design.md").read_text()
    assert (res_dir / "err_E.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # same design: rewritten; another design: refused without --force, nothing changed
    assert main(["design", str(path)]) == 0
    before = (res_dir / "design.json").read_text()
    path.write_text(yaml.safe_dump(design(constraints={"max_duration": 100})))
    assert main(["design", str(path)]) == 2
    assert "--force" in capsys.readouterr().err
    assert (res_dir / "design.json").read_text() == before
    assert main(["design", str(path), "--force"]) == 0


@pytest.mark.parametrize("over, key", [
    ({"strain_rate": {"low": 1e-2, "high": 1e-3, "n": 3}}, "conditions.strain_rate: low (0.01) must be "
                                                           "smaller than high (0.001)"),
    ({"strain_max": {"low": 0.5, "high": 0.5, "n": 3}}, "conditions.strain_max: low (0.5) must be smaller"),
    ({"constraints": {"max_duration": 1.0}}, "constraints.max_duration: no candidate meets it: the "
                                             "shortest planned test lasts 6.5 s > 1 s"),
    ({"constraints": {"max_points": 10}}, "constraints.max_points: no candidate meets it"),
    ({"criterion": "sd_sigma_inf"}, "criterion: sd_sigma_inf asks about sigma_inf, which is not free"),
    ({"criterion": "best"}, "criterion: unknown criterion 'best'"),
    ({"hold": 60}, "conditions.hold: a hold > 0 needs the guess of ['sigma_inf', 'tau_max_R']"),
    ({"from_run": "nowhere"}, "parameters: give either parameters"),
    ({"frees": ["E"]}, "frees: unknown key"),
])
def test_bad_designs_name_the_key(tmp_path, over, key):
    path = tmp_path / "design.yaml"
    path.write_text(yaml.safe_dump(design(**over)))
    with pytest.raises(ConfigError) as err:
        run_design(load_design(path), write=False)
    assert key in str(err.value) and str(path) in str(err.value)


@pytest.mark.parametrize("key", ["data", "tests"])
def test_a_run_config_given_to_design_is_named_as_one(tmp_path, capsys, key):
    """The first error pydantic finds in a run's config (its noise.sigma0) would not say that the
    file is of the other kind."""
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump({"name": "run", key: {"file": "test.csv"},
                                    "noise": {"sigma0": "residuals"}}))
    assert main(["design", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}: a run config (it has {key}:), not a design file")
    assert "from_run" in err and "docs/design.md" in err and "sigma0" not in err


def test_missing_run_is_named(tmp_path):
    raw = design(from_run="no-such-run")
    raw.pop("parameters")
    with pytest.raises(RunError, match="from_run: .*no-such-run is not a directory"):
        run_design(parse_design(raw, source=tmp_path / "design.yaml"), write=False)


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    return make_finished_run(tmp_path_factory.mktemp("runs"))


def test_from_run_averages_over_the_posterior(finished_run, tmp_path):
    """from_run: draws of the run's posterior and its noise; at the run's own test the predicted sd
    of E is the posterior's, within the sampling error of a short chain."""
    raw = {"name": "b", "from_run": str(finished_run), "draws": 40,
           "conditions": {"strain_rate": 1e-2, "strain_max": 1.0, "n_points": 300}}
    res = run_design(parse_design(raw, source=tmp_path / "design.yaml"))
    assert res.draws.n == 40 and "posterior draws" in res.draws.source and res.draws.white
    post = json.loads((finished_run / "summary.json").read_text())["posterior"]
    assert res.recommended.sd["E"] == pytest.approx(post["E"]["sd"], rel=0.3)
    assert res.recommended.sd["tau_max"] == pytest.approx(post["tau_max"]["sd"], rel=0.3)
    assert json.loads((tmp_path / "b" / "design.json").read_text())["source"]["draws"] == 40


# ------------------------------------------------------------------ does the prediction come true?

@pytest.mark.slow
@pytest.mark.parametrize("noise", [
    {"sigma0": 0.3},
    {"sigma0": 0.3,
     "discrepancy": {"kernel": "matern32", "axis": "strain", "amplitude": 1.0, "length": 0.05}},
])
def test_prediction_comes_true(noise):
    """60 simulated tests of one planned test, fitted: the spread of E, G, tau_max is the predicted
    sd, within the 99.9 % band of a correct prediction (χ² with 59 dof, about ±25 %)."""
    raw = {"name": "v", "parameters": GUESS, "noise": noise,
           "conditions": {"strain_rate": 1e-2, "strain_max": 1.9, "n_points": 1500}}
    rep = validate_design(raw, 60, seed=7, jobs=2)
    assert rep.failed == 0 and rep.estimates.shape == (60, 3)
    lo, hi = rep.ratio_interval(0.999)
    for k, r in rep.ratio().items():
        assert lo <= r <= hi, f"{k}: observed/predicted sd {r:.3f} outside [{lo:.2f}, {hi:.2f}]"


def test_the_sandwich_of_a_run_s_kernels_against_dense_matrices():
    """A run sampled under the exp kernel whose error model weighs matern32: the predicted covariance
    is Σ_k w_k Δ Xᵀ C⁻¹ C_k C⁻¹ X Δ with Δ = (Xᵀ C⁻¹ X)⁻¹, formed densely here; with the sampled
    kernel itself as the only error model it is Δ."""
    from dataclasses import replace

    from bayes_dnlr.workflows.design.fisher import ErrorModel

    cfg = parse_design(design(strain_rate=1e-2, strain_max=1.0, sample_rate=None, n_points=300,
                              noise={"sigma0": 0.3, "discrepancy": {"kernel": "exp", "axis": "time",
                                                                   "amplitude": 0.7, "length": 8.0}}))
    draws, free = _draws(cfg)
    c = expand(cfg)[0]
    plain = predict(c, draws, free, 50, 6.0)
    itself = predict(c, replace(draws, widen=[ErrorModel(1.0, "exp", draws.noise[0])]), free, 50, 6.0)
    for k in free:
        assert itself.sd[k] == pytest.approx(plain.sd[k], rel=1e-6)
    m32 = NoiseDraw(0.3, 2.5, 20.0)
    widen = [ErrorModel(0.25, "exp", draws.noise[0]), ErrorModel(0.75, "matern32", m32)]
    pred = predict(c, replace(draws, widen=widen), free, 50, 6.0)
    prot = planned_protocol(c, GUESS)
    X = sensitivity_matrix(DNLR(prot.time, prot.strain).basis(GUESS["tau_max"], grad=True), GUESS, free)
    C = gp.covariance(prot.time, 0.7, 8.0, "exp", 0.3)
    Cm = gp.covariance(prot.time, 2.5, 20.0, "matern32", 0.3)
    Z = np.linalg.solve(C, X)
    delta = np.linalg.inv(X.T @ Z)
    cov = sum(w * delta @ (Z.T @ K @ Z) @ delta for w, K in ((0.25, C), (0.75, Cm)))
    np.testing.assert_allclose([pred.sd[k] for k in free], np.sqrt(np.diag(cov)), rtol=1e-6)
    assert pred.sd["E"] > 1.5 * plain.sd["E"]


def test_a_run_s_kernels_are_carried_only_when_they_weigh_another_kernel():
    from bayes_dnlr.workflows.design.run import error_model_note, run_error_models

    def fit(weights):
        return {"discrepancy": {"projection": {"kernels": {
            k: {"weight": w, "hyperparameters": {"sigma0": 0.004, "amplitude": a, "length": ell}}
            for (k, w), (a, ell) in zip(weights.items(), ((0.98, 600.0), (5.12, 99.2)), strict=True)}}}}

    models = run_error_models(fit({"exp": 0.0, "matern32": 1.0}), "exp")
    assert [(m.kernel, m.weight, m.noise.amplitude) for m in models] == [("matern32", 1.0, 5.12)]
    summary = {"noise": {"projection": {"sd_factor": {"E": 5.0137, "G": 6.2383}}}}
    note = error_model_note(models, summary)
    assert "(matern32 100 %, their maximum-likelihood hyperparameters)" in note
    assert "(there: sd E 5.01x, G 6.24x the sampled kernel's alone)" in note
    assert run_error_models(fit({"exp": 1.0, "matern32": 0.0}), "exp") == []      # the sampled kernel
    assert run_error_models({}, "exp") == [] and error_model_note([], summary) == ""

