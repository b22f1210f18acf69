"""What the data layer checks and says about a test: the first sample,
toe compensation and an unloaded start, the strain rate of the window, and a strain column whose
unit or meaning looks wrong."""

from __future__ import annotations

import re

import numpy as np
import pytest

from bayes_dnlr.data import DataError, load_test, ramp_strain_rate
from bayes_dnlr.data.initial_state import toe_point


def csv_text(cols: dict[str, np.ndarray]) -> str:
    rows = np.column_stack(list(cols.values()))
    return ",".join(cols) + "\n" + "\n".join(",".join(f"{v:.10g}" for v in r) for r in rows) + "\n"


def elastic_plastic(t: np.ndarray, rate: float = 5e-3, E: float = 2000.0) -> tuple[np.ndarray, np.ndarray]:
    """Nominal strain and a smooth nominal stress: linear at E, bending over towards 30 MPa."""
    e = rate * t
    return e, 30.0 * np.tanh(E * e / 30.0)


# ------------------------------------------------------------------ item 6: the strain rate of the window


def test_strain_rate_is_the_ramp_rate_over_the_window(write_csv, make_config):
    """A ramp at 5e-3 1/s, a hold, an unloading and a rest: the whole-record slope is negative."""
    t = np.arange(0, 700.0, 0.5)
    e = np.interp(t, [0, 100, 200, 250, 700], [0, 0.5, 0.5, 0.0, 0.0])
    write_csv(csv_text({"t_s": t, "F_N": 24 * 1000 * e, "eps11": e}))
    assert ramp_strain_rate(t, e, None) < 0                 # what strain_rate used to be
    cases = (({"time_max": 60.0}, "the window's loading"), ({"time_max": 200.0}, "the window's loading"),
             ({"time_min": 120.0, "time_max": 190.0}, "the loading before the window"))
    for window, how in cases:
        test = load_test(make_config(window=window, strain_input="measured"))
        assert test.strain_rate == pytest.approx(5e-3, rel=1e-9), window
        assert any(n.startswith(f"strain_rate: 0.005 1/s (over {how}") for n in test.notes), test.notes
    # with the hold declared, a window in the hold takes the ramp before it
    test = load_test(make_config(window={"time_min": 120.0, "time_max": 190.0}, relaxation_start=100.0,
                                 strain_input="measured"))
    assert test.strain_rate == pytest.approx(5e-3, rel=1e-9)
    assert "loading before the window" in next(n for n in test.notes if n.startswith("strain_rate"))


def test_strain_rate_of_a_pre_yield_window(write_csv, make_config):
    """rHDPE-like: a window on the first part of a test whose strain rate changes later; the rate must
    be that of the window (it was the whole record's: 2.6 times too low)."""
    t = np.arange(0, 500.0, 0.1)
    e = np.where(t < 10, 7.5e-3 * t, 0.075 + 1e-3 * (t - 10))
    write_csv(csv_text({"t_s": t, "F_N": 24 * 30 * np.tanh(e / 0.015), "eps11": e}))
    test = load_test(make_config(window={"strain_max": 0.07}, strain_input="measured"))
    assert test.strain_rate == pytest.approx(7.5e-3, rel=1e-6)
    assert ramp_strain_rate(t, e, None) < 0.4 * 7.5e-3


# ------------------------------------------------------------------ item 5: the first sample


def cropped(write_csv, crop: float = 0.005, noise: float = 0.01, rate: float = 5e-3) -> tuple:
    """A test at 10 Hz whose rows below ``crop`` nominal strain are missing (as the rHDPE export)."""
    rng = np.random.default_rng(1)
    t = np.arange(0, 40.0, 0.1)
    e, s = elastic_plastic(t, rate)
    keep = e >= crop
    s_noisy = s + rng.normal(0, noise, t.size)
    write_csv(csv_text({"t_s": t[keep], "F_N": 24 * s_noisy[keep], "e": e[keep]}))
    return t[keep], e[keep], s[keep]


def test_a_loaded_first_sample_gives_a_warning_naming_it(write_csv, make_config):
    cropped(write_csv)
    cfg = dict(columns={"time": "t_s", "force": "F_N", "strain": "e"}, strain_measure="nominal")
    test = load_test(make_config(**cfg))
    warn = [n for n in test.notes if n.startswith("warning: the first sample (line 2) carries 231.5 N "
                                                  "(9.694 MPa with area0 = 24 mm²")]
    assert warn and "data.toe: compensate" in warn[0] and "initial_state: ramp-from-zero" in warn[0]
    assert test.virtual_start == 0
    # a test that starts unloaded: no warning
    rng = np.random.default_rng(2)
    t = np.arange(0, 40.0, 0.1)
    e, s = elastic_plastic(t)
    write_csv(csv_text({"t_s": t, "F_N": 24 * (s + rng.normal(0, 0.01, t.size)), "e": e}))
    assert not any("first sample" in n for n in load_test(make_config(**cfg)).notes)


def test_initial_state_ramp_from_zero_prepends_an_unloaded_model_only_sample(write_csv, make_config):
    t, e, s = cropped(write_csv)
    test = load_test(make_config(columns={"time": "t_s", "force": "F_N", "strain": "e"},
                                 strain_measure="nominal", initial_state="ramp-from-zero"))
    assert test.virtual_start == 1 and not test.window[0]
    assert test.strain[0] == 0 and test.stress[0] == 0 and test.force[0] == 0 and test.lines[0] == 0
    assert test.time[0] == pytest.approx(0.0, abs=0.02)            # e = 5e-3 t reaches the first sample
    np.testing.assert_allclose(test.time[1:], t)
    assert test.n_points == t.size                                  # every data row is still compared
    assert not any(n.startswith("warning: the first sample") for n in test.notes)
    assert any("model-only sample at t = " in n for n in test.notes)


@pytest.mark.parametrize("crop", [0.0, 0.005])
def test_toe_compensation_finds_point_b(write_csv, make_config, crop):
    """ASTM D638 X1: the linear part continued to zero stress gives B, the corrected zero strain.
    A slack toe of 0.3 % strain (no stress) before a linear part at 2000 MPa: B at 0.003."""
    t = np.arange(0, 40.0, 0.1)
    e = 5e-3 * t
    s = 30.0 * np.tanh(2000 * np.maximum(e - 0.003, 0) / 30.0)
    keep = e >= crop
    rng = np.random.default_rng(3)
    write_csv(csv_text({"t_s": t[keep], "F_N": 24 * (s + rng.normal(0, 0.01, t.size))[keep], "e": e[keep]}))
    test = load_test(make_config(columns={"time": "t_s", "force": "F_N", "strain": "e"},
                                 strain_measure="nominal", toe="compensate", strain_input="measured"))
    note = next(n for n in test.notes if n.startswith("toe compensation (ASTM D638 X1"))
    b = float(note.split("point B at nominal strain ")[1].split(",")[0])
    # the curve is concave above B: the steepest chord lies a little below the tangent (3 % of B)
    assert b == pytest.approx(0.003, abs=1e-4)
    assert test.strain[0] == 0 and test.stress[0] == 0 and test.virtual_start == 1
    assert test.time[0] == pytest.approx(0.6, abs=0.02)             # B is reached at t = 0.003 / 5e-3
    np.testing.assert_allclose(test.strain[1:], np.log1p(e[keep & (e > b)]) - np.log1p(b), atol=1e-7)
    if crop == 0.0:
        assert any("the 7 sample(s) before B (lines 2-8, the toe) are left out" in n for n in test.notes)


def test_toe_point_with_a_stress_band():
    from bayes_dnlr.config import ToeBand

    e = np.linspace(0, 0.05, 501)
    s = 30.0 * np.tanh(2000 * np.maximum(e - 0.002, 0) / 30.0)
    b, slope, _, _ = toe_point(e, s, ToeBand(stress_min=1.0, stress_max=4.0))
    assert b == pytest.approx(0.002, abs=2e-5) and slope == pytest.approx(2000, rel=0.01)
    with pytest.raises(DataError, match=r"holds 0 sample\(s\) of the rising curve"):
        toe_point(e, s, ToeBand(stress_min=40.0, stress_max=50.0))


# ------------------------------------------------------------------ item 8: percent, or the wrong column


def test_percent_strain_below_147_is_flagged(write_csv, make_config):
    """A pre-yield crop in percent (0..7) read as a fraction: nominal strain 7 is Hencky 2.08 and
    passes the Hencky > 5 check; the initial slope (20 MPa) gives it away."""
    t = np.arange(0, 14.0, 0.02)
    e, s = elastic_plastic(t, 5e-3)
    write_csv(csv_text({"t_s": t, "F_N": 24 * s, "e": 100 * e}))
    cfg = dict(columns={"time": "t_s", "force": "F_N", "strain": "e"}, strain_measure="nominal")
    warn = [n for n in load_test(make_config(**cfg)).notes if "percent" in n]
    assert warn and warn[0].startswith("warning: the initial slope of the nominal stress-strain curve is 20")
    assert re.search(r"set data.strain_unit: percent \(x100 gives (199\d|200\d) MPa\)", warn[0])
    assert not any("percent" in n for n in load_test(make_config(strain_unit="percent", **cfg)).notes)
    assert not any("initial slope" in n for n in load_test(make_config(strain_unit="fraction", **cfg)).notes)


def test_a_time_column_taken_for_strain_gets_the_right_hint(write_csv, make_config):
    """A misaligned header puts time under the strain name: not a percent problem."""
    t = np.arange(0, 600.0, 0.5)
    write_csv(csv_text({"t_s": 0.005 * t, "F_N": 24 * 30 * np.tanh(t / 10), "eps11": t}))
    with pytest.raises(DataError) as err:
        load_test(make_config(strain_input="measured"))
    msg = str(err.value)
    assert "like a time or index column: is data.columns.eps11 the right column" in msg
    assert "percent?" not in msg


def test_a_spike_is_named_by_its_line(write_csv, make_config):
    """One force cell x1000 made the fit fail with 'singular matrix' and no cause."""
    rng = np.random.default_rng(5)
    t = np.arange(0, 40.0, 0.1)
    e, s = elastic_plastic(t)
    F = 24 * (s + rng.normal(0, 0.05, t.size))
    F[150] *= 1000
    write_csv(csv_text({"t_s": t, "F_N": F, "e": e}))
    cfg = dict(columns={"time": "t_s", "force": "F_N", "strain": "e"}, strain_measure="nominal")
    notes = load_test(make_config(**cfg)).notes
    assert any(n.startswith("warning: a spike at line 152: the stress there is 3") for n in notes), notes
    F[150] /= 1000
    write_csv(csv_text({"t_s": t, "F_N": F, "e": e}))
    assert not any("spike" in n for n in load_test(make_config(**cfg)).notes)


def test_a_break_is_named_as_a_break(write_csv, make_config):
    """A specimen that breaks (the force falls and stays down, as the real rHDPE exports end) was
    reported as 'a spike ... a corrupt cell?'. After the window it is a note; inside, a warning."""
    rng = np.random.default_rng(6)
    t = np.arange(0, 40.0, 0.1)
    e, s = elastic_plastic(t)
    F = 24 * (s + rng.normal(0, 0.05, t.size))
    F[380:] = 24 * rng.normal(0.5, 0.05, t.size - 380)          # broken at row 380 (line 382)
    write_csv(csv_text({"t_s": t, "F_N": F, "e": e}))
    cfg = dict(columns={"time": "t_s", "force": "F_N", "strain": "e"}, strain_measure="nominal")
    after = [n for n in load_test(make_config(window={"strain_max": 0.1}, **cfg)).notes
             if "spike" in n or "breaks" in n]
    assert len(after) == 1 and re.fullmatch(r"the specimen breaks at line 382: the stress falls from "
                                            r"3\d\.\d+ to 0\.\d+ MPa and does not climb back, after the "
                                            r"window: the fit does not use it", after[0]), after
    inside = [n for n in load_test(make_config(**cfg)).notes if "breaks" in n]
    assert inside[0].startswith("warning: the specimen breaks at line 382")
    assert "inside the window: the model has no break; end data.window before it" in inside[0]
