"""Synthetic tests (workflows/simulate.py): the protocol, the noise model, the file, the shipped examples."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from support import REPO
from support.simulate import TENSILE, truth

from bayes_dnlr.cli import main
from bayes_dnlr.config import ConfigError, load_config, parse_config
from bayes_dnlr.data import DataError, load_test
from bayes_dnlr.model import simulate
from bayes_dnlr.workflows.simulate import simulate_test

RUNS = REPO / "runs"
EXAMPLES = ["hdpe-a-2.5e-3", "hdpe-a-5e-3", "hdpe-a-1e-2", "hdpe-b-relax-5e-3"]
RELAX = {"E": 2270.0, "G": 2.30, "tau_max": 7.16, "sigma_inf": 100.0, "tau_max_R": 150.0}


def relax_truth(**kw):
    return truth(**{"params": RELAX, "strain_max": 2.0, "hold": 600.0, "n_points": None, "sample_rate": 2.0,
                    **kw})


def test_file_holds_noisy_measured_strain_and_sigma_star_equals_truth_plus_noise(make_config):
    cfg = make_config(truth=truth(), strain_input="measured")
    res = simulate_test(cfg)
    assert res.status == "written" and res.path == cfg.data_path and res.path.is_file()
    test = load_test(cfg)
    assert test.time.size == 2000 and test.time[-1] == 380.0
    strain_noise = test.strain - res.strain
    stress_noise = test.stress - res.stress
    assert np.std(strain_noise) == pytest.approx(1e-4, rel=0.1)
    assert abs(np.mean(strain_noise)) < 1e-5
    assert np.std(stress_noise) == pytest.approx(0.3, rel=0.1)
    assert abs(np.mean(stress_noise)) < 0.03
    # the noise is independent of the strain noise (σ* uses the measured strain, eq. 6)
    assert abs(np.corrcoef(strain_noise, stress_noise)[0, 1]) < 0.1


def test_true_stress_is_the_model_on_the_noise_free_strain(make_config):
    res = simulate_test(make_config(truth=truth()))
    np.testing.assert_allclose(res.strain, 5e-3 * res.time, rtol=1e-9)
    np.testing.assert_array_equal(res.stress, simulate(res.time, res.strain, TENSILE))
    strain, stress = res.considere()
    assert 0.07 < strain < 0.13 and 28 < stress < 36       # paper: yield near 0.1, ~33 MPa
    assert res.stress[-1] > 100


def test_relaxation_kink_falls_exactly_on_a_sample(make_config):
    cfg = make_config(truth=relax_truth(), relaxation_start=400.0)
    res = simulate_test(cfg)
    assert res.relaxation_start == 400.0 and res.n_points == 2001
    k = int(np.flatnonzero(res.time == 400.0)[0])
    assert k == 800 and res.strain[k] == 2.0 and np.all(res.strain[k:] == 2.0)
    np.testing.assert_allclose(np.diff(res.time), 0.5, rtol=1e-9)
    np.testing.assert_array_equal(
        res.stress, simulate(res.time, res.strain, RELAX, relaxation_start=400.0))
    assert res.stress[k] > 1.4 * res.stress[-1]             # relaxes by about a third
    auto = load_test(make_config(truth=relax_truth(), relaxation_start="auto"))
    assert auto.relaxation_start == 400.0


def test_time_jitter_keeps_the_kink(make_config):
    res = simulate_test(make_config(truth=relax_truth(time_jitter=0.15, seed=3), relaxation_start=400.0))
    steps = np.diff(res.time)
    assert steps.min() < 0.45 and steps.max() > 0.55 and steps.min() > 0.5 * 0.8
    assert 400.0 in res.time and res.time[-1] == 1000.0


def test_nominal_strain_file_reads_back_as_hencky(make_config, tmp_path):
    cfg = make_config(truth=truth(noise={"strain_sd": 0.0, "stress_sd": 0.0}), strain_measure="nominal",
                      strain_input="measured")
    res = simulate_test(cfg)
    first = np.loadtxt(cfg.data_path, delimiter=",", skiprows=1)
    np.testing.assert_allclose(first[:, 1], np.expm1(res.strain), rtol=1e-9, atol=1e-15)
    test = load_test(cfg)
    np.testing.assert_allclose(test.strain, res.strain, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(test.stress, res.stress, rtol=1e-8, atol=1e-9)


def test_sigma_observable_with_eps22_and_force_noise(make_config):
    cols = {"time": "t", "force": "F", "eps11": "e11", "eps22": "e22"}
    cfg = make_config(truth=truth(noise={"stress_sd": 0.0, "force_sd": 2.0}), columns=cols,
                      observable="sigma", strain_input="measured")
    res = simulate_test(cfg)
    test = load_test(cfg)
    assert np.std(test.transverse_strain + 0.5 * res.strain) == pytest.approx(1e-4, rel=0.1)
    # σ = F/S0·exp(-2ε22) (eq. 2): noise is the force noise scaled by exp(-2ε22)/S0
    scaled = (test.stress - res.stress) / (np.exp(-2 * test.transverse_strain) / 24.0)
    assert np.std(scaled) == pytest.approx(2.0, rel=0.1)


def test_stress_column_only(make_config):
    cfg = make_config(truth=truth(), columns={"time": "t", "eps11": "e", "stress": "s"}, observable="stress",
                      area0=None)
    simulate_test(cfg)
    header = cfg.data_path.read_text().splitlines()[0]
    assert header == "t,e,s"
    assert np.std(load_test(cfg).stress - simulate_test(cfg).stress) == pytest.approx(0.3, rel=0.1)


def test_never_silently_overwrites(make_config):
    cfg = make_config(truth=truth())
    simulate_test(cfg)
    before = cfg.data_path.stat().st_mtime_ns
    again = simulate_test(cfg)
    assert again.status == "up to date" and cfg.data_path.stat().st_mtime_ns == before
    other = make_config(truth=truth(seed=2))
    with pytest.raises(DataError) as err:
        simulate_test(other)
    assert str(cfg.data_path) in str(err.value) and "--force" in str(err.value)
    assert simulate_test(other, overwrite=True).status == "written"
    assert simulate_test(other).status == "up to date"


def test_last_digit_rounding_differences_count_as_up_to_date(make_config):
    cfg = make_config(truth=truth())
    simulate_test(cfg)
    lines = cfg.data_path.read_text().splitlines()
    t, e, f = lines[5].split(",")
    lines[5] = ",".join([t, e, f[:-1] + str((int(f[-1]) + 1) % 10)])
    cfg.data_path.write_text("\n".join(lines) + "\n")
    res = simulate_test(cfg)
    assert res.status == "up to date" and "last printed digit" in res.summary()


def test_sample_rate_grid_and_summary(make_config):
    res = simulate_test(make_config(truth=truth(n_points=None, sample_rate=4.0)))
    assert res.n_points == 1521
    text = res.summary()
    for words in ("written", "1521 points over 380 s", "0 to 1.9", "(first Considère point): strain 0.0",
                  "final", "seed 1"):
        assert words in text, text


def test_missing_truth_and_impossible_protocols(make_config, tmp_path):
    with pytest.raises(ConfigError, match="truth: section is missing"):
        simulate_test(make_config())
    with pytest.raises(ConfigError, match="a synthetic test without a time column"):
        simulate_test(make_config(truth=truth(), columns={"force": "F", "eps11": "e"}, strain_rate=5e-3))
    with pytest.raises(ConfigError, match="truth.n_points 3 leaves no sample for the hold"):
        simulate_test(make_config(truth=relax_truth(sample_rate=None, n_points=3, hold=1.0)))


def test_cli_simulate_prints_and_refuses_to_clobber(tmp_path, capsys):
    raw = {"name": "x", "data": {"file": "x.csv", "columns": {"time": "t", "force": "F", "eps11": "e"},
                                 "area0": 24.0}, "truth": truth()}
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(raw))
    assert main(["simulate", str(path)]) == 0
    assert "written" in capsys.readouterr().out
    raw["truth"]["seed"] = 9
    path.write_text(yaml.safe_dump(raw))
    assert main(["simulate", str(path)]) == 2
    assert "not overwritten" in capsys.readouterr().err
    assert main(["simulate", str(path), "--force"]) == 0


# ------------------------------------------------------------------ the shipped examples


@pytest.mark.parametrize("name", EXAMPLES)
def test_shipped_example_is_what_simulate_makes(name, tmp_path):
    src = RUNS / name / "config.yaml"
    cfg = load_config(src)
    assert cfg.name == name and cfg.truth is not None
    shipped = cfg.data_path
    assert shipped.is_file() and shipped.stat().st_size < 300_000
    copy = parse_config(yaml.safe_load(src.read_text()), source=tmp_path / "config.yaml")
    made = simulate_test(copy)
    assert made.status == "written"
    old, new = np.loadtxt(shipped, delimiter=",", skiprows=1), np.loadtxt(copy.data_path, delimiter=",",
                                                                          skiprows=1)
    np.testing.assert_allclose(old, new, rtol=1e-8, atol=1e-12)
    test = load_test(cfg)
    assert test.n_points >= 0.99 * test.time.size


def test_shipped_relaxation_example_auto_finds_the_hold():
    cfg = load_config(RUNS / "hdpe-b-relax-5e-3" / "config.yaml")
    assert cfg.data.relaxation_start == 400.0
    cfg.data.relaxation_start = "auto"
    test = load_test(cfg)
    assert test.relaxation_start == 400.0
    assert "relaxation_start: auto -> 400 s (detected)" in test.notes


# ------------------------------------------------------------------ machine-export layouts

LAYOUT_EXAMPLES = {"bluehill-like": ("delimiter ',' (detected)", "metadata lines 1-5 (not read)",
                                     "header line 7", "units row line 8"),
                   "zwick-like": ("delimiter ';' (detected)", "decimal comma (detected)",
                                  "metadata lines 1-3 (not read)", "header line 5", "units row line 6")}


@pytest.mark.parametrize("name", sorted(LAYOUT_EXAMPLES))
def test_shipped_export_layout_reads_with_no_format_keys(name, tmp_path):
    """runs/bluehill-like and runs/zwick-like: what simulate makes with truth.layout, read back by
    data.format: auto with no delimiter, decimal, header or unit key in the config."""
    src = RUNS / name / "config.yaml"
    raw = yaml.safe_load(src.read_text())
    assert not {"format", "delimiter", "decimal", "header", "strain_unit", "units"} & set(raw["data"])
    cfg = load_config(src)
    copy = parse_config(raw, source=tmp_path / "config.yaml")
    made = simulate_test(copy)
    assert copy.data_path.read_bytes() == cfg.data_path.read_bytes() or made.notes
    assert simulate_test(copy).status == "up to date"
    test = load_test(cfg)
    for words in LAYOUT_EXAMPLES[name]:
        assert words in test.notes[0], test.notes[0]
    assert any("in % -> fraction (×0.01, units row" in n for n in test.notes)
    # the arrays are the truth plus the noise simulate added, whatever the layout
    np.testing.assert_allclose(test.time, made.time, rtol=0, atol=1e-9)
    assert np.std(test.strain - made.strain) == pytest.approx(1e-4, rel=0.15)
    assert np.std(test.stress - made.stress) == pytest.approx(0.3, rel=0.15)


def test_bluehill_layout_writes_quoted_thousands_and_a_units_row(make_config):
    cfg = make_config(truth=truth(layout="bluehill", strain_max=0.3, n_points=300), area0=60.0,
                      columns={"time": "Time", "force": "Load", "strain": "Tensile strain"},
                      strain_measure="nominal")
    simulate_test(cfg)
    lines = cfg.data_path.read_text().splitlines()
    i = lines.index("")
    assert lines[i + 1] == '"Time","Tensile strain","Load"' and lines[i + 2] == '"(s)","(%)","(N)"'
    assert any('","1,' in line for line in lines[i + 3:])           # "1,234.5": quoted thousands
    test = load_test(cfg)
    assert test.nominal_strain.max() == pytest.approx(np.expm1(0.3), abs=1e-3)   # % read back as %


def test_layout_refuses_format_keys_that_contradict_it(make_config):
    with pytest.raises(ConfigError, match="truth.layout: zwick writes its own format; remove data.delimiter"):
        simulate_test(make_config(truth=truth(layout="zwick"), delimiter=","))


def cyclic_truth(**kw):
    return truth(**{"params": {"E": 2000.0, "G": 5.0, "tau_max": 20.0}, "strain_rate": 1e-3,
                    "strain_max": 0.02, "n_points": None, "sample_rate": 5.0,
                    "cycles": {"count": 4}, **kw})


def test_cycles_turn_on_samples_and_unload_to_the_stress(make_config):
    res = simulate_test(make_config(truth=cyclic_truth()))
    np.testing.assert_array_equal(res.stress, simulate(res.time, res.strain, cyclic_truth()["params"]))
    d = np.diff(res.strain)
    turns = np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1])) + 1
    peaks, valleys = res.strain[turns[::2]], res.strain[turns[1::2]]
    np.testing.assert_allclose(peaks, [0.005, 0.01, 0.015, 0.02], rtol=1e-9)
    # each unloading stops at the first sample where the stress reaches 0, not before
    assert np.all(res.stress[turns[1::2]] <= 0.0) and valleys.min() > 0.0
    assert np.all(res.stress[turns[1::2] - 1] > 0.0)
    # loading and unloading at the ramp's rate
    np.testing.assert_allclose(np.abs(d) / np.diff(res.time), 1e-3, rtol=1e-6)
    assert "4 loading-unloading cycles to 0.005, 0.01, 0.015, 0.02" in res.summary()


def test_cycles_with_a_richer_model_and_explicit_peaks(make_config):
    cfg = make_config(truth=cyclic_truth(cycles={"peaks": [0.01, 0.02], "unload_stress": 1.0},
                                         model_form={"kind": "two-process"}))
    res = simulate_test(cfg)
    d = np.diff(res.strain)
    turns = np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1])) + 1
    assert turns.size == 3 and np.all(res.stress[turns[1::2]] <= 1.0)


def test_cycles_refuse_what_they_cannot_make(make_config):
    with pytest.raises(ConfigError, match="cycles need sample_rate"):
        make_config(truth=cyclic_truth(sample_rate=None, n_points=500))
    with pytest.raises(ConfigError, match="peaks must increase"):
        make_config(truth=cyclic_truth(cycles={"peaks": [0.02, 0.01]}))
    with pytest.raises(ConfigError, match="above strain_max"):
        make_config(truth=cyclic_truth(cycles={"peaks": [0.01, 0.03]}))
