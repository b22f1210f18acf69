"""Loading-unloading cycles, repeated time stamps and an engineering stress as the data layer reads
them: turning points are no spikes, a strain bound ends the window where the measured strain says,
fit never recommends the window already set, a repeated time stamp has a config key (the error
names it), a time that goes back stays an error, and data.stress_measure: engineering converts as
the paper does (eq. 4-6)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from support.plastic_cycles import plastic_cycles
from support.real_data import CYCLES, reads_export

from bayes_dnlr.config import ConfigError
from bayes_dnlr.data import DataError, load_test
from bayes_dnlr.data.cycles import turning_points
from bayes_dnlr.data.ramp import find_hold

E = 1000.0       # MPa: a linear elastic material is enough for what the data layer reads


def _cycles(peaks=(0.01, 0.02, 0.02), step=0.0005, back=0.9) -> tuple[np.ndarray, np.ndarray]:
    """Time and nominal strain of loading-unloading cycles, sampled sparsely (every `step` of
    strain): each cycle unloads by `back` of its peak."""
    e = [0.0]
    for p in peaks:
        e += list(np.arange(e[-1] + step, p + 1e-12, step))
        e += list(np.arange(e[-1] - step, p * (1 - back) - 1e-12, -step))
    e = np.array(e)
    return np.arange(e.size) * 0.5, e


def _write(write_csv, t, e, s, name="test.csv", extra=None):
    cols = {"t_s": t, "e": e, "s_MPa": s, **(extra or {})}
    rows = np.column_stack(list(cols.values()))
    write_csv(",".join(cols) + "\n" + "\n".join(",".join(f"{v:.10g}" for v in r) for r in rows) + "\n",
              name)


CYCLIC = dict(columns={"time": "t_s", "strain": "e", "stress": "s_MPa"}, strain_measure="nominal",
              observable="stress", area0=None)


def test_the_turning_points_of_cycles_are_no_spikes_but_a_corrupt_cell_still_is(write_csv, make_config):
    t, e = _cycles(step=0.0015)             # the peaks of about 10 and 20 MPa, 1.5 MPa between samples
    s = E * e + np.random.default_rng(1).normal(0, 0.01, e.size)
    _write(write_csv, t, e, s)
    notes = load_test(make_config(**CYCLIC)).notes
    assert not [n for n in notes if "spike" in n], notes
    s[10] += 4.0                                                  # a corrupt cell is one
    _write(write_csv, t, e, s)
    notes = load_test(make_config(**CYCLIC)).notes
    assert any(n.startswith("warning: a spike at line 12") for n in notes), notes


def test_turning_points_come_from_an_unloading_not_from_a_hold_or_a_falling_force():
    t, e = _cycles()
    turns = turning_points(e, E * e)
    assert turns.cyclic and len(turns.peaks) == 3
    assert [round(float(e[k]), 6) for k in turns.peaks] == [0.01, 0.02, 0.02]
    hold = np.minimum(np.linspace(0, 0.02, 400), 0.01)           # a ramp and a hold, noisy strain
    noisy = hold + np.random.default_rng(2).normal(0, 2e-4, hold.size)
    assert not turning_points(noisy, 10 * np.exp(-np.arange(400) / 100.0) + E * hold).peaks
    necking = np.linspace(0, 1.0, 300)                            # the force falls, the strain rises
    assert not turning_points(necking, np.exp(-3 * necking) * necking * 50).peaks
    shipped = Path(__file__).resolve().parents[2] / "runs/hdpe-b-relax-5e-3/hdpe-b-relax-5e-3.csv"
    _, strain, force = np.loadtxt(shipped, delimiter=",", skiprows=1).T   # the force falls by 42 %
    assert not turning_points(strain, force).peaks            # past its peak, rises again, then holds


def test_a_strain_bound_ends_the_window_where_the_measured_strain_says(write_csv, make_config):
    """The smoothed strain rounds a sparsely sampled turning point down: a strain_max just below
    the measured peak used to let the window run into the next cycle."""
    t, e = _cycles()
    _write(write_csv, t, e, E * e)
    bound = 0.0099                          # below the first peak (0.01), above the sample before it
    test = load_test(make_config(**CYCLIC, window={"strain_max": bound}))
    last = int(np.flatnonzero(test.window)[-1])
    assert test.strain[last] <= np.log1p(bound) < test.strain[last + 1]
    assert test.time[last] < t[int(np.argmax(e >= 0.01))]        # before the first peak, not past it


def test_fit_never_recommends_the_window_already_set(write_csv, make_config):
    t, e = _cycles()
    _write(write_csv, t, e, E * e)
    peak = float(t[int(np.argmax(e >= 0.01))])
    late = load_test(make_config(**CYCLIC, window={"time_max": peak + 1.0})).notes
    hint = [n for n in late if n.startswith("warning: data.window ends")]
    assert hint and f"data.window: {{time_max: {peak:g}}}" in hint[0], late
    fixed = load_test(make_config(**CYCLIC, window={"time_max": peak}))
    assert not [n for n in fixed.notes if n.startswith("warning: data.window ends")], fixed.notes
    assert fixed.time[fixed.window][-1] == peak


def test_a_noisy_hold_is_a_hold():
    """A DIC strain wanders by a few % of its range in the hold, with a glitch: still a hold."""
    rng = np.random.default_rng(3)
    t = np.concatenate((np.linspace(0, 8, 41), np.linspace(8.2, 3000, 400)))
    e = np.minimum(t / 8, 1.0) * 0.0077 + np.convolve(rng.normal(0, 6e-5, t.size + 8), np.ones(9) / 3,
                                                     mode="valid") * (t > 0)
    e[300] += 4e-4
    s = np.where(t <= 8, t / 8 * 9.0, 7.5 + 1.5 * np.exp(-(t - 8) / 500))
    hold = find_hold(t, e, s)
    assert hold is not None and hold.time <= 10.0, hold


def test_repeated_time_stamps_have_a_key_and_a_note(write_csv, make_config):
    t = np.arange(0, 20.0, 0.5)
    e = 0.001 * t
    rows = np.array([0, 1, 2, 3, 3, *range(4, t.size)])           # line 6 repeats line 5's time
    s = E * e[rows]
    s[4] += 0.2                                                    # ... with a new value
    _write(write_csv, t[rows], e[rows], s)
    with pytest.raises(DataError) as err:
        load_test(make_config(**CYCLIC))
    msg = str(err.value)
    assert "line 5 has 1.5 and line 6 has 1.5" in msg and "set data.repeated_time: drop" in msg, msg
    dropped = load_test(make_config(**CYCLIC, repeated_time="drop"))
    assert dropped.time.size == t.size and dropped.stress[3] == pytest.approx(E * e[3], rel=1e-9)
    assert any(n.startswith("repeated time stamps: 1 row(s) repeat the time stamp of the row before "
                            "them (line(s) 6): dropped") for n in dropped.notes), dropped.notes
    averaged = load_test(make_config(**CYCLIC, repeated_time="average"))
    assert averaged.time.size == t.size
    assert averaged.stress[3] == pytest.approx(E * e[3] + 0.1, rel=1e-9)


def test_a_time_that_goes_back_stays_an_error(write_csv, make_config):
    t = np.arange(0, 20.0, 0.5)
    rows = np.array([0, 1, 2, 3, 3, 5, 4, *range(6, t.size)])
    _write(write_csv, t[rows], 0.001 * t[rows], E * 0.001 * t[rows])
    with pytest.raises(DataError, match="line 7 has 2.5 and line 8 has 2") as err:
        load_test(make_config(**CYCLIC, repeated_time="drop"))
    assert "repeated_time" not in str(err.value)


def test_an_engineering_stress_is_converted_as_sigma_star_of_a_force(write_csv, make_config):
    t = np.arange(0, 60.0, 0.5)
    e = 0.004 * t
    s = 30 * np.tanh(E * e / 30)
    _write(write_csv, t, e, s, extra={"F_N": s})
    eng = load_test(make_config(**CYCLIC, stress_measure="engineering"))
    force = load_test(make_config(columns={"time": "t_s", "strain": "e", "force": "F_N"}, area0=1.0,
                                  strain_measure="nominal"))
    np.testing.assert_array_equal(eng.stress, force.stress)           # σ = s·exp(ε), eq. 4-6
    np.testing.assert_allclose(eng.nominal_stress, s, rtol=1e-9)     # the column, as written
    assert any(n.startswith("stress: engineering -> true") for n in eng.notes)
    with pytest.raises(ConfigError, match="stress_measure: engineering"):
        make_config(columns={"time": "t_s", "strain": "e", "force": "F_N"}, area0=1.0,
                    stress_measure="engineering")


def test_a_name_a_confirmed_relation_contradicts_is_overruled_with_where_it_fits():
    from bayes_dnlr.data.name_check import Said, overruled, time_copies

    t = np.arange(10.0)
    values = [t, 0.001 * t, 2.0 * t, t.copy(), 0.001 * t, 2.0 * t * (1 + 0.001 * t)]
    copies = time_copies(values, 0)
    assert list(copies) == [3]                          # the time's copy, whatever its name
    confirmed = {**copies, 5: Said("true stress", "column 6 = column 3 × (1 + column 2) (to 1e-16)")}
    names = {3: Said("Hencky strain", "exxHencky"), 4: Said("true stress", "StressTrue"),
             5: Said("Hencky strain", "SR0Hencky"), 2: Said("engineering stress", "StressEng")}
    header = ["t", "e", "StressEng", "exxHencky", "StressTrue", "SR0Hencky"]
    wrong, lines = overruled(names, confirmed, header)
    assert sorted(wrong) == [3, 4, 5]                  # the engineering stress's name stands
    assert lines[0].startswith("column 4 is named 'exxHencky' (a Hencky strain), but column 4 = column 1")
    assert "the true stress is column 6" in lines[1]
    assert "the name 'StressTrue' over column 5 fits it: the header is shifted" in lines[2]


def test_cycles_that_reverse_by_4_percent_of_the_strain_are_cycles_everywhere(write_csv, make_config,
                                                                              tmp_path):
    """One rule for where a test turns (data/cycles.py), computed when the test is loaded and read
    by init's window, the strain rate of the first loading, the branches the predictive check
    reports on, and the first peak a first loading ends at."""
    from bayes_dnlr.data.cycles import turning_points as rule
    from bayes_dnlr.inference.checks.predictive import segments
    from bayes_dnlr.workflows.init import init_config

    t, e, s = plastic_cycles()
    s = s + np.random.default_rng(5).normal(0, 0.01, e.size)
    _write(write_csv, t, e, s)
    test = load_test(make_config(**CYCLIC))
    path, turns = test.path, test.turns
    assert len(turns.peaks) == 3 and len(turns.valleys) == 2 and turns == rule(test.strain, test.stress)
    e_n = test.nominal_strain
    back = [e_n[p] - e_n[v] for p, v in zip(turns.peaks[:2], turns.valleys, strict=True)]
    assert np.allclose(back, 0.04 * np.ptp(test.nominal_strain), rtol=0.05)      # 4 % of the range
    assert test.first_peak == turns.peaks[0] and test.time[test.first_peak] == pytest.approx(200.0)
    # the strain rate of the first loading, not of the whole history
    assert test.strain_rate == pytest.approx(1e-3, rel=0.1)
    # the branches of the predictive check
    seg = segments(test.time, None, turns=turns.within(np.arange(test.time.size)))
    assert [k for k in seg if k.startswith(("loading", "unloading"))] == [
        "loading 1", "unloading 1", "loading 2", "unloading 2", "loading 3", "unloading 3"]
    # init proposes the first loading, which ends at the same peak, and names the whole history
    result = init_config(path, tmp_path / "init" / "config.yaml")
    assert "the first loading of 3 loading-unloading cycles" in result.text()
    assert "the strain turns back first (t = 200.00 s" in result.text()
    assert yaml.safe_load((tmp_path / "init" / "config.yaml").read_text())["data"]["window"] == {
        "time_max": 200.0}
    # a window that ends before the first peak has no peak to end at
    early = load_test(make_config(**CYCLIC, window={"time_max": 150.0}))
    assert early.first_peak is None and early.turns == turns


@reads_export(CYCLES)
def test_the_strain_rate_of_real_cycles_to_a_force_is_that_of_their_first_loading(make_config):
    """The film's fifth cyclic specimen is cycled to a force: its strain creeps up from cycle to
    cycle, so that its largest strain comes at the last peak; the rate is that of the
    first loading (the export's README: 0.1 %/s), not of the whole history (1.26e-5 1/s)."""
    rates = []
    for specimen in range(1, 7):
        test = load_test(make_config(file=str(CYCLES), specimen=specimen, specimen_columns=8,
                                     columns={"time": 1, "strain": 2, "stress": 4},
                                     strain_unit="fraction", strain_measure="nominal",
                                     observable="stress", stress_measure="engineering",
                                     repeated_time="drop", area0=None, window={}))
        assert test.turns.cyclic and len(test.turns.peaks) == 10, (specimen, test.turns)
        assert test.first_peak == test.turns.peaks[0]
        rates.append(test.strain_rate)
    assert np.allclose(rates, 1e-3, rtol=0.12), rates
