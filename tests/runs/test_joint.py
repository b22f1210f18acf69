"""Several tests, one answer: a run with ``tests:`` through simulate, fit and sample; the
joint names in every output; a one-test config unchanged; bad configs name the key."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from support.drawing import figures_not_drawn
from support.joint import RATES, SHARED, TAU_MAX, make_joint
from support.runs import make_run, ramp_truth

JOINT_NAMES = ["E", "G", *(f"tau_max[{t}]" for t in RATES)]


@pytest.fixture(scope="module")
def joint_run(tmp_path_factory) -> Path:
    """A three-rate run with shared E, G and one tau_max per test, fitted and sampled (tiny chain)."""
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    path = make_joint(tmp_path_factory.mktemp("joint"))
    sample(load_config(path), progress=False)
    return path.parent


def test_joint_fit_json_names_and_uses_every_test(joint_run):
    fit = json.loads((joint_run / "fit.json").read_text())
    assert fit["joint"] is True
    assert fit["parameters"] == JOINT_NAMES
    assert fit["per_test"] == ["tau_max"]
    assert set(fit["tests"]) == set(RATES) and set(fit["single_fits"]) == set(RATES)
    truth = {**SHARED, **{f"tau_max[{t}]": v for t, v in TAU_MAX.items()}}
    for k in JOINT_NAMES:
        assert abs(fit["estimate"][k] - truth[k]) < 4 * fit["sd"][k], (k, fit["estimate"][k], fit["sd"][k])
    # the shared E pools the tests: its sd is below every single-test sd
    single = [fit["single_fits"][t]["sd"]["E"] for t in RATES]
    assert fit["sd"]["E"] < min(single)
    # Δ̃ of the joint vector (eq. 35): one row per joint parameter
    assert np.asarray(fit["delta_tilde"]).shape == (5, 5)


def test_joint_posterior_names_in_summary_and_posterior_nc(joint_run):
    from bayes_dnlr.runs.results import read_draws

    summary = json.loads((joint_run / "summary.json").read_text())
    assert list(summary["posterior"])[:5] == JOINT_NAMES
    draws = read_draws(joint_run / "posterior.nc")
    assert set(JOINT_NAMES) <= set(draws)
    assert "tau_max" not in draws          # no unnamed per-test parameter
    assert set(summary["noise"]["tests"]) == set(RATES)
    for t in RATES:
        m = float(draws[f"tau_max[{t}]"].mean())
        assert abs(m - TAU_MAX[t]) / TAU_MAX[t] < 0.02, (t, m)


def test_joint_sample_is_resumable_without_resampling(joint_run):
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    post = sample(load_config(joint_run / "config.yaml"), progress=False)
    assert "nothing sampled" in (post.note or "")


def test_single_test_config_unchanged(tmp_path):
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.fit import fit

    path = make_run(tmp_path, "one", ramp_truth(0.4, n_points=150))
    cfg = load_config(path)
    assert not cfg.is_joint and cfg.test_names == ["one"]
    result = fit(cfg).to_dict()
    assert result["parameters"] == ["E", "G", "tau_max"]
    assert "joint" not in result and "single_fits" not in result


def _joint_raw(tmp_path: Path) -> dict:
    path = make_joint(tmp_path, "bad")
    return yaml.safe_load(path.read_text())


def _run_fit(tmp_path: Path, raw: dict, cli):
    """``cli``: conftest's cli_here (the command in this process: it is not about the process)."""
    path = tmp_path / "bad" / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return cli("fit", str(path))


def _one_error_line(r) -> str:
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    assert "Traceback" not in r.stderr
    return lines[0]


def test_bad_config_test_name_used_twice(tmp_path, cli_here):
    raw = _joint_raw(tmp_path)
    raw["tests"][2]["name"] = raw["tests"][0]["name"]
    line = _one_error_line(_run_fit(tmp_path, raw, cli_here))
    assert "tests[2].name: 'r2.5e-3' is used twice" in line
    assert not (tmp_path / "bad" / "fit.json").exists()


def test_bad_config_per_test_on_one_test(tmp_path, cli_here):
    path = make_run(tmp_path, "one", ramp_truth(0.4, n_points=150))
    raw = yaml.safe_load(path.read_text())
    raw["parameters"] = {"tau_max": {"prior": "log-uniform", "low": 0.01, "high": 1e4, "per": "test"}}
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    line = _one_error_line(cli_here("fit", str(path)))
    assert "parameters.tau_max.per: test needs several tests" in line
    assert not (path.parent / "fit.json").exists()


def test_bad_config_shared_parameter_a_test_cannot_identify(tmp_path, cli_here):
    """A shared sigma_inf with a test whose window ends before its hold: that test cannot identify
    it; the message names the test and the key to change."""
    raw = _joint_raw(tmp_path)
    raw["tests"].append({
        "name": "relax",
        "data": {"file": "relax.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
                 "observable": "stress", "relaxation_start": 1.54, "window": {"time_max": 1.4}},
        "noise": {"sigma0": 0.05},
        "truth": {"params": {"E": 2854, "G": 2.32, "tau_max": 5.0, "sigma_inf": 6.0, "tau_max_R": 50.0},
                  "strain_rate": 5e-3, "strain_max": 0.0077, "hold": 100, "sample_rate": 5,
                  "noise": {"strain_sd": 0.0, "stress_sd": 0.05}, "seed": 11}})
    path = tmp_path / "bad" / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    assert cli_here("simulate", str(path)).returncode == 0
    line = _one_error_line(cli_here("fit", str(path)))
    assert "tests[3] (relax)" in line and "sigma_inf" in line and "data.window" in line
    assert not (tmp_path / "bad" / "fit.json").exists()


def test_bad_config_simulate_needs_every_truth(tmp_path, cli_here):
    raw = _joint_raw(tmp_path)
    del raw["tests"][1]["truth"]
    path = tmp_path / "bad" / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    line = _one_error_line(cli_here("simulate", "--force", str(path)))
    assert "tests[1].truth" in line


def test_joint_report_shows_every_test_one_corner_and_tables_3_5(joint_run):
    from bayes_dnlr.report import build_report

    page = build_report(joint_run).read_text()
    figs = sorted(p.name for p in (joint_run / "figures").glob("*.png"))
    assert figs.count("corner.png") == 1
    assert [f for f in figs if f.startswith("fit-")] == sorted(f"fit-{t}.png" for t in RATES)
    assert "Tables 3/5 layout" in page and "(shared)" in page
    for t in RATES:
        assert f"<th>{t}</th>" in page          # one column per test
        assert f"<h3>{t} (" in page             # its fit and residuals
    # E shared: the rate question is explained, the paper's χ² of the tests alone is given
    assert "one E by construction" in page and "χ²" in page


@pytest.mark.slow
def test_joint_recovery(tmp_path):
    """Three rates with one E and G : the joint E within 3 sd of the
    truth, its sd at most 0.75 × the best single-test posterior sd, R-hat ≤ 1.01 and ESS ≥ 1000
    for every parameter (benchmarks/joint.py prints these with the times)."""
    from support.joint import recovery

    r = recovery(tmp_path, seed=0)
    j = r["joint"]
    assert j["converged"]
    assert abs(j["E_z"]) <= 3, j
    assert j["sd_ratio_to_best_single"] <= 0.75, j
    assert j["r_hat_max"] <= 1.01, j
    assert min(j["ess_bulk_min"], j["ess_tail_min"]) >= 1000, j
    assert j["parameters"][:5] == JOINT_NAMES


def test_compare_refuses_a_joint_run_in_one_line(joint_run, tmp_path, cli_here):
    line = _one_error_line(cli_here("compare", str(joint_run), "--out", str(tmp_path / "cmp")))
    assert "several tests" in line and "report" in line
    assert not (tmp_path / "cmp").exists()


def test_joint_correlation_warnings_in_one_line():
    """A shared E ties every test's tau_max to it and so to each other: one warning, every pair."""
    from bayes_dnlr.inference.lsq.run_fit import _joint_identifiability
    from bayes_dnlr.inference.lsq.sensitivity import analyse

    rng = np.random.default_rng(0)
    n = 200
    ua, ub = rng.normal(size=n), rng.normal(size=n)    # E's sensitivity in test a and in test b
    Xa = np.column_stack([ua, -ua + 0.03 * rng.normal(size=n), np.zeros(n), rng.normal(size=n)])
    Xb = np.column_stack([ub, np.zeros(n), -ub + 0.03 * rng.normal(size=n), rng.normal(size=n)])
    names = ["E", "tau_max[a]", "tau_max[b]", "G"]
    warns = _joint_identifiability(analyse(np.vstack([Xa, Xb]), names, np.ones(4), 1.0))
    corr = [w for w in warns if "correlated" in w]
    assert len(corr) == 1 and not any(w.startswith("|ρ(") for w in warns)
    for pair in ("E–tau_max[a]", "E–tau_max[b]", "tau_max[a]–tau_max[b]"):
        assert pair in corr[0]


def test_joint_report_with_model_error_in_one_test(tmp_path, monkeypatch):
    """One test with a smooth correlated error: its own discrepancy in the joint posterior
    (disc_amplitude[r5e-3]); the others white; the report draws δ on that test's residuals only."""
    from bayes_dnlr.config import load_config
    from bayes_dnlr.report import build_report
    from bayes_dnlr.runs.sample import sample
    from bayes_dnlr.workflows.simulate import simulate_tests

    path = make_joint(tmp_path, "bias", discrepancy=True, sampler={"walkers": 24, "max_steps": 200})
    raw = yaml.safe_load(path.read_text())
    for t in raw["tests"]:
        t["noise"] = {"sigma0": "residuals"}
    raw["tests"][1]["truth"]["noise"]["correlated"] = {"kernel": "matern32", "amplitude": 0.5,
                                                       "length": 20.0}
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    cfg = load_config(path)
    simulate_tests(cfg, overwrite=True)
    summary = sample(cfg, progress=False).summary
    assert "disc_amplitude[r5e-3]" in summary["posterior"]
    assert not any(k.startswith("disc_") and "[r5e-3]" not in k for k in summary["posterior"])
    assert summary["noise"]["tests"]["r5e-3"]["model"] == "discrepancy"
    # the page's text is read (the fit's caption says where δ is drawn); a joint page's figures
    # are drawn by test_joint_report_shows_every_test_one_corner_and_tables_3_5
    figures_not_drawn(monkeypatch)
    page = build_report(path.parent).read_text()
    assert page.count("green on the residuals") == 1
    verdicts = page.split("Model error: ")[1:]          # in test order: r2.5e-3, r5e-3, r1e-2
    assert len(verdicts) == 3
    assert "discrepancy" in verdicts[1][:600] and "No evidence" not in verdicts[1][:100]
