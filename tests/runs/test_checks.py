"""The checks of a sampled run and the verdict they decide (runs/checks.py, inference/checks/)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bayes_dnlr.inference.checks import bounds, physical, power_scaling, predictive
from bayes_dnlr.inference.layout import Layout
from bayes_dnlr.runs.checks import model_form_check, stress_shift_check
from bayes_dnlr.runs.checks import verdict as verdict_parts
from bayes_dnlr.runs.verdict import (
    COVERAGE_HIGH,
    COVERAGE_LOW,
    E_WEIGHTED_LOW,
    SEGMENT_LOW,
    SEGMENT_MIN_POINTS,
    SHIFT_SD,
)


def verdict(checks, converged, several):
    """(adequate, trust_interval, the words summary.json keeps: the sentences joined)."""
    adequate, trust, head, points = verdict_parts(checks, converged, several)
    return adequate, trust, " ".join([head, *points])


def test_power_scaling_equals_arviz_stats_psense() -> None:
    ab = pytest.importorskip("arviz_base")
    psense = pytest.importorskip("arviz_stats").psense
    rng = np.random.default_rng(1)
    for case in range(3):
        x = rng.normal(size=(8, 400))
        y = rng.gamma(2.0, 1.0, size=(8, 400))
        log_prior = -0.5 * (x / (0.5 + case)) ** 2 - 0.3 * case * y
        log_lik = -5.0 * (x - 0.3) ** 2
        dt = ab.from_dict({"posterior": {"x": x, "y": y}, "log_prior": {"lp": log_prior},
                           "log_likelihood": {"obs": log_lik}})
        for group, comp in (("prior", log_prior), ("likelihood", log_lik)):
            ref = psense(dt, group=group)
            mine = power_scaling.sensitivity({"x": x, "y": y}, comp)
            for k in ("x", "y"):
                assert mine[k] == pytest.approx(float(ref[k]), rel=1e-9, abs=1e-12)


def test_a_flat_prior_is_not_informative_and_a_tight_one_is() -> None:
    rng = np.random.default_rng(2)
    x = rng.normal(1.0, 0.1, size=(4, 1000))
    tight = -0.5 * ((x - 0.9) / 0.1) ** 2         # a prior as narrow as the posterior
    wide = -0.5 * ((x - 0.9) / 100.0) ** 2
    assert power_scaling.sensitivity({"x": x}, tight)["x"] > power_scaling.SENSITIVE
    assert power_scaling.sensitivity({"x": x}, wide)["x"] < power_scaling.SENSITIVE


def test_predictive_coverage_is_ninety_percent_for_the_right_noise_and_low_where_the_model_fails():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 100.0, 2000)
    curves = np.sin(t / 10.0)[None, :] + rng.normal(0, 0.01, size=(200, 1))
    y = np.sin(t / 10.0) + rng.normal(0, 0.3, t.size)
    masks = predictive.segments(t, None)
    ok = predictive.coverage(predictive.inside_band(y, curves, 0.09), masks)
    assert 0.87 < ok["overall"] < 0.93
    assert all(0.8 < s["share"] < 1.0 for s in ok["segments"].values())
    y_bad = y + np.where(t < 20.0, 1.0, 0.0)       # a misfit the noise does not describe, early on
    bad = predictive.coverage(predictive.inside_band(y_bad, curves, 0.09), masks)
    assert bad["segments"]["time block 1"]["share"] < 0.3
    assert bad["segments"]["time block 3"]["share"] > 0.8
    hold = predictive.segments(t, 60.0)
    assert hold["loading"].sum() + hold["hold"].sum() == t.size and hold["hold"][-1]


@pytest.mark.parametrize(("draws", "low", "high", "log", "side"), [
    (np.linspace(40.0, 50.0, 1001), 0.0, 50.0, False, "high"),
    (np.linspace(0.0, 10.0, 1001), 0.0, 50.0, False, "low"),
    (np.linspace(20.0, 30.0, 1001), 0.0, 50.0, False, None),
    (np.geomspace(1e3, 1e4, 1001), 0.01, 1e4, True, "high"),
    (np.geomspace(1.0, 10.0, 1001), 0.01, 1e4, True, None),
])
def test_posterior_piled_against_a_bound(draws, low, high, log, side) -> None:
    assert bounds.piled_side(draws, low, high, log) == side


def test_a_bound_widened_ten_times() -> None:
    assert bounds.widened(0.0, 50.0, "high", False) == (0.0, 500.0)
    assert bounds.widened(0.01, 1e4, "high", True) == (0.01, 1e5)
    assert bounds.widened(100.0, 200.0, "low", False) == (-800.0, 200.0)
    assert bounds.physical_limit("low", 0.0) and not bounds.physical_limit("high", 50.0)


def test_sigma_inf_above_the_last_stress_of_a_falling_hold_is_implausible() -> None:
    t = np.linspace(0.0, 1000.0, 501)
    falling = 10.0 + 5.0 * np.exp(-t / 2000.0)        # still relaxing at the end
    still, last = physical.hold_still_falling(t, falling, 0.0)
    assert still and last == pytest.approx(np.median(falling[-5:]), rel=1e-12)
    assert not physical.sigma_inf_check(np.full(100, last + 0.5), last, still)["ok"]
    assert physical.sigma_inf_check(np.full(100, last - 0.5), last, still)["ok"]
    flat, _ = physical.hold_still_falling(t, np.full(t.size, 10.0) + 1e-3 * np.sin(t), 0.0)
    assert not flat
    assert not physical.chord_check(np.full(100, 900.0), 1000.0)["ok"]
    assert not physical.time_constant_check(np.full(10, 2e4), 1000.0)["ok"]


def _checks(coverage=0.9, block=0.9, shift=None, sens=0.0, sigma_inf_ok=True) -> dict:
    segs = {f"time block {b}": {"share": block if b == 1 else 0.9, "points": 200} for b in range(1, 6)}
    bound = ([] if shift is None else
             [{"parameter": "G", "side": "high", "bound": 50.0, "widened": [0.0, 500.0],
               "E_shift_sd": {"E": shift}}])
    plaus = {"t": {"sigma_inf": {"ok": sigma_inf_ok, "sigma_inf_median": 8.3, "last_stress": 7.7,
                                 "hold_falling": True}}}
    return {"predictive_coverage": {"t": {"overall": coverage, "points": 1000, "segments": segs}},
            "bound_limited": bound, "prior_sensitivity": {"E": sens}, "plausibility": plaus}


def test_the_verdict_follows_from_the_checks() -> None:
    adequate, trust, words = verdict(_checks(), True, False)
    assert adequate and trust and words.startswith("Use E's interval as it is.")
    adequate, trust, words = verdict(_checks(block=0.3), True, False)
    assert not adequate and not trust and "30 % in the time block 1" in words
    adequate, trust, words = verdict(_checks(shift=30.0), True, False)
    assert adequate and not trust and "prior box decides E" in words and "+30.0 posterior sd" in words
    adequate, trust, _ = verdict(_checks(shift=0.4), True, False)
    assert trust
    _, trust, words = verdict(_checks(sens=0.2), True, False)
    assert not trust and "power-scaling sensitivity E 0.20" in words
    adequate, _, words = verdict(_checks(sigma_inf_ok=False), True, False)
    assert not adequate and ("σ∞ = 8.300 MPa (posterior median) lies above the last stress of the hold "
                             "(7.700 MPa)") in words
    _, trust, words = verdict(_checks(), False, False)
    assert not trust and "not converged" in words


def _fit_with_score(z: float, step: float, slope: float = -3300.0) -> dict:
    return {"spectrum_exponent": {"derivative": {"E": slope}, "relative_per_tenth": {"E": -0.1},
                                  "score": {"z": 99.0, "step": 1.0, "sd": 0.01}},
            "discrepancy": {"alpha_score": {"z": z, "step": step, "sd": step / z if z else 1.0}}}


def test_the_model_form_check_reads_the_score_under_the_discrepancy_and_weighs_the_move_of_e() -> None:
    layout = Layout.build({"t": ["E", "G", "tau_max"]}, (), plain=True)
    c = model_form_check(_fit_with_score(1.0, 0.01), layout, {"E": 30.0})["t"]
    assert c["likelihood"] == "under the discrepancy" and c["z"] == 1.0 and c["ok"]
    c = model_form_check(_fit_with_score(6.0, 0.1), layout, {"E": 30.0})["t"]
    assert c["E_shift_sd"] == pytest.approx(-11.0) and not c["ok"]
    # a pull the data are sure of that hardly moves E: E's interval stands
    c = model_form_check(_fit_with_score(6.0, 0.001), layout, {"E": 30.0})["t"]
    assert abs(c["E_shift_sd"]) < 1.0 and c["ok"]
    # the white score when there is no discrepancy block; none when alpha is sampled
    white = _fit_with_score(1.0, 0.01)
    del white["discrepancy"]
    assert model_form_check(white, layout, {"E": 30.0})["t"]["likelihood"] == "white"
    assert model_form_check({"spectrum_exponent": None}, layout, {"E": 30.0}) == {}


def test_a_model_form_error_withdraws_trust_and_says_what_to_do() -> None:
    checks = _checks()
    checks["model_form"] = {"t": {"z": 6.0, "step": 0.1, "likelihood": "under the discrepancy",
                                  "E_relative_per_tenth": -0.1, "E_shift_sd": -11.0, "ok": False}}
    adequate, trust, words = verdict(checks, True, False)
    assert adequate and not trust
    assert "by +6.0 sd" in words and "-10 % per +0.1" in words and "parameters.alpha" in words


def test_the_stress_shift_check_weighs_e_of_the_fit_that_admits_it() -> None:
    layout = Layout.build({"t": ["E", "G", "tau_max"]}, (), plain=True)
    posterior = {"E": {"mean": 1600.0, "sd": 100.0}}
    asked = {"stress_score": {"z": 5.0}, "stress_refit": {"estimate": {"E": 1050.0, "sigma_s": 2.4}}}
    c = stress_shift_check(asked, layout, posterior)["t"]
    assert c["E_shift_sd"] == pytest.approx(-5.5) and c["sigma_s"] == 2.4 and not c["ok"]
    # under the discrepancy, its score decides; one that does not ask leaves E's interval alone
    quiet = {**asked, "discrepancy": {"stress_score": {"z": 1.0}}}
    assert stress_shift_check(quiet, layout, posterior)["t"]["ok"]
    # a refit that hardly moves E, or no refit (it failed), leaves it too
    near = {**asked, "stress_refit": {"estimate": {"E": 1650.0, "sigma_s": 9.0}}}
    assert stress_shift_check(near, layout, posterior)["t"]["ok"]
    assert stress_shift_check({"stress_score": {"z": 5.0}}, layout, posterior)["t"]["ok"]
    assert stress_shift_check({}, layout, posterior) == {}
    checks = _checks()
    checks["stress_shift"] = {"t": stress_shift_check(asked, layout, posterior)["t"]}
    adequate, trust, words = verdict(checks, True, False)
    assert adequate and not trust
    assert ("The data ask for a stress shift (its score test, z = 5.0; sigma_s about 2.40 MPa), and "
            "admitting it moves E to 1050 MPa, -5.5 posterior sd") in words
    assert "model.shift.stress: eyring" in words


def test_a_sampled_run_records_its_checks(tmp_path) -> None:
    """summary.json's checks block: a clean synthetic test is trusted; its coverage is about 90 %."""
    from support.finished_run import make_finished_run

    run = make_finished_run(tmp_path)
    checks = json.loads((run / "summary.json").read_text())["checks"]
    assert set(checks) >= {"predictive_coverage", "bound_limited", "prior_sensitivity", "plausibility",
                           "adequate", "trust_interval", "verdict"}
    assert 0.8 <= checks["predictive_coverage"]["overall"] <= 0.97
    summary = json.loads((run / "summary.json").read_text())
    assert checks["adequate"], checks["verdict"]
    # the tiny chain stops at max_steps: not converged is the one reason not to trust it
    assert checks["trust_interval"] == summary["converged"], checks["verdict"]
    assert checks["bound_limited"] == []


def test_a_prior_bound_that_decides_e_is_named_with_the_move_of_e(tmp_path) -> None:
    """G bounded below its true value: G piles against the bound, and widening it moves E."""
    import yaml
    from support.finished_run import make_finished_run

    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    run = make_finished_run(tmp_path)
    cfg_path = run / "config.yaml"
    raw = yaml.safe_load(cfg_path.read_text())
    raw["parameters"] = {"G": {"prior": "uniform", "low": 0.0, "high": 1.0}}
    cfg_path.write_text(yaml.safe_dump(raw))
    post = sample(load_config(cfg_path), restart=True, progress=False)
    checks = post.summary["checks"]
    entry = next(b for b in checks["bound_limited"] if b["parameter"] == "G")
    assert entry["side"] == "high" and entry["widened"] == [0.0, 10.0]
    assert abs(entry["E_shift_sd"]["E"]) > 1.0
    assert not checks["trust_interval"] and "prior box decides E" in checks["verdict"]


def test_a_misfit_where_e_has_no_weight_leaves_e_trusted() -> None:
    """Weights from a Jacobian: a sample's share of E's variance; the verdict reads the weighted
    coverage: a misfit at the end of a ramp (where E has little weight) keeps E's interval."""
    x = np.linspace(0.0, 1.0, 200)
    X = np.column_stack([1.0 - np.exp(-x / 0.02), x])       # E acts early, a hardening term late
    w = predictive.weights(X, 0)
    assert w.sum() == pytest.approx(1.0) and w[:40].sum() > w[-40:].sum()
    inside = np.ones(200, dtype=bool)
    inside[-60:] = False                                    # the misfit: the last 30 %
    assert predictive.weighted_share(inside, w) > predictive.weighted_share(~inside, w)
    checks = _checks(block=0.3)
    checks["predictive_coverage"]["t"]["E_weighted"] = 0.997
    adequate, trust, words = verdict(checks, True, False)
    assert not adequate and trust and "E's interval stands" in words
    checks["predictive_coverage"]["t"]["E_weighted"] = 0.97
    adequate, trust, words = verdict(checks, True, False)
    assert not adequate and not trust and "E's interval rests on a misfit" in words


def test_the_white_likelihood_chosen_on_signed_residuals_withdraws_trust() -> None:
    from types import SimpleNamespace

    from bayes_dnlr.runs.checks import noise_model_check

    def config(has_discrepancy: bool):
        noise = SimpleNamespace(has_discrepancy=has_discrepancy)
        return SimpleNamespace(for_test=lambda t: SimpleNamespace(noise=noise))

    signed = {"t": {"model": "white", "fit_residuals_white": False}}
    assert not noise_model_check(config(False), signed)["t"]["ok"]
    # the discrepancy analysis found no evidence of model error and fell back to white: its test decided
    assert noise_model_check(config(True), signed)["t"]["ok"]
    assert noise_model_check(config(False), {"t": {"model": "white", "fit_residuals_white": True}})["t"]["ok"]
    checks = _checks()
    checks["noise_model"] = noise_model_check(config(False), signed)
    adequate, trust, words = verdict(checks, True, False)
    assert adequate and not trust and "noise.discrepancy: none" in words and "too narrow" in words


def test_the_model_form_check_of_a_joint_run_reads_each_tests_own_fit() -> None:
    layout = Layout.build({"a": ["E", "tau_max"], "b": ["E", "tau_max"]}, ("tau_max",))
    fit = {"single_fits": {"a": _fit_with_score(6.0, 0.1), "b": _fit_with_score(1.0, 0.01)}}
    c = model_form_check(fit, layout, {"E": 30.0})
    assert not c["a"]["ok"] and c["a"]["E_shift_sd"] == pytest.approx(-11.0)
    assert c["b"]["ok"] and c["b"]["E_relative_per_tenth"] == -0.1


def _priors_and_draws(e_prior: dict, alpha_prior: dict):
    """Draws of (E, alpha) with E tied to alpha (ρ ≈ -0.9), under the given priors."""
    from bayes_dnlr.config import ParameterSpec
    from bayes_dnlr.inference.posterior.priors import Prior, PriorSet

    rng = np.random.default_rng(5)
    alpha = rng.normal(0.55, 0.04, size=(4000, 8))
    e = 2000.0 - 3000.0 * (alpha - 0.55) + rng.normal(0.0, 50.0, size=alpha.shape)
    priors = PriorSet((Prior.from_spec("E", ParameterSpec(**e_prior)),
                       Prior.from_spec("alpha", ParameterSpec(**alpha_prior))))
    return np.stack([e, alpha], axis=-1), ["E", "alpha"], priors


def test_the_verdict_names_the_prior_that_shapes_e() -> None:
    """With E's own prior flat and alpha's tight, E's sensitivity comes through alpha's prior: the
    verdict says so instead of asking for a wider prior on E."""
    from bayes_dnlr.runs.checks import prior_sensitivity_check, prior_sources

    tight = {"prior": "normal", "mean": 0.5, "sd": 0.03, "low": 0, "high": 1}
    draws, names, priors = _priors_and_draws({"prior": "uniform", "low": 100, "high": 20000}, tight)
    sens = prior_sensitivity_check(draws, names, priors)
    assert sens["E"] > power_scaling.SENSITIVE
    sources = prior_sources(draws, names, priors, ["E"])
    assert list(sources["E"]) == ["alpha"]                  # E's flat prior is not scaled at all
    assert sources["E"]["alpha"] == pytest.approx(sens["E"], rel=1e-9)   # the only non-flat prior
    checks = _checks(sens=sens["E"]) | {"prior_sources": sources}
    _, trust, words = verdict(checks, True, False)
    assert not trust and "through the prior of alpha" in words and "not E's own" in words
    assert "give E a wider prior" not in words


def test_e_shaped_by_its_own_prior_is_asked_for_a_wider_one() -> None:
    from bayes_dnlr.runs.checks import prior_sensitivity_check, prior_sources

    draws, names, priors = _priors_and_draws({"prior": "normal", "mean": 1950, "sd": 60},
                                             {"prior": "uniform", "low": 0, "high": 1})
    sens = prior_sensitivity_check(draws, names, priors)
    sources = prior_sources(draws, names, priors, ["E"])
    assert sens["E"] > power_scaling.SENSITIVE and list(sources["E"]) == ["E"]
    _, _, words = verdict(_checks(sens=sens["E"]) | {"prior_sources": sources}, True, False)
    assert "through the prior of E" in words and "give E a wider prior or more data" in words


def test_an_e_below_the_standards_chord_is_neither_adequate_nor_trusted() -> None:
    """E's 95 % quantile below the standards' chord, a lower bound of the instantaneous modulus:
    the model does not describe the start of the curve, and E's interval is not to be used."""
    checks = _checks()
    checks["plausibility"]["t"]["E_chord"] = physical.chord_check(np.full(100, 900.0), 1000.0)
    adequate, trust, words = verdict(checks, True, False)
    assert not adequate and not trust
    assert words.startswith("The model does not describe this test: E's interval is not reliable.")
    assert "E's 95 % quantile (900.0 MPa) lies below the standards' chord (1000 MPa)" in words
    # the same E above the chord changes nothing
    checks["plausibility"]["t"]["E_chord"] = physical.chord_check(np.full(100, 1100.0), 1000.0)
    assert verdict(checks, True, False)[:2] == (True, True)
    # with a failing coverage where E draws no information, the chord still withdraws trust
    checks = _checks(block=0.3)
    checks["predictive_coverage"]["t"]["E_weighted"] = 0.999
    checks["plausibility"]["t"]["E_chord"] = physical.chord_check(np.full(100, 900.0), 1000.0)
    adequate, trust, words = verdict(checks, True, False)
    assert not adequate and not trust and "Use E's interval" not in words


@pytest.mark.parametrize("sampled", [False, True])
def test_the_predictive_band_under_the_discrepancy_equals_a_dense_computation(tmp_path, sampled) -> None:
    """The band of the coverage check under the model discrepancy: at each sample the spread of the
    model curves over the draws plus what the likelihood puts around them, σ0² + the discrepancy's
    variance (the diagonal of its dense covariance, averaged over the draws' amplitudes). On data
    with that error the band holds about 90 % of the points; without the discrepancy's part, far
    fewer."""
    from bayes_dnlr.config import parse_config
    from bayes_dnlr.inference.discrepancy import gp
    from bayes_dnlr.model import simulate
    from bayes_dnlr.runs.checks import coverage_check
    from bayes_dnlr.runs.testset import load_tests
    from bayes_dnlr.vocabulary import Z90

    truth, n, rate = {"E": 2854.0, "G": 2.32, "tau_max": 3.15}, 200, 1e-2
    t = np.linspace(0.0, 1.0 / rate, n)
    rng = np.random.default_rng(11)
    # data with the error the likelihood describes: a discrepancy of amplitude 0.5 MPa and white noise
    delta = np.linalg.cholesky(gp.covariance(t, 0.5, 5.0, kind="exp", sigma0=1e-6)) @ rng.normal(size=n)
    stress = simulate(t, rate * t, truth) + delta + rng.normal(0.0, 0.3, n)
    np.savetxt(tmp_path / "d.csv", np.column_stack([t, rate * t, stress]), delimiter=",",
               header="t,e,s", comments="")
    amplitude = {"prior": "half-normal", "scale": 1.0} if sampled else {"value": 0.5}
    raw = {"name": "band", "data": {"file": "d.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                                    "observable": "stress"},
           "noise": {"sigma0": 0.3, "discrepancy": {"kernel": "exp", "amplitude": amplitude,
                                                    "length": {"value": 5.0}}}}
    cfg = parse_config(raw, source=tmp_path / "config.yaml")
    tests = load_tests(cfg)
    name = cfg.test_names[0]
    data = tests.tests[name]
    names = ["E", "G", "tau_max"] + (["disc_amplitude"] if sampled else [])
    layout = Layout.build({name: names}, (), plain=True)
    k = 160                                    # fewer than the check's 200 curves: it uses every draw
    draws = np.column_stack([rng.normal(truth["E"], 2.0, k), rng.normal(truth["G"], 0.001, k),
                             rng.normal(truth["tau_max"], 0.003, k)]
                            + ([rng.uniform(0.05, 0.95, k)] if sampled else []))
    noise = {name: {"model": "discrepancy", "kernel": "exp", "amplitude":
                    {"sampled": True} if sampled else {"sampled": False, "value": 0.5}}}
    got = coverage_check(cfg, tests, layout, draws.reshape(20, 8, -1), names, noise, {name: 0.3})[name]

    # the dense computation: each draw's model curve and the diagonal of its dense covariance
    assert data.model_end == n and data.window.all()
    curves = np.array([simulate(t, rate * t, dict(zip(["E", "G", "tau_max"], d[:3], strict=True)))
                       for d in draws])
    amplitudes = draws[:, 3] if sampled else np.full(k, 0.5)
    around = np.mean([np.diag(gp.covariance(t, a, 5.0, kind="exp", sigma0=0.3)) for a in amplitudes],
                     axis=0)
    inside = np.abs(stress - curves.mean(axis=0)) <= Z90 * np.sqrt(curves.var(axis=0) + around)
    assert got["overall"] == pytest.approx(inside.mean(), abs=1.5 / n)
    blocks = predictive.segments(t, None)
    for seg, mask in blocks.items():
        assert got["segments"][seg]["share"] == pytest.approx(inside[mask].mean(), abs=1.5 / mask.sum())
    white_only = np.abs(stress - curves.mean(axis=0)) <= Z90 * np.sqrt(curves.var(axis=0) + 0.09)
    assert 0.8 < inside.mean() < 0.97 and white_only.mean() < 0.7


# ---------------------------------------------------------------- the verdict at its thresholds

def _at_thresholds(overall: float = 0.9, share: float = 0.9, points: int = 200,
                   e_weighted: float | None = None, **more) -> dict:
    segs = {"time block 1": {"share": share, "points": points},
            "time block 2": {"share": 0.9, "points": 200}}
    cov = {"overall": overall, "points": 1000, "segments": segs}
    if e_weighted is not None:
        cov["E_weighted"] = e_weighted
    return {"predictive_coverage": {"t": cov}, "bound_limited": [], "prior_sensitivity": {"E": 0.0},
            "plausibility": {"t": {}}} | more


def _decided(checks: dict) -> tuple[bool, bool]:
    adequate, trust, _, _ = verdict_parts(checks, True, False)
    return adequate, trust


def test_the_coverage_at_its_thresholds() -> None:
    assert _decided(_at_thresholds(overall=COVERAGE_LOW)) == (True, True)
    assert _decided(_at_thresholds(overall=COVERAGE_LOW - 0.001)) == (False, False)
    assert _decided(_at_thresholds(share=SEGMENT_LOW)) == (True, True)
    assert _decided(_at_thresholds(share=SEGMENT_LOW - 0.01)) == (False, False)
    # a segment too small to judge is not judged
    assert _decided(_at_thresholds(share=0.1, points=SEGMENT_MIN_POINTS - 1)) == (True, True)
    assert _decided(_at_thresholds(share=0.1, points=SEGMENT_MIN_POINTS)) == (False, False)


def test_a_band_wider_than_the_scatter_is_said_and_a_failing_segment_still_fails() -> None:
    _, _, _, words = verdict_parts(_at_thresholds(overall=COVERAGE_HIGH), True, False)
    assert words[0] == "The 90 % predictive band holds 97 % of the points (80-97 % expected)."
    _, _, _, words = verdict_parts(_at_thresholds(overall=0.99), True, False)
    assert words[0].endswith("(80-97 % expected): the band is wider than the data's scatter, so the "
                             "intervals lean to the safe side.")
    # nearly every point inside, but one segment of 20 holds fewer than half: not adequate
    checks = _at_thresholds(overall=0.99, share=0.45, points=20)
    adequate, trust, _, words = verdict_parts(checks, True, False)
    assert not adequate and not trust and "45 % in the time block 1" in words[0]


def test_the_e_weighted_coverage_at_its_threshold() -> None:
    assert _decided(_at_thresholds(overall=0.5, e_weighted=E_WEIGHTED_LOW)) == (False, True)
    assert _decided(_at_thresholds(overall=0.5, e_weighted=E_WEIGHTED_LOW - 0.001)) == (False, False)


@pytest.mark.parametrize(("shift", "trusted"), [(SHIFT_SD, True), (-SHIFT_SD, True),
                                                (SHIFT_SD + 0.01, False), (-SHIFT_SD - 0.01, False)])
def test_a_bound_moves_e_by_at_most_shift_sd(shift: float, trusted: bool) -> None:
    bound = [{"parameter": "G", "side": "high", "bound": 5.0, "widened": [0.0, 50.0],
              "E_shift_sd": {"E": shift}}]
    assert _decided(_at_thresholds(bound_limited=bound)) == (True, trusted)


def test_checks_that_pass_leave_the_verdict_as_it_is() -> None:
    passing = _at_thresholds(model_form={"t": {"ok": True, "z": 0.3}},
                      noise_model={"t": {"ok": True, "likelihood": "white", "residuals_white": True}})
    adequate, trust, head, words = verdict_parts(passing, True, False)
    assert adequate and trust and head == "Use E's interval as it is." and len(words) == 1


def test_a_verdict_that_does_not_trust_e_says_so_first_and_then_why() -> None:
    """Its first sentence is the decision and does not contradict the points (it used to open "The
    model describes this test, but ..." above a point that says the model's form does not fit); the
    failed checks come before the passing ones (a failed verdict opened with the good news of the
    predictive band)."""
    form = {"t": {"ok": False, "z": 5.8, "likelihood": "under the discrepancy",
                  "E_relative_per_tenth": -0.09}}
    bound = [{"parameter": "disc_length", "side": "high", "bound": 100.0, "note": "a noise hyperparameter"}]
    adequate, trust, head, words = verdict_parts(_at_thresholds(model_form=form, bound_limited=bound),
                                                 True, False)
    assert adequate and not trust
    assert head.startswith("Do not use E's interval as it is: ") and "describes" not in head
    assert words[0].startswith("The data pull the spectrum's exponent away from Cunat's ½ by +5.8 sd")
    assert words[1].startswith("The 90 % predictive band holds") and words[2].startswith("The posterior of")
    _, _, _, unconverged = verdict_parts(_at_thresholds(), False, False)
    assert unconverged[0].startswith("The chain has not converged")


def test_a_time_constant_beyond_the_test_withdraws_trust_in_words() -> None:
    for k in ("tau_max", "tau_max_R"):
        failing = {"ok": False, "median": 2.0e4, "test_duration": 400.0}
        checks = _at_thresholds(plausibility={"t": {k: failing}})
        adequate, trust, head, words = verdict_parts(checks, True, False)
        assert adequate and not trust
        assert words[0] == (f"{k[0].upper() + k[1:]} = 20000 s (posterior median) is more than 10× the "
                            "test's duration (400 s): "
                            "the test does not measure it, and what trades off with it comes from the "
                            "prior box.")


def test_a_time_constant_is_judged_against_the_test_s_duration_in_reduced_time() -> None:
    t = np.linspace(0.0, 40.0, 401)
    assert physical.reduced_duration(t, np.full(t.size, np.log(0.01))) == pytest.approx(4000.0)
    assert physical.reduced_duration(t, np.zeros(t.size)) == pytest.approx(40.0)
    c = physical.time_constant_check(np.full(10, 1000.0), 40.0, 4000.0)
    assert c == {"ok": True, "median": 1000.0, "test_duration": 40.0, "reduced_duration": 4000.0}
    assert not physical.time_constant_check(np.full(10, 1000.0), 40.0)["ok"]
    failing = physical.time_constant_check(np.full(10, 1000.0), 40.0, 60.0)
    _, trust, _, words = verdict_parts(_at_thresholds(plausibility={"t": {"tau_max": failing}}),
                                       True, False)
    assert not trust and words[0] == (
        "Tau_max = 1000 s (posterior median) is more than 10× the test's duration in reduced time "
        "(60.0 s, its 40.0 s over the stress shift a_σ at the data's stress): the test "
        "does not measure it, and what trades off with it comes from the prior box.")


def test_a_stress_shifted_test_measures_a_time_constant_far_beyond_its_clock_duration(tmp_path) -> None:
    """An Eyring truth (sigma_s 2 MPa) on a slow spectrum (tau_max 1000 s), a 40 s ramp into its
    flow at 10-12 MPa: there the stress shortens the modes' times about 30-fold (sinh x / x), and
    the test lasts about 730 s in reduced time; the shifted model identifies tau_max (1153 ± 317 s
    on such a ramp), and at the truth the plausibility check keeps trust. The same draws in a
    stress-blind model fail it."""
    import yaml

    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.checks import plausibility_check
    from bayes_dnlr.runs.testset import load_tests
    from bayes_dnlr.workflows.simulate import simulate_test

    truth = {"E": 1000.0, "G": 5.0, "tau_max": 1000.0, "sigma_s": 2.0}
    raw = {"name": "t", "data": {"file": "t.csv", "columns": {"time": "t", "eps11": "e", "stress": "s"},
                                 "observable": "stress"},
           "model": {"shift": {"stress": "eyring"}},
           "truth": {"params": truth, "shift": {"stress": "eyring"}, "strain_rate": 1e-3,
                     "strain_max": 0.04, "n_points": 200, "noise": {"strain_sd": 0.0, "stress_sd": 0.3}}}
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(raw))
    cfg = load_config(tmp_path / "config.yaml")
    simulate_test(cfg)
    tests = load_tests(cfg)
    names = list(cfg.free_parameters)
    layout = Layout.build({"t": names}, [], plain=True)
    draws = np.array([truth[k] for k in names])[None, None, :] * np.ones((20, 4, 1))
    c = plausibility_check(cfg, tests, layout, draws, names, {})["t"]["tau_max"]
    assert c["ok"] and c["test_duration"] == pytest.approx(40.0)
    assert 15 * 40.0 < c["reduced_duration"] < 25 * 40.0
    blind = cfg.model_copy(update={"model": cfg.model.model_copy(update={"shift": type(cfg.model.shift)()})})
    assert not plausibility_check(blind, tests, layout, draws, names, {})["t"]["tau_max"]["ok"]


def test_e_below_a_noisy_chord_is_impossible_only_beyond_the_chord_s_noise() -> None:
    """A slow spectrum's chord lies within a few % of E, and noise moves the measured chord above
    E's 95 % quantile in about one test of ten: the check allows CHORD_Z of the chord's noise sd
    (73 MPa on a 40 s ramp to 4 % with 0.3 MPa of noise, E 1000 MPa)."""
    e = np.full(100, 1000.0)
    assert physical.chord_check(e, 1039.0, 73.0) == {"ok": True, "E_q95": 1000.0, "chord": 1039.0,
                                                      "chord_sd": 73.0}
    assert not physical.chord_check(e, 1039.0, 10.0)["ok"]
    assert not physical.chord_check(e, 1039.0)["ok"]                    # no noise known: as before
    failing = physical.chord_check(e, 1300.0, 73.0)
    adequate, _, _, words = verdict_parts(_at_thresholds(plausibility={"t": {"E_chord": failing}}),
                                          True, False)
    assert not adequate and words[0].startswith(
        "E's 95 % quantile (1000 MPa) lies below the standards' chord (1300 MPa, by more than 1.645 "
        "of its noise sd of 73.00 MPa), a lower bound")
