"""simulate and init for the references: a DMA sweep written from the run's truth (its model form
included), a point set beside the truth, init on a DMA export; a run whose spectrum is per test
names the test that predicts a reference."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from bayes_dnlr.config import load_config
from bayes_dnlr.data.dma import read_sweep
from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.workflows.init import init_config
from bayes_dnlr.workflows.sweeps import frequencies, simulate_references
from bayes_dnlr.workflows.truth_forms import complex_modulus
from tests.support.references import PULSE_ECHO, run_with_references
from tests.support.runs import HDPE, ramp_truth


def test_the_sweep_is_the_truth_s_complex_modulus_with_its_noise(tmp_path):
    truth = ramp_truth(0.13, n_points=300) | {"model_form": {"kind": "spectrum-power", "strength": "mild"}}
    sweep = {"method": "dma", "file": "s.txt", "relative_sd": 0.02,
             "truth": {"frequency_min": 0.01, "frequency_max": 1000, "points_per_decade": 3,
                       "relative_sd": 0.0, "layout": "anton-paar", "temperature": 40}}
    path = run_with_references(tmp_path, [sweep, PULSE_ECHO], truth=truth)
    s = read_sweep(path.parent / "s.txt")
    f = frequencies(load_config(path).reference_moduli[0].truth)
    assert f.size == 16 and f[0] == pytest.approx(0.01) and f[-1] == pytest.approx(1000)
    storage, loss = complex_modulus(f, HDPE, "spectrum-power", "mild")     # the model form's, not eq. 12's
    np.testing.assert_allclose(s.storage, storage, rtol=1e-7)
    np.testing.assert_allclose(s.loss, loss, rtol=1e-7)
    np.testing.assert_allclose(s.temperature, 40.0)
    lines = simulate_references(load_config(path))             # again: the same file, kept
    assert "up to date" in lines[0] and "the truth's E'(5 MHz)" in lines[1]


def test_the_simulate_command_writes_the_sweep(tmp_path, cli_here):
    path = run_with_references(tmp_path, [{"method": "dma", "file": "s.csv", "relative_sd": 0.01,
                                           "truth": {"seed": 1}}])
    (path.parent / "s.csv").unlink()
    ran = cli_here("simulate", str(path))
    assert ran.returncode == 0 and (path.parent / "s.csv").is_file()


def test_init_reads_a_dma_export_into_a_reference_entry(tmp_path):
    path = run_with_references(tmp_path, [{"method": "dma", "file": "trios.txt", "relative_sd": 0.01,
                                           "truth": {"layout": "trios", "temperature": 23}}])
    result = init_config(path.parent / "trios.txt", tmp_path / "new" / "reference.yaml")
    entry = yaml.safe_load((tmp_path / "new" / "reference.yaml").read_text())["reference_moduli"][0]
    assert entry["method"] == "dma" and entry["use"] == "data" and entry["file"] == "../r/trios.txt"
    assert "16 rows, 0.1-100 Hz" in result.text() and "set relative_sd" in result.text()
    with pytest.raises(BayesDnlrError, match="never overwrites"):
        init_config(path.parent / "trios.txt", tmp_path / "new" / "reference.yaml")


def test_a_per_test_spectrum_needs_the_reference_s_test(tmp_path):
    rates = {}
    for name, rate in (("slow", 2.5e-3), ("fast", 1e-2)):
        rates[name] = ramp_truth(0.13, n_points=200) | {"strain_rate": rate}
    raw = {"name": "j", "tests": [
        {"name": n, "data": {"file": f"{n}.csv", "columns": {"time": "t_s", "strain": "eps", "stress": "s"},
                             "observable": "stress", "strain_input": "measured"},
         "noise": {"sigma0": 0.1, "discrepancy": "none"}, "truth": t} for n, t in rates.items()],
           "parameters": {"tau_max": {"prior": "log-uniform", "low": 0.01, "high": 1e4, "per": "test"}},
           "reference_moduli": [{"method": "nanoindentation", "value": 2790, "sd": 60, "frequency": 45,
                                 "use": "data"}]}
    d = tmp_path / "j"
    d.mkdir()
    path = d / "config.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    from bayes_dnlr.workflows.simulate import simulate_tests

    simulate_tests(load_config(path))
    with pytest.raises(BayesDnlrError, match=r"tau_max is one per test.*reference_moduli\[i\].test"):
        fit(load_config(path), write=False)
    raw["reference_moduli"][0]["test"] = "fast"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    result = fit(load_config(path), write=False).to_dict()
    nano = result["reference_moduli"][0]
    assert nano["test"] == "fast" and nano["prediction"]["mean"] > 2500
    assert result["reference_data"]["references"] == ["nanoindentation"]
    assert result["sd"]["E"] < result["reference_data"]["without"]["white"]["sd"]["E"]


def test_the_shipped_table_4_example_is_what_simulate_makes(tmp_path):
    """runs/table4-hdpe-a: the tensile test and the DMA sweep from one truth, and its point values
    within their sd of the truth's moduli at their frequencies, as its comments say."""
    from pathlib import Path

    from bayes_dnlr.config import parse_config
    from bayes_dnlr.workflows.simulate import simulate_test

    src = Path(__file__).resolve().parents[2] / "runs" / "table4-hdpe-a" / "config.yaml"
    raw = yaml.safe_load(src.read_text())
    copy = parse_config(raw, source=tmp_path / "config.yaml")
    simulate_test(copy)
    simulate_references(copy)
    for name in ("table4-hdpe-a.csv", "dma-sweep.txt"):
        old, new = (src.parent / name).read_text(), (tmp_path / name).read_text()
        assert old.splitlines()[:2] == new.splitlines()[:2]
        np.testing.assert_allclose(np.genfromtxt(src.parent / name, delimiter="\t" if "dma" in name else ",",
                                                 skip_header=8 if "dma" in name else 1),
                                   np.genfromtxt(tmp_path / name, delimiter="\t" if "dma" in name else ",",
                                                 skip_header=8 if "dma" in name else 1), rtol=1e-8)
    truth = raw["truth"]["params"]
    for entry in raw["reference_moduli"]:
        if entry.get("frequency"):
            true = complex_modulus(entry["frequency"], truth, None)[0][0]
            assert abs(entry["value"] - true) < entry["sd"]
