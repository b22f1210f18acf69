"""References in a run (runs/reference_moduli.py): fit.json and summary.json ``reference_moduli``
with their contract keys, ``use: data`` in the analyses and the posterior, the held-out check in the
verdict, and what a result depends on (runs/identity.py)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from bayes_dnlr.config import load_config
from bayes_dnlr.errors import RunError
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.runs.identity import fit_is_current
from bayes_dnlr.runs.sample import sample
from tests.support.references import PULSE_ECHO, SWEEP, TRUE_E, run_with_references

ENTRY_KEYS = {"method", "value", "sd", "frequency", "time", "temperature", "use", "note", "label", "at",
              "prediction", "z", "discrepancy_pct", "discrepancy_to_E_pct", "check", "regime"}


def run(tmp_path: Path, refs: list[dict], name: str = "r") -> Path:
    return run_with_references(tmp_path, refs, name)


def test_fit_json_holds_every_reference_with_its_prediction(tmp_path):
    path = run(tmp_path, [PULSE_ECHO, {"method": "manufacturer", "value": 1200.0},
                          {"method": "nanoindentation", "value": 2700.0, "sd": 60, "time": 0.02}])
    result = fit(load_config(path))
    block = json.loads((path.parent / "fit.json").read_text())
    pe, man, nano = block["reference_moduli"]
    assert ENTRY_KEYS <= set(pe)
    assert (pe["method"], pe["value"], pe["sd"], pe["frequency"], pe["use"]) == ("pulse-echo", TRUE_E,
                                                                                   40.0, 5.0e6, "check")
    assert pe["regime"] == "frozen" and pe["at"] == "E'(5 MHz)"
    e = result.estimate["E"]
    assert pe["prediction"]["mean"] == pytest.approx(e, rel=1e-5)          # frozen: E itself
    lo, hi = pe["prediction"]["hdi_90"]
    assert lo < pe["prediction"]["mean"] < hi
    assert pe["z"] == pytest.approx((TRUE_E - pe["prediction"]["mean"]) / (40**2 + pe["prediction"]["sd"]**2)
                                    ** 0.5)
    assert pe["discrepancy_to_E_pct"] == pytest.approx(100 * (TRUE_E - e) / e)
    assert man["prediction"] is None and man["discrepancy_to_E_pct"] == pytest.approx(100 * (1200 - e) / e)
    assert nano["at"] == "E(t = 0.02 s)" and nano["prediction"]["mean"] < e
    assert "reference_data" not in block                               # nothing in the data
    assert "reference moduli" in result.table()


def test_data_references_enter_the_analysis_and_say_how_far_e_moved(tmp_path):
    path = run(tmp_path, [PULSE_ECHO, SWEEP])
    alone = run(tmp_path, [PULSE_ECHO], name="alone")
    fit(load_config(alone))
    without = json.loads((alone.parent / "fit.json").read_text())
    fit(load_config(path))
    block = json.loads((path.parent / "fit.json").read_text())
    data = block["reference_data"]
    assert data["references"] == ["dma"]
    moved = data["E"]["white"]
    assert moved["before"]["estimate"] == pytest.approx(without["estimate"]["E"])
    assert moved["before"]["sd"] == pytest.approx(without["sd"]["E"])
    assert moved["after"]["estimate"] == pytest.approx(block["estimate"]["E"])
    assert moved["width_ratio"] < 0.8 and block["sd"]["E"] < without["sd"]["E"]
    assert abs(block["estimate"]["E"] - TRUE_E) < 3 * block["sd"]["E"]
    dma = block["reference_moduli"][1]
    assert dma["use"] == "data" and len(dma["points"]["value"]) == 2 * 16 and dma["dof"] == 32
    assert set(data["sensitivities"]["dma"]) >= {"E", "G", "tau_max"}


def test_a_result_depends_on_the_data_references_only(tmp_path):
    path = run(tmp_path, [PULSE_ECHO, SWEEP])
    cfg = load_config(path)
    fit(cfg)
    assert fit_is_current(cfg)
    raw = yaml.safe_load(path.read_text())
    raw["reference_moduli"][0]["value"] = 2500.0         # a check: fit.json is still this config's
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    assert fit_is_current(load_config(path))
    raw["reference_moduli"][1]["relative_sd"] = 0.02      # data: it is not
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    assert not fit_is_current(load_config(path))
    with pytest.raises(RunError, match="reference_moduli"):
        fit(load_config(path))
    raw["reference_moduli"][1]["relative_sd"] = 0.01
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    assert fit_is_current(load_config(path))
    sweep = path.parent / "sweep.csv"
    sweep.write_text(sweep.read_text().replace("0,1;", "0,1000001;", 1))
    assert not fit_is_current(load_config(path))        # the sweep's file by its content


def test_the_posterior_predicts_every_reference_and_the_check_enters_the_verdict(tmp_path):
    wrong = {**PULSE_ECHO, "value": 0.8 * TRUE_E, "name": "pe-wrong"}
    path = run(tmp_path, [PULSE_ECHO, wrong, SWEEP])
    post = sample(load_config(path), progress=False)
    s = post.summary
    good, bad, dma = s["reference_moduli"]
    assert ENTRY_KEYS <= set(good)
    assert good["prediction"]["how"] == "posterior" and good["check"]["fired"] is False
    assert bad["check"]["fired"] is True and bad["z"] < -2.576
    e = s["posterior"]["E"]
    assert good["prediction"]["mean"] == pytest.approx(e["mean"], rel=1e-4)
    assert dma["check"]["held_out"] is False
    checks = s["checks"]
    assert checks["reference_moduli"]["ok"] is False
    assert [(x["label"], x["fired"]) for x in checks["reference_moduli"]["entries"]] == [
        ("pulse-echo", False), ("pe-wrong", True), ("dma", False)]
    assert checks["trust_interval"] is False
    assert any(p.startswith("Pe-wrong (pulse-echo") and "disagree" in p for p in checks["verdict_points"])
    # use: data: the posterior holds the sweep; it agrees with the linearized analysis with it
    gn = json.loads((path.parent / "fit.json").read_text())
    assert abs(e["mean"] - gn["estimate"]["E"]) < 0.5 * gn["sd"]["E"]
    assert e["sd"] == pytest.approx(gn["sd"]["E"], rel=0.25)
    assert s["reference_curve"]["E_median"] == pytest.approx(e["mean"], rel=1e-3)
    assert "reference pe-wrong (check)" in post.table() and "DISAGREES" in post.table()


def test_a_run_folder_elsewhere_reads_the_sweep_from_its_resolved_config(tmp_path):
    path = run(tmp_path, [SWEEP])
    raw = yaml.safe_load(path.read_text())
    raw["output"] = {"dir": "../elsewhere"}
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    fit(load_config(path))
    resolved = tmp_path / "elsewhere" / "config.yaml"
    assert yaml.safe_load(resolved.read_text())["reference_moduli"][0]["file"] == "../r/sweep.csv"
    from bayes_dnlr.runs.reference_moduli import references_of

    (ref,) = references_of(load_config(resolved))
    assert ref.m == 32
