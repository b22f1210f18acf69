"""`fit` on awkward optima: a parameter on its lower bound gives results
with a warning naming it, a singular X names the parameters, the negligible-sensitivity warning
spares well-determined parameters, and a relaxed modulus above the instantaneous one is flagged."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from support.runs import WIDE_RELAXATION_PRIORS, make_run, small_ramp_relaxation_truth
from support.sampling import write_case

from bayes_dnlr.config import load_config
from bayes_dnlr.data import load_test
from bayes_dnlr.inference.lsq import identify as lsq
from bayes_dnlr.inference.lsq.plausibility import plausibility_warnings, singular_message
from bayes_dnlr.inference.lsq.sensitivity import analyse, analyse_holding, bound_side
from bayes_dnlr.runs.fit import fit

NO_HARDENING = {"E": 2854.0, "G": 0.0, "tau_max": 5.79}


@pytest.fixture(scope="module")
def g_on_bound(tmp_path_factory):
    """A 300-point ramp of a material without hardening (G = 0): with this noise the optimum puts
    G on its lower bound 0 (it raised 'the sensitivity matrix is singular' before)."""
    folder = tmp_path_factory.mktemp("bound")
    return write_case(folder, "g0", params=NO_HARDENING, n=300, seed=0,
                      sampler={"walkers": 12, "max_steps": 100, "target_ess": 50, "checkpoint_every": 50})


def test_a_parameter_on_its_lower_bound_gives_results_with_a_warning(g_on_bound):
    cfg = load_config(g_on_bound)
    result = fit(cfg).only
    assert result.estimate["G"] <= 1e-12
    [warning] = [w for w in result.warnings if w.startswith("G = ")]
    assert warning.startswith("G = 0 (its lower bound; prior [0, 50])")
    assert "parameters.G: {value: 0}" in warning
    # G keeps a linearized sd (its unconstrained curvature) and correlations; its Err is undefined
    assert 0 < result.sd["G"] < 0.01
    assert math.isnan(result.err["G"])
    assert np.all(np.isfinite(result.correlation))
    assert 0.002 < result.err["E"] < 0.05
    # nothing relative to G's value (zero) is reported as a problem
    assert not any("negligible" in w or "Err(G)" in w or "ill-conditioned" in w for w in result.warnings)
    saved = json.loads((cfg.run_dir / "fit.json").read_text())
    assert saved["err"]["G"] is None and saved["sd"]["G"] > 0


def test_sample_starts_and_the_report_builds_on_a_run_with_g_on_its_bound(g_on_bound):
    from bayes_dnlr.cli import main
    from bayes_dnlr.runs.sample import sample

    cfg = load_config(g_on_bound)
    post = sample(cfg, progress=False)
    g = post.summary["posterior"]["G"]
    assert g["hdi_90"][0] >= 0.0 and g["mean"] > 0.0
    assert main(["report", str(cfg.run_dir)]) == 0
    assert len(list((cfg.run_dir / "figures").glob("*.png"))) >= 6
    page = (cfg.run_dir / "report.html").read_text()
    assert "G = 0 (its lower bound" in page
    # G's Err is undefined at 0: a dash in the parameter table, not sd / 1e-24 in %
    row = page[page.index("<th>G</th>"):].split("</tr>")[0]
    assert row.endswith("<td>–</td>") and not re.search(r"\d{6,}(\.\d*)? %", row)


def test_when_the_full_analysis_fails_the_bound_parameter_is_held(g_on_bound, monkeypatch):
    cfg = load_config(g_on_bound)
    test = load_test(cfg)

    def singular(*args, **kwargs):
        raise np.linalg.LinAlgError("rank deficient")

    monkeypatch.setattr(lsq, "analyse", singular)
    result = lsq.fit_test(cfg, test)
    assert math.isnan(result.sd["G"]) and math.isnan(result.err["G"])
    assert math.isfinite(result.sd["E"]) and math.isfinite(result.sd["tau_max"])
    assert any(w.startswith("G = 0 (its lower bound") and "holds G there" in w for w in result.warnings)
    d = result.to_dict()
    assert d["sd"]["G"] is None and d["covariance"][1][1] is None and d["covariance"][0][0] > 0


def test_analyse_holding_conditions_on_the_held_parameter():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=200), rng.normal(size=200)
    X = np.column_stack([a, b, a + 1e-17 * b])          # the third column repeats the first
    with pytest.raises(np.linalg.LinAlgError):
        analyse(X, ["E", "G", "tau_max"], [1.0, 2.0, 3.0], 0.1)
    held = analyse_holding(X, ["E", "G", "tau_max"], [1.0, 2.0, 3.0], 0.1, ["tau_max"])
    ref = analyse(X[:, :2], ["E", "G"], [1.0, 2.0], 0.1)
    np.testing.assert_allclose(held.covariance[:2, :2], ref.covariance)
    assert np.all(np.isnan(held.covariance[2])) and np.isnan(held.sd[2])
    assert held.correlation[2, 2] == 1.0


def test_bound_side():
    assert bound_side(0.0, 0.0, 50.0) == "lower"
    assert bound_side(3e-30, 0.0, 50.0) == "lower"
    assert bound_side(50.0, 0.0, 50.0) == "upper"
    assert bound_side(1e-3, 0.0, 50.0) is None
    assert bound_side(1e4, 0.01, 1e4) == "upper"
    assert bound_side(5.0, 0.0, math.inf) is None


def test_a_singular_x_names_the_parameters_and_the_bound():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=100), rng.normal(size=100)
    X = np.column_stack([a, b, 2.0 * a])
    text = singular_message(X, ["E", "G", "tau_max"], [1.0, 0.0, 3.0], {"G": "lower"},
                            {"E": (100, 2e4), "G": (0.0, 50.0), "tau_max": (0.01, 1e4)})
    assert "the data do not inform the combination of" in text
    assert "E" in text.split("combination of")[1] and "tau_max" in text.split("combination of")[1]
    assert "G = 0 (its lower bound)" in text
    assert "parameters.tau_max: {value: 3}" in text and "..." not in text


def test_negligible_sensitivity_warning_spares_a_well_determined_parameter(tmp_path):
    """A relaxation test whose stress relaxes little: max |X̃(tau_max_R)| is about 4 % of the
    largest, yet tau_max_R is determined to about 3 %: no 'negligible' warning (it fired before)."""
    path = make_run(tmp_path, "rx", small_ramp_relaxation_truth(sigma_inf=6.5), sigma0=0.05,
                    data={"relaxation_start": "auto"}, parameters=WIDE_RELAXATION_PRIORS)
    cfg = load_config(path)
    result = lsq.fit_test(cfg, load_test(cfg))
    top = max(result.normalised_sensitivity_max.values())
    assert result.normalised_sensitivity_max["tau_max_R"] < 0.05 * top
    assert result.err["tau_max_R"] < 0.06
    assert not any("sensitivity to tau_max_R is negligible" in w for w in result.warnings)


def test_a_relaxed_modulus_above_the_instantaneous_one_is_flagged(tmp_path):
    truth = {"params": {"E": 1200.0, "G": 500.0, "tau_max": 8.0}, "strain_rate": 5e-3,
             "strain_max": 0.05, "n_points": 300, "noise": {"strain_sd": 0.0, "stress_sd": 0.05}}
    path = make_run(tmp_path, "g3", truth, sigma0=0.05,
                    parameters={"E": {"prior": "uniform", "low": 100, "high": 20000},
                                "G": {"prior": "uniform", "low": 0, "high": 5000},
                                "tau_max": {"prior": "log-uniform", "low": 0.01, "high": 10000}})
    result = fit(load_config(path)).only
    assert 3 * result.estimate["G"] > result.estimate["E"]
    assert any(w.startswith("3G = ") and "exceeds E = " in w for w in result.warnings)
    assert plausibility_warnings({"E": 2854.0, "G": 2.32}) == []


def _smoothed_into_a_new_folder(tmp_path):
    """A synthetic test with a smoothed strain input, its run folder not made yet."""
    import yaml

    path = write_case(tmp_path, "syn", n=300, seed=4)
    raw = yaml.safe_load(path.read_text())
    raw["data"]["strain_input"] = "smoothed"
    raw["output"] = {"dir": str(tmp_path / "new" / "run")}
    path.write_text(yaml.safe_dump(raw))
    return load_config(path)


def test_a_fit_into_a_new_run_folder_keeps_the_smoothed_strain_for_the_next_commands(tmp_path, monkeypatch):
    """From an empty run folder the strain is smoothed before the folder exists; the fit keeps it
    once it has made the folder, so sample and report read it instead of searching λ again (and a
    report then loads no numba)."""
    from bayes_dnlr.data import smoothing

    cfg = _smoothed_into_a_new_folder(tmp_path)
    assert not cfg.run_dir.exists()
    fit(cfg)
    [kept] = (cfg.run_dir / ".cache").glob("strain-*.npz")
    first = load_test(cfg).strain_input

    def no_search(*args, **kwargs):
        raise AssertionError("the kept smoothing was not read")

    monkeypatch.setattr(smoothing, "_smooth", no_search)
    again = load_test(cfg, cfg.run_dir / ".cache")
    assert np.array_equal(again.strain_input, first)
    assert again.unkept_smoothing is None                  # the folder exists: nothing left to keep


def test_a_failed_fit_into_a_new_folder_keeps_no_smoothing_there(tmp_path, monkeypatch):
    from bayes_dnlr.runs import fit as run_fit_module

    cfg = _smoothed_into_a_new_folder(tmp_path)

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(run_fit_module, "write_json", full_disk)
    with pytest.raises(OSError):
        fit(cfg)
    assert not cfg.run_dir.exists()                        # no half-made run folder, no cache in it


def test_an_estimate_under_model_error_on_a_bound_is_named_at_the_bound(tmp_path):
    """The estimate under model error with G on its bound 0 is said to be 0, on the lower bound (it
    printed 'G = 2.55583e-19 ... sits on a bound' on a real curve)."""
    path = write_case(tmp_path, "g0", params=NO_HARDENING, n=300, seed=0, discrepancy="default",
                      error=("exp", 0.5, 20.0))
    warnings = fit(load_config(path), write=False).only.warnings
    assert "G = 0 (the estimate under model error) sits on the lower bound of its prior [0, 50]" in warnings
