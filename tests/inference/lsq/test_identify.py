"""Least-squares identification (`fit`): recovery, intervals I/II, fit.json contract, sigma0 forms."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from support import REPO
from support.real_data import ETFE, real

from bayes_dnlr.config import load_config, parse_config
from bayes_dnlr.data import TestData
from bayes_dnlr.errors import BayesDnlrError, RunError
from bayes_dnlr.inference.lsq.identify import FitResult, fit_test, stochastic_analysis
from bayes_dnlr.inference.lsq.sigma0 import resolve_sigma0
from bayes_dnlr.inference.lsq.start import physics_start, spread_starts
from bayes_dnlr.model import simulate
from bayes_dnlr.runs.fit import fit, fit_is_current, load_fit

RATE = 5e-3
TABLE3 = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
RELAX = {**TABLE3, "sigma_inf": 25.0, "tau_max_R": 60.0}
FIT_JSON_KEYS = {
    "parameters", "estimate", "sd", "covariance", "correlation", "delta_tilde", "sigma0", "sigma0_source",
    "n_points", "window", "residuals", "method", "iterations", "criterion", "multistart",
    "condition_number", "warnings", "deborah_max", "strain_rate", "relaxation_start", "config_digest",
    "data_sha256", "version", "wall_time_s"}


# ---------------------------------------------------------------- synthetic tests

def synthetic(truth: dict[str, float] = TABLE3, n: int = 2000, noise: float = 0.3, seed: int = 1,
              hold: float = 0.0, n_hold: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, float | None]:
    """Exact ramp at 5e-3 1/s to 1.9 (then a hold), model stress + Gaussian noise."""
    t = np.linspace(0.0, 1.9 / RATE, n - n_hold)
    t_r = None
    if hold:
        t_r = float(t[-1])
        t = np.r_[t, t_r + np.linspace(0.0, hold, n_hold + 1)[1:]]
    e = np.minimum(RATE * t, 1.9)
    y = simulate(t, e, truth, relaxation_start=t_r) + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return t, e, y, t_r


def test_data(t, e, y, t_r=None, strain_max=None) -> TestData:
    window = np.ones(t.size, bool) if strain_max is None else e <= strain_max
    return TestData(path=Path("synthetic.csv"), sha256="0" * 64, time=t, strain=e, strain_input=e,
                    stress=y, nominal_strain=np.expm1(e), nominal_stress=None, window=window,
                    relaxation_start=t_r, strain_rate=RATE, observable="stress")


test_data.__test__ = False  # type: ignore[attr-defined]


def config(**sections: Any):
    data = {"file": "x.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
            "observable": "stress", "strain_input": "measured"}
    data.update(sections.pop("data", {}))
    return parse_config({"name": "syn", "data": data, **sections})


def write_run(tmp_path: Path, t, e, y, **sections: Any):
    """CSV + config.yaml in tmp_path/run; returns the loaded config."""
    run = tmp_path / "run"
    run.mkdir(exist_ok=True)
    np.savetxt(run / "data.csv", np.column_stack([t, e, y]), delimiter=",", header="t,e,s", comments="",
               fmt="%.12g")
    data = {"file": "data.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
            "observable": "stress", "strain_input": "measured"}
    data.update(sections.pop("data", {}))
    (run / "config.yaml").write_text(yaml.safe_dump({"name": "run", "data": data, **sections}))
    return load_config(run / "config.yaml")


def within_sd(r: FitResult, truth: dict[str, float], ends: dict[str, float] | None = None) -> dict:
    est = ends or r.estimate
    return {k: (est[k] - truth[k]) / r.sd[k] for k in r.names}


# ---------------------------------------------------------------- the shipped examples

def shipped_examples() -> list[Path]:
    return sorted(REPO.glob("runs/hdpe-a-*/config.yaml"))


@pytest.mark.parametrize("path", shipped_examples(), ids=lambda p: p.parent.name)
def test_shipped_example_recovers_table3_within_3sd_from_every_start(path: Path, tmp_path: Path):
    raw = yaml.safe_load(path.read_text())
    if raw.get("truth") is None:
        pytest.skip("no truth: section")
    src = load_config(path)
    raw["data"]["file"] = str(src.data_path)
    raw["output"] = {"dir": str(tmp_path)}
    cfg = parse_config(raw, source=tmp_path / "config.yaml")
    if not cfg.data_path.is_file():
        from bayes_dnlr.workflows.simulate import simulate_test

        raw["data"]["file"] = "data.csv"
        cfg = parse_config(raw, source=tmp_path / "config.yaml")
        simulate_test(cfg)
    r = fit(cfg).only
    truth = {**cfg.truth.params}
    z = within_sd(r, truth)
    print(f"{cfg.name}: estimate {r.estimate}, sd {r.sd}, (est - truth)/sd {z}")
    assert r.converged and r.multistart["same_optimum"]
    assert all(abs(v) < 3 for v in z.values())
    phys = r.multistart["physics_start"]
    assert phys["converged"] and all(abs(v) < 3 for v in within_sd(r, truth, phys["end"]).values())
    assert r.multistart["starts"] == cfg.fit.multistart
    for run in r.multistart["runs"]:
        assert run["converged"]
        assert all(abs(v) < 3 for v in within_sd(r, truth, run["end"]).values()), run
    assert (tmp_path / "fit.json").is_file()


# ---------------------------------------------------------------- recovery on synthetic data

@pytest.mark.parametrize("method", ["lm", "gauss-newton"])
def test_interval_II_recovers_table3_from_physics_start_and_every_multistart(method: str):
    t, e, y, _ = synthetic(seed=11)
    r = fit_test(config(fit={"method": method, "multistart": 6}), test_data(t, e, y))
    z = within_sd(r, TABLE3)
    print(method, "(est - truth)/sd:", z, "iterations", r.iterations)
    assert r.converged and all(abs(v) < 3 for v in z.values())
    assert r.multistart["converged"] == 6 and r.multistart["same_optimum"]
    for run in r.multistart["runs"]:
        assert all(abs(v) < 3 for v in within_sd(r, TABLE3, run["end"]).values())
    assert r.names == ["E", "G", "tau_max"]
    assert r.n_points == 2000 and r.residuals.shape == (2000,) and r.fitted.shape == (2000,)
    np.testing.assert_allclose(r.fitted + r.residuals, y)
    assert r.criterion == pytest.approx(float(r.residuals @ r.residuals))
    assert r.sigma0_source == "residuals"
    assert r.sigma0 == pytest.approx(math.sqrt(r.criterion / (2000 - 3)))
    assert r.deborah_max == pytest.approx(r.estimate["tau_max"] * RATE)
    assert r.diagnostics["white"] is True
    assert any("ρ(E, tau_max)" in w for w in r.warnings)        # the paper's -0.9988: a warning


def test_stochastic_analysis_at_given_parameters_matches_the_fit():
    t, e, y, _ = synthetic(seed=24)
    cfg = config(noise={"sigma0": 0.3}, fit={"multistart": 0})
    td = test_data(t, e, y)
    r = fit_test(cfg, td)
    a = stochastic_analysis(cfg, td, r.estimate, 0.3)
    np.testing.assert_allclose(a.covariance, r.covariance, rtol=1e-10)
    np.testing.assert_allclose(a.delta_tilde, r.delta_tilde, rtol=1e-10, atol=1e-14)
    assert a.Xn.shape == (2000, 3)
    # at the true parameters, a-priori (Table 2 style): same bands as the paper's
    b = stochastic_analysis(cfg, td, TABLE3, 0.3)
    assert b.correlation[0, 2] <= -0.99


def test_both_methods_reach_the_same_optimum():
    t, e, y, _ = synthetic(seed=12)
    a = fit_test(config(fit={"method": "lm", "multistart": 0}), test_data(t, e, y))
    b = fit_test(config(fit={"method": "gauss-newton", "multistart": 0}), test_data(t, e, y))
    for k in a.names:
        assert abs(a.estimate[k] - b.estimate[k]) < 1e-3 * a.sd[k]
    assert b.criterion == pytest.approx(a.criterion, rel=1e-10)
    assert a.multistart["starts"] == 0 and a.multistart["same_optimum"] is None


def test_interval_I_with_G_fixed_is_the_papers_two_parameter_identification():
    t, e, y, _ = synthetic(seed=13)
    cfg = config(data={"window": {"strain_max": 0.13}}, parameters={"G": {"value": 2.32}})
    r = fit_test(cfg, test_data(t, e, y, strain_max=0.13))
    print("interval I:", r.estimate, r.sd, "rho", r.correlation[0, 1])
    assert r.names == ["E", "tau_max"]
    assert r.estimate["G"] == 2.32 and r.fixed == {"G": 2.32}
    assert r.n_points == int(np.sum(e <= 0.13))
    assert r.window["strain"][1] <= 0.13 and r.window["bounds"] == {"strain_max": 0.13}
    assert all(abs(v) < 3 for v in within_sd(r, TABLE3).values())
    assert -0.995 <= r.correlation[0, 1] <= -0.95
    assert r.delta_tilde.shape == (2, 2)
    table = r.table().splitlines()
    rows = [line for line in table[table.index(next(x for x in table if x.startswith("parameter"))) + 1:][:3]]
    assert len(rows) == 3 and len({len(line) - len(line.split()[-1]) for line in rows}) == 1  # units aligned
    # interval II narrows E: the paper's Table 2 (a) vs (b)
    r2 = fit_test(config(), test_data(t, e, y))
    assert r2.sd["E"] < r.sd["E"]


def test_G_free_on_interval_I_is_flagged_as_negligible():
    t, e, y, _ = synthetic(seed=14)
    r = fit_test(config(data={"window": {"strain_max": 0.13}}), test_data(t, e, y, strain_max=0.13))
    assert any("sensitivity to G is negligible" in w for w in r.warnings)


def test_tensile_then_relaxation_five_parameters():
    t, e, y, t_r = synthetic(RELAX, n=1000, hold=200.0, n_hold=200, seed=15)
    cfg = config(data={"relaxation_start": t_r}, fit={"multistart": 4})
    r = fit_test(cfg, test_data(t, e, y, t_r))
    z = within_sd(r, RELAX)
    print("relaxation: (est - truth)/sd", z)
    assert r.names == ["E", "G", "tau_max", "sigma_inf", "tau_max_R"]
    assert all(abs(v) < 3 for v in z.values())
    assert r.multistart["same_optimum"]
    assert r.start["sigma_inf"] == pytest.approx(25.0, rel=0.1)


def test_tau_fixed_makes_a_linear_problem():
    t, e, y, _ = synthetic(seed=16)
    r = fit_test(config(parameters={"tau_max": {"value": 5.79}}, fit={"multistart": 2}), test_data(t, e, y))
    assert r.names == ["E", "G"]
    from bayes_dnlr.model import DNLR

    v = DNLR(t, e).basis(5.79).values
    coef = np.linalg.lstsq(v[:, :2], y, rcond=None)[0]
    np.testing.assert_allclose([r.estimate["E"], r.estimate["G"]], coef, rtol=1e-8)


def test_relaxation_parameters_outside_the_window_are_refused():
    t, e, y, t_r = synthetic(RELAX, n=1000, hold=200.0, n_hold=200, seed=17)
    cfg = config(data={"relaxation_start": t_r, "window": {"time_max": t_r - 1.0}})
    td = test_data(t, e, y, t_r)
    td = TestData(**{**td.__dict__, "window": t <= t_r - 1.0})
    with pytest.raises(BayesDnlrError, match="relaxation phase"):
        fit_test(cfg, td)


def test_physics_start_is_close_to_the_truth():
    t, e, y, _ = synthetic(seed=18)
    guess, notes = physics_start(t, e, y, None, RATE)
    print("physics start:", guess)
    assert guess["E"] == pytest.approx(TABLE3["E"], rel=0.4)
    assert guess["G"] == pytest.approx(TABLE3["G"], rel=0.1)
    assert TABLE3["tau_max"] / 2 < guess["tau_max"] < 2 * TABLE3["tau_max"]
    assert set(notes) == {"E", "G", "tau_max"}


def test_spread_starts_cover_the_box():
    cfg = config()
    s = spread_starts(cfg.parameters, ["E", "G", "tau_max"], 8, time_span=(0.19, 380.0))
    assert s.shape == (8, 3)
    assert np.all((s[:, 0] > 100) & (s[:, 0] < 20000)) and np.ptp(s[:, 0]) > 0.8 * 19900
    assert len(set(s[:, 1])) == 8
    lt = np.log(s[:, 2])                             # log-spaced, capped to [step, 10 x duration]
    assert np.all((s[:, 2] >= 0.19) & (s[:, 2] <= 3800.0))
    np.testing.assert_allclose(np.diff(np.sort(lt)), np.diff(np.sort(lt))[0])


# ---------------------------------------------------------------- sigma0

def test_resolve_sigma0_forms(tmp_path: Path):
    t, e, y, _ = synthetic(seed=19)
    td = test_data(t, e, y)
    res = np.random.default_rng(0).normal(0, 0.5, 1000)
    s_res = math.sqrt(float(res @ res) / (1000 - 3))
    assert resolve_sigma0(config(noise={"sigma0": 0.4}), td) == (0.4, "config")
    assert resolve_sigma0(config(), td, res) == pytest.approx((s_res, "residuals"))
    sampled = config(noise={"sigma0": {"prior": "half-normal", "scale": 5}})
    assert resolve_sigma0(sampled, td, res) == pytest.approx((s_res, "residuals (sigma0 sampled in MCMC)"))
    with pytest.raises(BayesDnlrError):
        resolve_sigma0(config(), td)
    # baseline: an unloaded stretch before the ramp
    tb = np.r_[np.linspace(-10, -0.1, 50), t]
    yb = np.r_[np.random.default_rng(1).normal(0, 0.25, 50), y]
    eb = np.r_[np.zeros(50), e]
    base = test_data(tb, eb, yb)
    value, source = resolve_sigma0(config(noise={"sigma0": {"baseline": {"time_max": -0.05}}}), base)
    assert source == "baseline" and value == pytest.approx(0.25, rel=0.3)


def test_known_sigma0_scales_the_covariance_not_the_correlation():
    t, e, y, _ = synthetic(seed=20)
    a = fit_test(config(noise={"sigma0": 0.3}, fit={"multistart": 0}), test_data(t, e, y))
    b = fit_test(config(noise={"sigma0": 0.6}, fit={"multistart": 0}), test_data(t, e, y))
    assert a.sigma0_source == "config" and a.sigma0 == 0.3
    np.testing.assert_allclose(b.covariance, 4 * a.covariance, rtol=1e-9)
    np.testing.assert_allclose(b.correlation, a.correlation, atol=1e-12)


# ---------------------------------------------------------------- fit.json and overwrite rules

def test_fit_writes_fit_json_with_the_contract_keys(tmp_path: Path):
    t, e, y, _ = synthetic(seed=21)
    cfg = write_run(tmp_path, t, e, y, fit={"multistart": 3})
    r = fit(cfg).only
    saved = load_fit(cfg.run_dir)
    assert FIT_JSON_KEYS <= set(saved)
    assert saved["parameters"] == ["E", "G", "tau_max"]
    assert saved["estimate"] == pytest.approx(r.estimate)
    assert np.array(saved["delta_tilde"]).shape == (3, 3)
    assert saved["delta_tilde"][0][0] == pytest.approx(r.sd["E"] / r.estimate["E"])
    assert saved["delta_tilde"][0][2] == pytest.approx(r.correlation[0, 2])
    res = saved["residuals"]
    assert {"rms", "lag1_autocorrelation", "durbin_watson", "runs_test", "white", "verdict"} <= set(res)
    assert {"n_runs", "expected", "z", "p_value"} <= set(res["runs_test"])
    ms = saved["multistart"]
    assert {"starts", "converged", "same_optimum", "spread"} <= set(ms) and ms["starts"] == 3
    assert set(ms["spread"]) == {"E", "G", "tau_max"}
    assert {"bounds", "time", "strain"} <= set(saved["window"])
    assert saved["version"] and saved["wall_time_s"] > 0
    assert fit_is_current(cfg)
    assert "fit " in r.table() and "Δ̃" in r.table()


def test_fit_refuses_to_overwrite_a_fit_from_another_config_or_data(tmp_path: Path):
    t, e, y, _ = synthetic(seed=22)
    white = {"discrepancy": "none"}      # the refusals do not depend on the likelihood; white is cheap
    cfg = write_run(tmp_path, t, e, y, fit={"multistart": 0}, noise=white)
    fit(cfg)
    fit(cfg)                                              # same inputs: may rewrite
    other = write_run(tmp_path, t, e, y, fit={"multistart": 0}, noise={"sigma0": 0.3, **white})
    assert not fit_is_current(other)
    with pytest.raises(RunError, match=r"fit\.json.*noise.*--force"):
        fit(other)
    fit(other, overwrite=True)
    assert fit_is_current(other) and load_fit(other.run_dir)["sigma0_source"] == "config"
    # a different data file (same config)
    y2 = y + 0.01
    again = write_run(tmp_path, t, e, y2, fit={"multistart": 0}, noise={"sigma0": 0.3, **white})
    assert not fit_is_current(again)
    with pytest.raises(RunError, match="different data file"):
        fit(again)
    r = fit(again, write=False).only                           # nothing written: allowed
    assert r.data_sha256 != load_fit(again.run_dir)["data_sha256"]


def test_load_fit_without_a_fit_says_so(tmp_path: Path):
    with pytest.raises(RunError, match="run `fit` first"):
        load_fit(tmp_path)


def test_fit_json_is_strict_json(tmp_path: Path):
    t, e, y, _ = synthetic(seed=23)
    cfg = write_run(tmp_path, t, e, y, fit={"multistart": 0})
    fit(cfg)
    json.loads((cfg.run_dir / "fit.json").read_text(), parse_constant=lambda c: pytest.fail(c))


# ---------------------------------------------------------------- real data (optional)

@real
def test_real_etfe_specimen_converges_and_its_residuals_are_called_biased(tmp_path: Path):
    a = np.genfromtxt(ETFE, delimiter=",")
    t, e, s = a[:, 0], a[:, 7], a[:, 9]          # specimen 0: time, Hencky strain (SOI), true stress
    keep = np.isfinite(t) & np.isfinite(e) & np.isfinite(s)
    cfg = write_run(tmp_path, t[keep], e[keep], s[keep], fit={"multistart": 4},
                    data={"strain_input": "smoothed"})
    r = fit(cfg).only
    print("ETFE specimen 0:", r.estimate, "rms", r.diagnostics["rms"])
    assert r.converged and r.multistart["same_optimum"]
    assert 1500 < r.estimate["E"] < 3000                 # README: roughly 1.9-2.4 GPa
    assert 1.0 < r.diagnostics["rms"] < 2.5              # README: 1.3-2.0 MPa
    assert r.diagnostics["white"] is False and "model bias" in r.diagnostics["verdict"]


# ---------------------------------------------------------------- coverage (slow)

@pytest.mark.slow
def test_coverage_of_the_linearized_interval():
    """±1.96 linearized sd covers the truth in 90-99 % of 200 noisy replicates."""
    n_rep = 200
    hits = {k: 0 for k in TABLE3}
    cfg = config(fit={"multistart": 0})
    for seed in range(n_rep):
        t, e, y, _ = synthetic(seed=1000 + seed)
        r = fit_test(cfg, test_data(t, e, y))
        for k in TABLE3:
            hits[k] += abs(r.estimate[k] - TABLE3[k]) <= 1.96 * r.sd[k]
    cover = {k: v / n_rep for k, v in hits.items()}
    print("coverage of ±1.96 sd:", cover)
    assert all(0.90 <= c <= 0.99 for c in cover.values())
