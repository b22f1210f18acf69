"""The shift factor as a user meets it: the config's keys and their errors, a temperature read per row,
init finding a temperature, simulate's truth.shift, and a fit that recovers Ea and sigma_s."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from bayes_dnlr.config import ConfigError, load_config
from bayes_dnlr.data import DataError, load_test
from bayes_dnlr.data.temperature import in_file_name, in_metadata
from bayes_dnlr.inference.posterior.likelihood import build_likelihood
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.workflows.init import init_config
from bayes_dnlr.workflows.simulate import simulate_test

DATA = {"file": "t.csv", "columns": {"time": "t_s", "force": "F_N", "eps11": "eps11"}, "area0": 24.0}
TRUTH = {"params": {"E": 1500.0, "G": 5.0, "tau_max": 300.0, "Ea": 250.0, "sigma_s": 2.0},
         "shift": {"temperature": "arrhenius", "reference_temperature": 20.0, "stress": "eyring"},
         "temperature": {"start": 30.0, "rate": 0.05}, "strain_rate": 1.0e-3, "strain_max": 0.3,
         "n_points": 250, "noise": {"strain_sd": 0.0, "stress_sd": 0.1}, "seed": 3}
SHIFT = {"temperature": "arrhenius", "reference_temperature": 20.0, "stress": "eyring"}


def write(folder: Path, raw: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / "config.yaml"
    p.write_text(yaml.safe_dump(raw))
    return p


def raw(**data) -> dict:
    return {"name": "t", "data": {**DATA, **data}, "model": {"shift": dict(SHIFT)},
            "noise": {"sigma0": 0.1, "discrepancy": "none"}}


# ------------------------------------------------------------------------------- config

@pytest.mark.parametrize("change, key", [
    ({}, "data.temperature"),                                        # a shift without a temperature
    ({"temperature": 40.0}, "parameters.Ea"),                        # one temperature: Ea unidentifiable
])
def test_a_temperature_shift_names_what_it_lacks(tmp_path, change, key):
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        load_config(write(tmp_path, raw(**change)))


def test_config_errors_name_their_keys(tmp_path):
    r = raw(temperature=40.0)
    r["parameters"] = {"Ea": {"value": 200.0}, "C1": {"value": 17.4}}
    with pytest.raises(ConfigError, match=r"parameters\.C1 belongs to a shift .*\.temperature: wlf"):
        load_config(write(tmp_path / "a", r))
    r = raw(temperature=40.0)
    del r["model"]["shift"]["reference_temperature"]
    with pytest.raises(ConfigError, match="needs reference_temperature"):
        load_config(write(tmp_path / "b", r))
    r = raw(temperature=-300.0)
    with pytest.raises(ConfigError, match="above -273.15"):
        load_config(write(tmp_path / "c", r))
    r = raw(temperature=40.0)
    r["parameters"] = {"Ea": {"value": 200.0}, "sigma_s": {"prior": "uniform", "low": -1, "high": 5}}
    with pytest.raises(ConfigError, match=r"parameters\.sigma_s: the prior reaches -1 MPa"):
        load_config(write(tmp_path / "d", r))


def test_no_shift_dumps_as_before_and_a_shift_adds_its_parameters(tmp_path):
    plain = {"name": "t", "data": dict(DATA)}
    cfg = load_config(write(tmp_path / "a", plain))
    dumped = cfg.model_dump(mode="json")
    assert "shift" not in dumped["model"] and "temperature" not in dumped["data"]
    r = raw(temperature="T_C")
    cfg = load_config(write(tmp_path / "b", r))
    assert cfg.parameter_names == ["E", "G", "tau_max", "Ea", "sigma_s"]
    assert cfg.parameters["sigma_s"].prior == "log-uniform"


# ----------------------------------------------------------- simulate, the data, and a fit

def test_simulate_writes_the_temperature_and_a_fit_recovers_ea_and_sigma_s(tmp_path):
    r = raw(temperature="T_C")
    r["truth"] = TRUTH
    r["fit"] = {"multistart": 0}        # the physics start is enough here, and 9 times cheaper
    cfg = load_config(write(tmp_path, r))
    simulate_test(cfg)
    header = (tmp_path / "t.csv").read_text().splitlines()[0]
    assert header.split(",")[-1] == "T_C"
    test = load_test(cfg)
    assert test.temperature[0] == pytest.approx(30.0) and test.temperature[-1] == pytest.approx(
        30.0 + 0.05 * test.time[-1])
    assert any("temperature: per row" in n for n in test.notes)
    result = fit(cfg).only
    for k in ("E", "Ea", "sigma_s", "tau_max"):     # within 3 linearized sd of the truth
        assert abs(result.estimate[k] - TRUTH["params"][k]) < 3 * result.sd[k], k
    assert result.sd["sigma_s"] < 0.3 * TRUTH["params"]["sigma_s"]
    # the posterior's compiled likelihood of the shifted model is its reference path's
    like = build_likelihood(cfg, test, 0.1, cfg.free_parameters)
    theta = np.array([[result.estimate[k] * f for k in cfg.free_parameters]
                      for f in (1.0, 1.01, 0.99)])
    fused = like.log_likelihood(theta)
    reference = like.log_likelihood_reference(theta)
    assert np.all(np.isfinite(fused)) and np.allclose(fused, reference, rtol=1e-12, atol=1e-9)


def test_a_temperature_column_in_kelvin_and_a_bad_cell(tmp_path):
    t = np.linspace(0.0, 100.0, 50)
    rows = ["t_s,eps11,sigma_MPa,T"] + [f"{a},{1e-3 * a},{1e3 * 1e-3 * a},{313.15}" for a in t]
    (tmp_path / "k.csv").write_text("\n".join(rows) + "\n")
    base = {"name": "k", "data": {"file": "k.csv", "columns": {"time": "t_s", "eps11": "eps11",
                                                                "stress": "sigma_MPa"},
                                   "observable": "stress", "temperature": {"column": "T", "unit": "K"}}}
    test = load_test(load_config(write(tmp_path, base)))
    assert np.allclose(test.temperature, 40.0)
    base["data"]["temperature"] = "T"           # read as °C: 313 °C is a plausible temperature
    assert np.allclose(load_test(load_config(write(tmp_path, base))).temperature, 313.15)
    rows[10] = rows[10].rsplit(",", 1)[0] + ",2000"
    (tmp_path / "k.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"line 11, column 'T'.*not a temperature in °C"):
        load_test(load_config(write(tmp_path, base)))


def test_a_temperature_without_a_shift_is_a_note(tmp_path):
    r = {"name": "t", "data": {**DATA, "temperature": 40.0}, "truth": {
        "params": {"E": 1500.0, "G": 5.0, "tau_max": 30.0}, "strain_rate": 1e-3, "strain_max": 0.05,
        "n_points": 50}}
    cfg = load_config(write(tmp_path, r))
    simulate_test(cfg)
    notes = load_test(cfg).notes
    assert any("model has no temperature shift" in n for n in notes)


# ------------------------------------------------------------------------------- init

def test_temperature_in_a_name_or_metadata():
    assert in_file_name("OUTRaw_MD_CYC_CSR_01_T20") == (20.0, "T20")
    assert in_file_name("ETFE_MD_CSR_0p1pct_per_s_T40C_3specimens")[0] == 40.0
    assert in_file_name("pp 23 °C spec")[0] == 23.0
    assert in_file_name("pmma_T-10_a")[0] == -10.0
    assert in_file_name("test_313K")[0] == pytest.approx(39.85)
    assert in_file_name("tensile_T3_spec") is None           # a test number, not 3 °C
    assert in_file_name("hdpe-a-5e-3") is None
    assert in_metadata(["Operator: A", "Test temperature: 23.5 °C"])[0] == 23.5
    assert in_metadata(["Temp;296.15;K"])[0] == pytest.approx(23.0)
    assert in_metadata(["Specimen: 3"]) is None


def test_init_writes_a_temperature_column_or_the_one_in_the_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    t = np.linspace(0.0, 100.0, 60)
    lines = ["time_s,strain,stress_MPa,Temperature (°C)"]
    lines += [f"{a},{2e-4 * a},{2e-4 * a * 1000 / (1 + 10 * 2e-4 * a)},{40 + 0.01 * a}" for a in t]
    (tmp_path / "ramp.csv").write_text("\n".join(lines) + "\n")
    res = init_config(tmp_path / "ramp.csv", tmp_path / "a" / "config.yaml")
    assert res.raw["data"]["temperature"] == "Temperature (°C)"
    assert res.raw["data"]["columns"]["time"] == "time_s"
    assert not any(e.key == "data.temperature" for e in res.edits)
    assert math.isclose(load_test(load_config(res.path)).temperature[-1], 41.0)
    (tmp_path / "ramp_T23.csv").write_text("\n".join(x.rsplit(",", 1)[0] for x in lines) + "\n")
    res = init_config(tmp_path / "ramp_T23.csv", tmp_path / "b" / "config.yaml")
    assert res.raw["data"]["temperature"] == 23.0
    assert any(e.key == "data.temperature" and e.action == "check" for e in res.edits)
