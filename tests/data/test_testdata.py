"""Reading tests (data.py): conversions eq. 1-8, checks that name file/line/column, windows,
relaxation_start: auto, the smoothed strain input and the baseline noise."""

from __future__ import annotations

import hashlib
import re

import numpy as np
import pytest

from bayes_dnlr.config import ConfigError, Window
from bayes_dnlr.data import (
    DataError,
    baseline_sd,
    detect_relaxation_start,
    gcv_lambda,
    haward_thackray_strain,
    hencky_from_nominal,
    load_test,
    nominal_from_hencky,
    nominal_from_true_stress,
    nominal_stress,
    ramp_strain_rate,
    sigma_star,
    smooth_segment,
    smooth_strain,
    true_stress,
    window_mask,
)

GOOD = "t_s,F_N,eps11\n0,0,0\n1,24,0.01\n2,48,0.02\n3,60,0.03\n"


def ramp_hold(rate=5e-3, ramp=400.0, hold=600.0, hz=2.0, sd=1e-4, seed=0, jitter=0.0):
    """Time, noise-free and noisy strain of a ramp + hold; the kink is sample k at t = ramp."""
    rng = np.random.default_rng(seed)
    n_r, n_h = round(ramp * hz), round(hold * hz)
    dt = np.ones(n_r + n_h) / hz
    if jitter:
        dt *= 1 + rng.uniform(-jitter, jitter, dt.size)
        dt[:n_r] *= ramp / dt[:n_r].sum()
        dt[n_r:] *= hold / dt[n_r:].sum()
    t = np.concatenate([[0.0], np.cumsum(dt)])
    t[n_r] = ramp
    e = rate * np.minimum(t, ramp)
    return t, e, e + rng.normal(0, sd, t.size), n_r


def csv_text(cols: dict[str, np.ndarray]) -> str:
    rows = np.column_stack(list(cols.values()))
    return ",".join(cols) + "\n" + "\n".join(",".join(f"{v:.10g}" for v in r) for r in rows) + "\n"


# ------------------------------------------------------------------ conversions


def test_hencky_nominal_round_trip_eq1():
    e = np.array([0.0, 0.5, 1.0, 5.0])
    eps = hencky_from_nominal(e)
    assert eps[1] == pytest.approx(np.log(1.5))
    np.testing.assert_allclose(nominal_from_hencky(eps), e, rtol=1e-14)


def test_true_stress_eq2_equals_isovolumic_eq6_when_eps22_is_minus_half_eps11():
    F, S0, eps11 = np.array([100.0, 480.0]), 24.0, np.array([0.1, 1.9])
    np.testing.assert_allclose(true_stress(F, S0, -0.5 * eps11), sigma_star(F, S0, eps11))
    assert sigma_star(F, S0, eps11)[0] == pytest.approx(100 / 24 * np.exp(0.1))
    # a measured eps22 that shrinks less than isovolumic gives a lower true stress
    assert true_stress(F, S0, -0.4 * eps11)[1] < sigma_star(F, S0, eps11)[1]


def test_nominal_stress_and_its_isovolumic_inverse():
    F, S0, eps = np.array([120.0]), 24.0, np.array([0.7])
    assert nominal_stress(F, S0)[0] == 5.0
    np.testing.assert_allclose(nominal_from_true_stress(sigma_star(F, S0, eps), eps), [5.0])


def test_haward_thackray_eq7_8():
    np.testing.assert_allclose(haward_thackray_strain(np.array([0.0, np.log(2.0)])), [0.0, 3.5])


# ------------------------------------------------------------------ reading a good file


def test_reads_every_row_in_order_with_sigma_star(write_csv, make_config):
    path = write_csv(GOOD)
    test = load_test(make_config(strain_input="measured"))
    np.testing.assert_array_equal(test.time, [0, 1, 2, 3])
    np.testing.assert_array_equal(test.strain, [0, 0.01, 0.02, 0.03])
    np.testing.assert_allclose(test.stress, np.array([0, 24, 48, 60]) / 24 * np.exp(test.strain))
    np.testing.assert_allclose(test.nominal_stress, [0, 1, 2, 2.5])
    np.testing.assert_allclose(test.nominal_strain, np.expm1(test.strain))
    assert test.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert test.strain_input is test.strain
    assert test.n_points == 4 and test.model_end == 4 and test.relaxation_start is None
    assert test.strain_rate == pytest.approx(0.01)
    assert test.observable == "sigma_star" and test.area0 == 24.0
    np.testing.assert_array_equal(test.force, [0, 24, 48, 60])


def test_strain_role_nominal_measure_and_stress_column(write_csv, make_config):
    write_csv("time;e;s\n0;0;0\n1;0.1;10\n2;0.2;20\n")
    test = load_test(make_config(columns={"time": "time", "strain": "e", "stress": "s"},
                                 observable="stress", strain_measure="nominal", delimiter=";",
                                 strain_input="measured"))
    np.testing.assert_allclose(test.strain, np.log1p([0, 0.1, 0.2]))
    np.testing.assert_allclose(test.nominal_strain, [0, 0.1, 0.2])
    np.testing.assert_array_equal(test.stress, [0, 10, 20])
    # only a true stress: F/S0 = σ·exp(-ε) (isovolumic)
    np.testing.assert_allclose(test.nominal_stress, [0, 10 / 1.1, 20 / 1.2])
    assert test.force is None
    assert any("nominal -> Hencky" in n for n in test.notes)


def test_sigma_with_measured_eps22(write_csv, make_config):
    write_csv("t,F,e11,e22\n0,0,0,0\n1,24,0.1,-0.04\n2,48,0.2,-0.09\n")
    test = load_test(make_config(columns={"time": "t", "force": "F", "eps11": "e11", "eps22": "e22"},
                                 observable="sigma", strain_input="measured"))
    np.testing.assert_allclose(test.stress, [0, np.exp(0.08), 2 * np.exp(0.18)])
    np.testing.assert_array_equal(test.transverse_strain, [0, -0.04, -0.09])


def test_time_from_strain_rate_without_time_column(write_csv, make_config):
    write_csv("F,e\n0,0\n10,0.01\n20,0.02\n25,0.03\n")
    test = load_test(make_config(columns={"force": "F", "eps11": "e"}, strain_rate=0.005,
                                 strain_input="measured"))
    np.testing.assert_allclose(test.time, [0, 2, 4, 6])
    assert test.strain_rate == pytest.approx(0.005)
    assert any("from strain / strain_rate" in n for n in test.notes)


def test_header_and_cells_may_have_spaces_and_a_bom(write_csv, make_config):
    write_csv("\ufeff t_s , F_N , eps11 \n 0 , 0 , 0 \n1,24,0.01\n2,48,0.02\n\n")
    test = load_test(make_config(strain_input="measured"))
    assert test.time.size == 3  # a trailing blank line is not a row


# ------------------------------------------------------------------ bad input: file, line, column


def test_missing_file_names_the_config_key_and_the_resolved_path(make_config, tmp_path):
    with pytest.raises(DataError) as err:
        load_test(make_config(file="nope.csv"))
    msg = str(err.value)
    assert str(tmp_path / "nope.csv") in msg and "data.file" in msg and "not found" in msg


@pytest.mark.parametrize(("text", "words"), [
    ("", "the file is empty"),
    ("t_s,F_N,eps11\n", "0 data row(s)"),
    ("t_s,F_N,eps11\n0,0,0\n1,2,0.1\n", "2 data row(s) after the header; at least 3"),
])
def test_empty_or_short_file(write_csv, make_config, text, words):
    path = write_csv(text)
    with pytest.raises(DataError) as err:
        load_test(make_config())
    assert str(path) in str(err.value) and words in str(err.value)


def test_column_not_in_header_lists_the_headers(write_csv, make_config):
    path = write_csv("time,F_N,eps11\n0,0,0\n1,1,0.1\n2,2,0.2\n")
    with pytest.raises(DataError) as err:
        load_test(make_config())
    msg = str(err.value)
    assert f"{path}, line 1: column 't_s' (data.columns.time) is not in the header" in msg
    assert "'time', 'F_N', 'eps11'" in msg


def test_headerless_file_gets_a_hint(write_csv, make_config):
    write_csv("0,0,0\n1,1,0.1\n2,2,0.2\n")
    with pytest.raises(DataError, match="the file has no header row .*: give the columns by number"):
        load_test(make_config())


def test_headerless_file_with_column_numbers_and_percent_strain(write_csv, make_config):
    # a machine export: index, time, force, nominal strain in percent; no header row
    path = write_csv("7,0,0,0\n8,1,24,1\n9,2,48,2\n10,3,60,3\n")
    test = load_test(make_config(header=False, columns={"time": 2, "force": 3, "strain": 4},
                                 strain_unit="percent", strain_measure="nominal", strain_input="measured"))
    np.testing.assert_array_equal(test.time, [0, 1, 2, 3])
    np.testing.assert_allclose(test.strain, np.log1p([0, 0.01, 0.02, 0.03]))
    np.testing.assert_allclose(test.nominal_stress, [0, 1, 2, 2.5])
    write_csv("0,0,0,0\n1,24,x,1\n2,48,0.02,2\n3,60,0.03,3\n")
    with pytest.raises(DataError, match=rf"{path}, line 2, column 'column 3' \(force\): cell 'x'"):
        load_test(make_config(header=False, columns={"time": 1, "force": 3, "eps11": 4}))
    with pytest.raises(DataError, match=r"column 9 \(data.columns.force\) does not exist: the rows have 4"):
        load_test(make_config(header=False, columns={"time": 1, "force": 9, "eps11": 4}))


@pytest.mark.parametrize(("data", "words"), [
    ({"header": False}, "header: false needs every column as a number counted from 1"),
    ({"header": False, "columns": {"time": 0, "force": 2, "eps11": 3}}, "greater than or equal to 1"),
    ({"strain_unit": "permille"}, "'fraction' or 'percent'"),
    ({"delimiter": ";;"}, "must be one character, 'tab' or 'whitespace'"),
    ({"delimiter": "1"}, "'1' cannot separate numbers"),
    ({"decimal": ";"}, "'.' or ','"),
    ({"encoding": "klingon"}, "unknown text encoding 'klingon'"),
    ({"units": {"force": "kg"}}, "force: unit 'kg' is not a unit of force"),
    ({"units": {"eps11": "mm"}}, "eps11: unit 'mm' is not a unit of strain"),
    ({"units": {"speed": "mm/s"}}, "unknown role 'speed'"),
    ({"rows": {"first": 5, "last": 2}}, "last (2) must not be smaller than first (5)"),
    ({"rows": {"first": 0}}, "greater than or equal to 1"),
    ({"specimen_columns": 5}, "specimen_columns needs specimen"),
    ({"specimen": 0}, "greater than or equal to 1"),
    ({"toe": "compensate", "initial_state": "first-sample"}, "initial_state: first-sample contradicts it"),
    ({"toe": {"stress_min": 5, "stress_max": 2}}, "stress_min (5.0) must be smaller than stress_max"),
    ({"columns": {"time": "t", "force": "F", "extension": "x"}}, "an extension column needs gauge_length"),
    ({"columns": {"time": "t", "force": "F", "eps11": "e", "extension": "x"}, "gauge_length": 50},
     "give the axial strain once"),
])
def test_data_keys_are_checked_in_the_config(make_config, data, words):
    with pytest.raises(ConfigError, match=re.escape(words)):
        make_config(**data)


def test_columns_by_number_in_a_file_with_a_header(write_csv, make_config):
    # a header row no longer forbids numbered columns: the header is recognised and skipped
    write_csv(GOOD)
    test = load_test(make_config(columns={"time": 1, "force": 2, "eps11": 3}, strain_input="measured"))
    np.testing.assert_array_equal(test.time, [0, 1, 2, 3])
    assert any("header line 1" in n for n in test.notes)


def test_duplicate_header(write_csv, make_config):
    write_csv("t_s,F_N,eps11,F_N\n0,0,0,0\n1,1,0.1,1\n2,2,0.2,2\n")
    with pytest.raises(DataError, match=r"column 'F_N' \(data.columns.force\) appears 2 times"):
        load_test(make_config())


@pytest.mark.parametrize(("cell", "column", "words"), [
    ("abc", "F_N", "cell 'abc' is not a number"),
    ("nan", "F_N", "cell 'nan' is not a finite number"),
    ("-inf", "eps11", "cell '-inf' is not a finite number"),
    ("", "t_s", "cell '' is not a number (empty cell)"),
    ('"0,5"', "eps11", "decimal comma"),
])
def test_bad_cell_names_file_line_column_and_text(write_csv, make_config, cell, column, words):
    cells = {"t_s": "2", "F_N": "48", "eps11": "0.02"}
    cells[column] = cell
    path = write_csv(GOOD.replace("2,48,0.02", ",".join(cells.values())))
    with pytest.raises(DataError) as err:
        load_test(make_config())
    msg = str(err.value)
    assert f"{path}, line 4, column '{column}'" in msg, msg
    assert words in msg


def test_time_not_increasing_gives_both_lines_and_values(write_csv, make_config):
    path = write_csv("t_s,F_N,eps11\n0,0,0\n1,1,0.01\n0.5,2,0.02\n3,3,0.03\n")
    with pytest.raises(DataError) as err:
        load_test(make_config())
    msg = str(err.value)
    assert f"{path}, column 't_s'" in msg and "increase strictly" in msg
    assert "line 3 has 1 and line 4 has 0.5" in msg


def test_repeated_time_is_refused(write_csv, make_config):
    write_csv("t_s,F_N,eps11\n0,0,0\n1,1,0.01\n1,2,0.02\n3,3,0.03\n")
    with pytest.raises(DataError, match="line 3 has 1 and line 4 has 1"):
        load_test(make_config())


def test_strain_not_increasing_without_time_column(write_csv, make_config):
    path = write_csv("F,e\n0,0\n1,0.02\n2,0.015\n3,0.03\n")
    with pytest.raises(DataError) as err:
        load_test(make_config(columns={"force": "F", "eps11": "e"}, strain_rate=0.01))
    msg = str(err.value)
    assert f"{path}, column 'e'" in msg and "strictly increasing strain" in msg
    assert "line 3 has 0.02 and line 4 has 0.015" in msg


def test_row_with_wrong_field_count(write_csv, make_config):
    path = write_csv("t_s,F_N,eps11\n0,0,0\n1,1\n2,2,0.02\n")
    with pytest.raises(DataError, match=f"{path}, line 3: 2 fields, but the header"):
        load_test(make_config())


def test_blank_line_between_rows_is_an_error_not_a_skip(write_csv, make_config):
    write_csv("t_s,F_N,eps11\n0,0,0\n\n1,1,0.01\n2,2,0.02\n")
    with pytest.raises(DataError, match="line 3: empty line between data rows"):
        load_test(make_config())


def test_nominal_strain_below_minus_one(write_csv, make_config):
    path = write_csv("t_s,F_N,eps11\n0,0,0\n1,1,-1.0\n2,2,0.02\n")
    with pytest.raises(DataError) as err:
        load_test(make_config(strain_measure="nominal"))
    assert f"{path}, line 3, column 'eps11'" in str(err.value) and "<= -1" in str(err.value)


def test_strain_in_percent_is_refused(write_csv, make_config):
    write_csv("t_s,F_N,eps11\n0,0,0\n1,1,5\n2,2,10\n")
    with pytest.raises(DataError, match=r"line 4, column 'eps11'.*percent\? set data.strain_unit: percent"):
        load_test(make_config(strain_input="measured"))


def test_non_positive_area_is_a_config_error_naming_data_area0(make_config):
    with pytest.raises(ConfigError, match=r"data\.area0: must be a positive cross-section"):
        make_config(area0=0.0)


def test_stress_column_with_sigma_star_names_data_observable(make_config):
    with pytest.raises(ConfigError) as err:
        make_config(columns={"time": "t", "eps11": "e", "stress": "s"})
    msg = str(err.value)
    assert "data.observable: 'sigma_star' (eq. 6) is computed from the force" in msg
    assert "observable: stress" in msg
    # with a force column too, sigma_star is fine
    make_config(columns={"time": "t", "eps11": "e", "stress": "s", "force": "F"})


# ------------------------------------------------------------------ windows


def test_window_is_contiguous_and_stops_at_first_breach():
    t = np.arange(7.0)
    e = np.array([0.0, 0.1, 0.2, 0.3, 0.2, 0.1, 0.05])
    mask = window_mask(t, e, Window(strain_min=0.05, strain_max=0.25), min_points=1)
    np.testing.assert_array_equal(mask, [0, 1, 1, 0, 0, 0, 0])
    mask = window_mask(t, e, Window(time_min=2, time_max=5.5))
    np.testing.assert_array_equal(mask, [0, 0, 1, 1, 1, 1, 0])


def test_interval_I_and_window_from_config(write_csv, make_config):
    t = np.linspace(0, 60, 301)
    e = 5e-3 * t
    write_csv(csv_text({"t_s": t, "F_N": 24 * 1000 * e, "eps11": e}))
    test = load_test(make_config(window={"strain_max": 0.13}, strain_input="measured"))
    assert test.strain[test.window].max() <= 0.13 < test.strain[test.model_end]
    assert test.window[0] and test.n_points == int(np.sum(e <= 0.13))


def test_empty_window_names_bounds_and_data_ranges(write_csv, make_config):
    path = write_csv(GOOD)
    with pytest.raises(DataError) as err:
        load_test(make_config(window={"strain_min": 0.025, "time_max": 2.5}, strain_input="measured"))
    msg = str(err.value)
    assert f"{path}: data.window {{strain_min: 0.025, time_max: 2.5}} selects 0 sample(s)" in msg
    assert "input strain spans 0 to 0.03" in msg and "time 0 to 3 s" in msg


@pytest.mark.parametrize(("window", "bad"), [
    ({"strain_max": 0.5}, "strain_max: 0.5"),
    ({"strain_min": 0.2}, "strain_min: 0.2"),
    ({"time_max": -1.0}, "time_max: -1"),
    ({"time_min": 10.0}, "time_min: 10"),
])
def test_window_bound_outside_the_data(write_csv, make_config, window, bad):
    write_csv(GOOD)
    with pytest.raises(DataError, match=f"data.window {bad} lies outside the data"):
        load_test(make_config(window=window, strain_input="measured"))


# ------------------------------------------------------------------ relaxation_start


@pytest.mark.parametrize(("seed", "rate", "jitter"), [(0, 5e-3, 0.0), (1, 5e-3, 0.15), (2, 1e-2, 0.0),
                                                      (3, 2.5e-3, 0.1), (4, 5e-3, 0.0)])
def test_auto_relaxation_start_within_two_samples_of_the_kink(seed, rate, jitter):
    t, _, noisy, k = ramp_hold(rate=rate, ramp=2.0 / rate, seed=seed, jitter=jitter)
    assert abs(detect_relaxation_start(t, noisy) - k) <= 2


@pytest.mark.parametrize("seed", [5, 6])
def test_auto_relaxation_start_at_constant_crosshead_speed(seed):
    """A machine drives the crosshead at constant speed: the nominal strain is linear in time and
    the Hencky strain bends; a line through the whole ramp met the hold four samples early (E off
    by 12 %). The start comes from the ramp's last part."""
    rate = 50.0 / 60.0 / 115.0                    # 50 mm/min on a 115 mm grip distance
    t = np.linspace(0.0, 100.0, 400)
    k = int(np.argmin(np.abs(t - 0.3 / rate)))
    t[k] = 0.3 / rate
    e = np.log1p(np.minimum(rate * t, 0.3)) + np.random.default_rng(seed).normal(0, 1e-5, t.size)
    assert abs(detect_relaxation_start(t, e) - k) <= 1


def test_auto_relaxation_start_through_load_test(write_csv, make_config):
    t, _, noisy, k = ramp_hold(seed=7)
    write_csv(csv_text({"t_s": t, "F_N": 24 * (100 + 0 * t), "eps11": noisy}))
    test = load_test(make_config(relaxation_start="auto"))
    assert abs(test.relaxation_start - 400.0) <= 1.0  # 2 Hz: within two samples
    assert any(n.startswith("relaxation_start: auto -> ") and "(detected)" in n for n in test.notes)
    assert test.strain_rate == pytest.approx(5e-3, rel=1e-3)


def test_auto_without_hold_is_an_error(write_csv, make_config):
    path = write_csv(GOOD)
    with pytest.raises(DataError) as err:
        load_test(make_config(relaxation_start="auto", strain_input="measured"))
    assert f"{path}: data.relaxation_start: auto:" in str(err.value)


def test_relaxation_start_outside_the_test(write_csv, make_config):
    write_csv(GOOD)
    with pytest.raises(DataError, match=r"data.relaxation_start 50 s lies outside the test"):
        load_test(make_config(relaxation_start=50.0, strain_input="measured"))


def test_ramp_strain_rate_ignores_the_hold():
    t, e, _, _ = ramp_hold()
    assert ramp_strain_rate(t, e, 400.0) == pytest.approx(5e-3, rel=1e-12)
    assert ramp_strain_rate(t, e, None) < 4e-3


# ------------------------------------------------------------------ smoothing the strain input


def test_state_space_spline_is_scipys_smoothing_spline_and_gcv_is_exact():
    """The Kalman/RTS spline equals make_smoothing_spline at the same λ; its GCV λ minimises the
    exact GCV criterion (dense hat matrix) and is within 1 % of scipy's own GCV choice."""
    from scipy.interpolate import make_smoothing_spline

    from bayes_dnlr.data.smoothing import PRIOR_VAR, _kernel

    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(0, 50, 300))
    y = 3e-3 * x + 0.02 * np.sin(x / 5) + rng.normal(0, 1e-4, x.size)
    fit, lam = smooth_segment(x, y)
    np.testing.assert_allclose(fit, make_smoothing_spline(x, y, lam=lam)(x), rtol=0, atol=1e-9)
    assert gcv_lambda(x, y) == pytest.approx(lam, rel=1e-12)

    def hat(lam_):
        """The dense hat matrix: column j is the spline of the unit vector e_j at x. A scipy that takes
        a 2-D y smooths every column in one call (the same matrix, bit for bit, 150x faster)."""
        eye = np.eye(x.size)
        try:
            return make_smoothing_spline(x, eye, lam=lam_)(x)
        except ValueError:                  # scipy before y of shape (n, ...): a vector at a time
            return np.column_stack([make_smoothing_spline(x, e, lam=lam_)(x) for e in eye])

    def exact_gcv(H):
        n = x.size
        r = y - H @ y
        return n * (r @ r) / (n - np.trace(H)) ** 2

    H = hat(lam)
    assert exact_gcv(H) <= min(exact_gcv(hat(lam * 0.97)), exact_gcv(hat(lam * 1.03)))
    h = np.median(np.diff(x))
    u = (x - x[0]) / h
    tr = _kernel()(u, np.zeros_like(u), h**3 / lam, PRIOR_VAR, np.empty_like(u))
    assert tr == pytest.approx(np.trace(H), rel=1e-8)
    ref = make_smoothing_spline(x, y)(x)
    assert np.abs(fit - ref).max() < 1e-6          # scipy's choice: the same spline to 1 % of the noise


def test_smoothing_a_million_samples_is_linear_and_does_not_fail():
    """scipy's make_smoothing_spline's GCV fails on 1e6 samples ('ill-posed'); the state-space
    spline smooths a straight ramp to a straight line, to a small fraction of the noise."""
    rng = np.random.default_rng(0)
    t = np.arange(1_000_000) * 1e-3
    e = 8e-3 * t + rng.normal(0, 1e-4, t.size)
    fit, lams = smooth_strain(t, e)
    assert np.sqrt(np.mean((fit - 8e-3 * t) ** 2)) < 5e-6
    assert lams == [np.inf]


def test_sparse_hold_is_not_fitted_to_its_noise():
    """A hold sampled every 0.2 s, then every 180 s. One spline over both follows
    the noise of the sparse samples (the model stress then jumps between them); split where the
    sampling changes, each part gets its own λ and the sparse part is smoothed."""
    rng = np.random.default_rng(4)
    ramp = np.arange(0, 400.0, 0.2)
    dense = 400.0 + np.arange(1, 1501) * 0.2
    sparse = dense[-1] + np.arange(1, 41) * 180.0
    t = np.concatenate([ramp, dense, sparse])
    # the crosshead settles after the ramp: a small decaying overshoot, which a spline must follow
    truth = 5e-3 * np.minimum(t, 400.0) + 5e-4 * np.where(t > 400, np.exp(-(t - 400) / 10.0), 0.0)
    e = truth + rng.normal(0, 1e-4, t.size)
    k = ramp.size
    from bayes_dnlr.data.smoothing import sampling_breaks

    breaks = sampling_breaks(t, [k])
    assert breaks == [k + dense.size - 1]        # the last sample 0.2 s after its neighbour
    smooth, _ = smooth_strain(t, e, [k, *breaks])
    tail = slice(k + dense.size, None)
    rms = np.sqrt(np.mean((smooth[tail] - truth[tail]) ** 2))
    assert rms < 0.35e-4                                       # the sparse hold: well below the noise 1e-4
    one, _ = smooth_strain(t, e, [k])
    assert np.sqrt(np.mean((one[tail] - truth[tail]) ** 2)) > 0.7e-4   # before: it followed the noise


def test_smoothed_strain_is_much_closer_to_the_truth_and_keeps_the_kink():
    t, e, noisy, k = ramp_hold(seed=11)
    smooth, lams = smooth_strain(t, noisy, [k])
    err = smooth - e
    rms_raw = np.sqrt(np.mean((noisy - e) ** 2))
    rms = np.sqrt(np.mean(err**2))
    assert rms_raw == pytest.approx(1e-4, rel=0.1)
    assert rms < 3e-5
    assert np.abs(err[k - 5:k + 6]).max() < 6e-5        # the kink survives
    assert len(lams) == 2
    one_piece, _ = smooth_strain(t, noisy)
    assert np.abs(one_piece - e)[k - 5:k + 6].max() > 3 * np.abs(err[k - 5:k + 6]).max()


def test_smoothed_is_the_default_and_measured_keeps_the_raw_strain(write_csv, make_config):
    t, e, noisy, _ = ramp_hold(hold=0.0, seed=5)
    write_csv(csv_text({"t_s": t, "F_N": 2400 * e, "eps11": noisy}))
    smoothed = load_test(make_config())
    measured = load_test(make_config(strain_input="measured"))
    np.testing.assert_array_equal(smoothed.strain, measured.strain)
    np.testing.assert_allclose(measured.strain_input, noisy, rtol=1e-9)  # as written (%.10g)
    assert np.sqrt(np.mean((smoothed.strain_input - e) ** 2)) < 0.3 * np.sqrt(np.mean((noisy - e) ** 2))
    assert any("strain_input: smoothed" in n for n in smoothed.notes)


def test_26000_rows_load(write_csv, make_config):
    """A long record loads whole with data.reduce: none (its speed is measured in benchmarks/, not
    asserted here)."""
    rng = np.random.default_rng(0)
    t = np.arange(26000) * 0.02
    e = 8e-3 * t + rng.normal(0, 1e-4, t.size)
    write_csv(csv_text({"t_s": t, "F_N": 900 * np.tanh(3 * e), "eps11": e}))
    test = load_test(make_config(reduce="none"))
    assert test.time.size == 26000
    # the default (data.reduce: auto) averages pairs of rows past 20000 rows, and says so
    test = load_test(make_config())
    assert test.time.size == 1 + 25999 // 2 + 1 and test.rows_per_point == 2
    assert any(n.startswith("data.reduce (auto): 26000 rows averaged in bins of 2") for n in test.notes)


# ------------------------------------------------------------------ baseline noise


def test_baseline_sd_detrends_and_estimates_the_noise(write_csv, make_config):
    rng = np.random.default_rng(2)
    t = np.linspace(0, 10, 1001)
    e = np.where(t < 4, 0.0, 5e-3 * (t - 4))
    # σ* = drift + noise 0.3, then the load (1000 MPa × strain, to 30 MPa)
    F = 24 * (0.5 + 0.2 * t + 1000 * e + rng.normal(0, 0.3, t.size)) * np.exp(-e)
    write_csv(csv_text({"t_s": t, "F_N": F, "eps11": e}))
    test = load_test(make_config(strain_input="measured"))
    assert baseline_sd(test, Window(time_max=4.0)) == pytest.approx(0.3, rel=0.12)


def test_baseline_needs_ten_samples(write_csv, make_config):
    path = write_csv(GOOD)
    test = load_test(make_config(strain_input="measured"))
    with pytest.raises(DataError) as err:
        baseline_sd(test, Window(time_max=2.0))
    msg = str(err.value)
    assert f"{path}: noise.sigma0.baseline {{time_max: 2}} selects 3 sample(s), at least 10" in msg


@pytest.mark.parametrize(("rs", "segments"), [(18.5, 1), (10.0, 2), (0.5, 2)])
def test_smoothing_segments_follow_relaxation_start(write_csv, make_config, rs, segments):
    t = np.arange(20.0)
    write_csv(csv_text({"t_s": t, "F_N": t, "eps11": 0.01 * np.minimum(t, rs)}))
    test = load_test(make_config(relaxation_start=rs))
    note = next(n for n in test.notes if n.startswith("strain_input: smoothed"))
    assert note.count(" s: ") == segments
    assert test.relaxation_start == rs


@pytest.mark.parametrize(("window", "words"), [
    ({"time_max": 2.0}, "the specimen is loaded there: the strain rises by 5e-05 across the window "
                        "(from 0 to 5e-05); the test loads from its first sample"),
    ({"time_min": 500.0, "time_max": 600.0}, "the stress there is not an unloaded baseline: it sits at 15."),
])
def test_baseline_over_a_loaded_specimen_is_refused(write_csv, make_config, window, words):
    """{baseline: {time_max: 2.0}} on a test loading from t = 0 gave 0.087 MPa,
    100 times the noise; a baseline in the hold of a relaxation test measures the relaxation."""
    t, e, _, _ = ramp_hold(rate=2.5e-5, hold=600.0, hz=20.0, sd=0.0)
    stress = 2000 * e * (1 - 0.3 * (t > 400) * (1 - np.exp(-(t - 400) / 100)))
    write_csv(csv_text({"t_s": t, "F_N": 24 * stress * np.exp(-e), "eps11": e}))
    test = load_test(make_config(strain_input="measured"))
    with pytest.raises(DataError) as err:
        baseline_sd(test, Window(**window))
    assert "noise.sigma0.baseline {" in str(err.value) and words in str(err.value), str(err.value)


def test_a_smoothing_is_kept_by_the_digest_of_its_inputs(tmp_path, monkeypatch):
    """The second command with the same samples reads the first one's smoothing, bit for bit; other
    samples are smoothed anew; no cache folder appears where its parent does not exist."""
    from bayes_dnlr.data import smoothing

    t = np.linspace(0.0, 100.0, 400)
    e = 1e-3 * t + np.random.default_rng(4).normal(0.0, 1e-4, t.size)
    first = smoothing.smooth_strain(t, e, [200], tmp_path / ".cache")
    assert len(list((tmp_path / ".cache").glob("strain-*.npz"))) == 1

    def no_search(*args, **kw):
        raise AssertionError("searched again")

    monkeypatch.setattr(smoothing, "_search", no_search)
    again = smoothing.smooth_strain(t, e, [200], tmp_path / ".cache")
    np.testing.assert_array_equal(again[0], first[0])
    assert again[1] == first[1]
    with pytest.raises(AssertionError, match="searched again"):
        smoothing.smooth_strain(t, e + 1e-6, [200], tmp_path / ".cache")
    monkeypatch.undo()
    smoothing.smooth_strain(t, e, [200], tmp_path / "absent" / ".cache")
    assert not (tmp_path / "absent").exists()
