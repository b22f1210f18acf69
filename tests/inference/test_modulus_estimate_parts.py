"""The parts of the E(t) estimator (inference/modulus_estimate.py) at their edges: the model's mode
count and decades carried everywhere, the parameters a test does not have, a temperature law's
factor and slopes, the Laplace draws of an awkward covariance, the exponent's pull followed or not,
the checks' numbers, and the rows and curve that fit.json and summary.json carry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayes_dnlr.inference.checks.band import Band, band_check
from bayes_dnlr.inference.checks.start import StartCheck
from bayes_dnlr.inference.modulus_estimate import (
    INFORMATIVE,
    LOG_SLOPES,
    SHIFT_FACTOR,
    STRESS_MOVE_Z,
    AtTemperature,
    BoundRefit,
    ExponentSpread,
    LocalEstimate,
    Source,
    StressPull,
    apply_spread,
    bound_moves,
    draw_stats,
    estimate,
    exponent_spread,
    fit_source,
    followed,
    gradient,
    local_check,
    modulus_draws,
    posterior_source,
    stress_check,
    stress_pull,
    width_check,
)
from bayes_dnlr.inference.modulus_window import ResolvedWindow
from bayes_dnlr.model.modulus import relaxation_modulus
from bayes_dnlr.model.shift import log_temperature_shift

POINT = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
WINDOW = ResolvedWindow(shortest=0.8, longest=380.0, origin=0.0, step=0.4, how="two steps")
MODES, DECADES = 20, 4.0          # a model other than the default 50 modes over 6 decades
ARRHENIUS = AtTemperature("arrhenius", 20.0, 40.0)


def E_t(t, E=2854.0, G=2.32, tau_max=5.79, alpha=0.5, modes=MODES, decades=DECADES, a_t=1.0):
    return relaxation_modulus(np.atleast_1d(t), E, G, tau_max, alpha, modes, decades, shift_factor=a_t)


# ---------------------------------------------------------------- E(t), its gradient, its draws

def test_e_t_follows_the_model_s_modes_and_decades_and_a_missing_g_is_zero():
    times = [0.5, 50.0, 5000.0]
    with_alpha = {**POINT, "alpha": 0.3, SHIFT_FACTOR: 2.0}
    np.testing.assert_allclose(modulus_draws(with_alpha, times, MODES, DECADES)[0],
                               E_t(times, alpha=0.3, a_t=2.0), rtol=1e-12)
    no_g = {"E": 2854.0, "tau_max": 5.79}
    np.testing.assert_allclose(modulus_draws(no_g, times, MODES, DECADES)[0], E_t(times, G=0.0),
                               rtol=1e-12)


def test_the_gradient_follows_the_model_s_modes_and_decades_and_a_missing_g_is_zero():
    names = ["E", "G", "tau_max", "alpha"]
    point = {"E": 2854.0, "tau_max": 5.79, "alpha": 0.45}
    times = [0.3, 7.0, 60.0]
    g = gradient(point, names, times, MODES, DECADES)
    full = {**point, "G": 0.0}
    for j, k in enumerate(names):
        h = 1e-6 * max(abs(full[k]), 1.0)

        def at(v, k=k):
            p = {**full, k: v}
            return E_t(times, p["E"], p["G"], p["tau_max"], p["alpha"])

        np.testing.assert_allclose(g[:, j], (at(full[k] + h) - at(full[k] - h)) / (2 * h),
                                   rtol=1e-5, atol=1e-9)


def test_draw_stats_of_one_two_and_many_draws():
    assert draw_stats(np.array([1.0, 2.0, 3.0])) == {"mean": 2.0, "sd": 1.0, "median": 2.0,
                                                      "hdi_90": [1.0, 3.0]}
    assert draw_stats(np.array([1.0, 3.0]))["sd"] == pytest.approx(math.sqrt(2.0))
    assert draw_stats(np.array([5.0])) == {"mean": 5.0, "sd": 0.0, "median": 5.0, "hdi_90": [5.0, 5.0]}


# ---------------------------------------------------------------- a test's temperature

def test_the_temperature_laws_log_slopes_are_the_derivatives_of_ln_a_t():
    for law, params in (("arrhenius", {"Ea": 250.0}), ("wlf", {"C1": 17.4, "C2": 51.6})):
        at = AtTemperature(law, 20.0, 45.0)
        slopes = at.log_slopes(params)
        assert set(slopes) == set(params)
        for k, v in params.items():
            h = 1e-6 * v

            def ln_a(x, k=k, law=law, params=params):
                return float(log_temperature_shift(45.0, law, 20.0, **{**params, k: x}))

            assert slopes[k] == pytest.approx((ln_a(v + h) - ln_a(v - h)) / (2 * h), rel=1e-6)
    assert AtTemperature("wlf", 20.0, 20.0).log_slopes({"C1": 17.4, "C2": 51.6}) == {}


def test_a_source_at_another_temperature_carries_a_t_and_its_slopes():
    rng = np.random.default_rng(1)
    ea = rng.normal(250.0, 5.0, 200)
    source = posterior_source({"E": rng.normal(2854.0, 5.0, 200), "Ea": ea}, {"tau_max": 5.79}, True,
                              None, False)
    columns = source.columns(ARRHENIUS)
    np.testing.assert_allclose(columns[SHIFT_FACTOR],
                               np.exp(log_temperature_shift(40.0, "arrhenius", 20.0, Ea=ea)))
    assert columns["G"] == 0.0 and columns["alpha"] == 0.5 and columns["tau_max"] == 5.79
    assert SHIFT_FACTOR not in source.columns() and SHIFT_FACTOR not in source.columns(AtTemperature())
    point = source.point(ARRHENIUS)
    median_ea = float(np.median(ea))
    assert point[SHIFT_FACTOR] == pytest.approx(
        math.exp(log_temperature_shift(40.0, "arrhenius", 20.0, Ea=median_ea)))
    assert point[LOG_SLOPES] == pytest.approx(ARRHENIUS.log_slopes({"Ea": median_ea}))
    assert SHIFT_FACTOR not in source.point() and LOG_SLOPES not in source.point(AtTemperature())


# ---------------------------------------------------------------- the two sources

def test_a_posterior_source_says_what_it_is():
    s = posterior_source({"E": [[1.0, 2.0], [3.0, 4.0]]}, {"G": 2}, 1, None, 1)
    assert s.kind == "posterior" and s.under_model_error is True and s.converged is True
    assert s.draws["E"].tolist() == [1.0, 2.0, 3.0, 4.0] and s.fixed == {"G": 2} and s.lacks == {}
    assert posterior_source({"E": [1.0]}, {}, 0, None, 0).under_model_error is False


def test_a_fit_source_says_what_it_is_and_draws_e_normal_about_its_estimate():
    s = fit_source({"E": 2000.0, "tau_max": 0.5}, np.diag([1000.0**2, 0.5**2]), ["E", "tau_max"],
                   {"G": 1.0, "E": 5.0}, 1, 1, n=20000)
    assert s.kind == "fit" and s.converged is True and s.under_model_error is True
    assert s.fixed == {"G": 1.0} and s.log_prior is None
    e = s.draws["E"]
    # E as the fit reports it: normal, so its mean is the estimate and some draws lie below 0
    assert e.mean() == pytest.approx(2000.0, abs=4 * 1000.0 / math.sqrt(e.size))
    assert e.std() == pytest.approx(1000.0, rel=0.03) and e.min() < 0
    # a time constant below 1 s, as wide as its value, still in log space: never negative
    assert s.draws["tau_max"].min() > 0
    assert np.median(s.draws["tau_max"]) == pytest.approx(0.5, rel=0.03)
    assert fit_source({"E": 1.0}, None, ["E"], {}, 0, 0).converged is False


def test_a_fit_without_a_covariance_draws_its_estimate():
    s = fit_source({"E": 2000.0, "tau_max": 5.0}, None, ["E", "tau_max"], {}, True, False, n=10)
    assert s.draws["E"].tolist() == [2000.0] * 10
    np.testing.assert_allclose(s.draws["tau_max"], 5.0, rtol=1e-12)


def test_infinite_and_negative_directions_of_a_covariance_add_no_spread():
    inf = math.inf
    # an entry that is not finite counts as 0; a negative eigenvalue (round-off) as 0
    cov = np.array([[25.0, -inf], [inf, np.nan]])
    s = fit_source({"E": 2000.0, "G": 2.0}, cov, ["E", "G"], {}, True, False, n=4000)
    assert s.draws["E"].std() == pytest.approx(5.0, rel=0.05) and np.all(s.draws["G"] == 2.0)
    s = fit_source({"E": 2000.0, "G": 2.0}, np.array([[-inf, 0.0], [0.0, inf]]), ["E", "G"], {},
                   True, False, n=10)
    assert np.all(s.draws["E"] == 2000.0) and np.all(s.draws["G"] == 2.0)
    s = fit_source({"E": 2000.0, "G": 2.0}, np.array([[1.0, 2.0], [2.0, 1.0]]), ["E", "G"], {},
                   True, False, n=4000)
    # eigenvalues 3 and -1: the draws spread along (1, 1) only, sd sqrt(3/2) each
    assert np.all(np.isfinite(s.draws["E"]))
    np.testing.assert_allclose(s.draws["E"] - 2000.0, s.draws["G"] - 2.0, atol=1e-9)
    assert s.draws["E"].std() == pytest.approx(math.sqrt(1.5), rel=0.05)


def test_a_time_constant_the_fit_cannot_place_is_drawn_finite_and_positive():
    s = fit_source({"sigma_s": 1.0}, np.array([[1e8]]), ["sigma_s"], {}, True, False, n=400)
    x = s.draws["sigma_s"]
    assert np.all(np.isfinite(x)) and np.all(x > 0) and x.max() > 1e300 and x.min() < 1e-300


# ---------------------------------------------------------------- the exponent's spread and pull

FIT = {"spectrum_exponent": {"sampled": False, "derivative": {"E": -2900.0, "tau_max": 3.0},
                             "score": {"sd": 0.05, "step": 0.012}},
       "discrepancy": {"alpha_score": {"sd": 0.2, "step": -0.03}}}


def test_the_spread_reads_the_score_s_sd_and_step():
    s = exponent_spread(FIT, False)
    assert (s.alpha_sd, s.derivative, s.step) == (0.05, {"E": -2900.0, "tau_max": 3.0}, 0.012)
    assert exponent_spread(FIT, True).step == -0.03
    no_step = {**FIT, "spectrum_exponent": {**FIT["spectrum_exponent"], "score": {"sd": 0.05}}}
    assert exponent_spread(no_step, False).step == 0.0
    for score in (None, {"sd": math.inf}, {"sd": math.nan}, {"sd": 0.0}):
        block = {**FIT["spectrum_exponent"], "score": score}
        assert exponent_spread({"spectrum_exponent": block}, False) is None


def test_the_pull_moves_e_t_along_the_refit_path_linearized():
    times = [0.5, 5.0, 50.0]
    point = {"E": 2854.0, "G": 2.32, "tau_max": 5.79, "alpha": 0.3, SHIFT_FACTOR: 2.0}
    spread = ExponentSpread(0.05, {"E": -2900.0, "G": 4.0, "tau_max": 3.0}, 0.02)
    np.testing.assert_allclose(spread.move(point, times, MODES, DECADES),
                               spread.slope(point, times, MODES, DECADES) * 0.02, rtol=1e-12)
    # the slope is the path's: dE(t)/dα plus each parameter's gradient times its d β*/dα
    h = 1e-6
    ahead = E_t(times, E=2854.0 - 2900.0 * h, G=2.32 + 4.0 * h, tau_max=5.79 + 3.0 * h,
                alpha=0.3 + h, a_t=2.0)
    behind = E_t(times, E=2854.0 + 2900.0 * h, G=2.32 - 4.0 * h, tau_max=5.79 - 3.0 * h,
                 alpha=0.3 - h, a_t=2.0)
    np.testing.assert_allclose(spread.slope(point, times, MODES, DECADES), (ahead - behind) / (2 * h),
                               rtol=1e-5)
    # the pull stays inside the family's [0, 1]: a step of 0.9 from ½ pulls by ½
    far = ExponentSpread(0.05, {"E": -2900.0}, 0.9)
    np.testing.assert_allclose(far.move(POINT, times, MODES, DECADES),
                               far.slope(POINT, times, MODES, DECADES) * 0.5, rtol=1e-12)


def test_the_pull_is_followed_only_where_it_stays_within_the_spread():
    rng = np.random.default_rng(4)
    times = [0.5, 5.0]
    # held tightly at 0.5 s, loosely at 5 s: the same pull is too far at one and not the other
    held = E_t(times) * (1 + np.array([1e-3, 3e-2]) * rng.standard_normal((400, 2)))
    spread = ExponentSpread(0.05, {"E": -2900.0}, 0.15)
    point = dict(POINT)
    added = spread.added_sd(point, times, MODES, DECADES)
    move = spread.move(point, times, MODES, DECADES)
    still = apply_spread(held, added)
    z = move / still.std(axis=0, ddof=1)
    assert abs(z[0]) > 2.576 > abs(z[1])           # too far at 0.5 s, within the spread at 5 s
    values, checks = followed(held, spread, point, times, MODES, DECADES)
    np.testing.assert_allclose(values[:, 0], still[:, 0])
    np.testing.assert_allclose(values[:, 1], apply_spread(held, added, np.array([0.0, move[1]]))[:, 1])
    assert [c["followed"] for c in checks] == [False, True] and [c["ok"] for c in checks] == [False, True]
    assert checks[1] == {"alpha_pulled": pytest.approx(0.65), "move": pytest.approx(move[1]),
                         "z": pytest.approx(z[1]), "inside_family": True, "ok": True, "followed": True}
    # not followed at all where the data ask for a stress shift; the check stays
    values, checks = followed(held, spread, point, times, MODES, DECADES, follow=False)
    np.testing.assert_allclose(values, still)
    assert [c["ok"] for c in checks] == [False, True] and not any(c["followed"] for c in checks)


def test_one_draw_is_judged_on_the_added_spread_alone():
    times = [5.0]
    held = E_t(times)[None, :]
    spread = ExponentSpread(0.05, {"E": -2900.0}, 0.01)
    added = spread.added_sd(POINT, times, MODES, DECADES)
    move = spread.move(POINT, times, MODES, DECADES)
    _, [check] = followed(held, spread, POINT, times, MODES, DECADES)
    assert check["z"] == pytest.approx(move[0] / added[0]) and check["followed"]


def test_a_spread_smaller_than_one_mpa_still_judges_the_pull():
    times = [5.0]
    held = E_t(times)[None, :] * np.ones((50, 1))
    spread = ExponentSpread(1e-4, {"E": -2900.0}, 1e-4)
    added = spread.added_sd(POINT, times, MODES, DECADES)
    assert added[0] < 1.0
    move = spread.move(POINT, times, MODES, DECADES)
    still = apply_spread(held, added)
    _, [check] = followed(held, spread, POINT, times, MODES, DECADES)
    assert check["z"] == pytest.approx(move[0] / still.std(ddof=1)) and check["z"] != 0


def test_the_spread_is_relative_to_each_time_s_median_however_small():
    values = np.column_stack([np.full(4000, 2e-3), np.full(4000, 5.0)])      # GPa, say
    out = apply_spread(values, np.array([2e-4, 0.5]))
    np.testing.assert_allclose(out.std(axis=0) / np.median(values, axis=0), [0.1, 0.1], rtol=0.05)
    np.testing.assert_allclose(np.median(out, axis=0), [2e-3, 5.0], rtol=0.01)


# ---------------------------------------------------------------- the stress shift

def test_the_stress_pull_reads_the_score_and_the_refit():
    fit = {"stress_score": {"z": 4.2, "sigma_s": 1.9},
           "stress_refit": {"estimate": {"E": 1800.0, "sigma_s": 2.1, "tau_max": 200}}}
    p = stress_pull(fit, False)
    assert (p.z, p.sigma_s, p.refit) == (4.2, 2.1, {"E": 1800.0, "sigma_s": 2.1, "tau_max": 200.0})
    assert p.asked and not StressPull(2.0, None).asked
    # without a refit, the sigma_s the score's step points to
    assert stress_pull({"stress_score": {"z": 4.2, "sigma_s": 1.9}}, False) == StressPull(4.2, 1.9, None)
    assert stress_pull({"stress_score": {"z": 4.2}}, False) == StressPull(4.2, None, None)
    # under model error, the discrepancy's score, else the white one
    under = {**fit, "discrepancy": {"stress_score": {"z": 1.0, "sigma_s": 9.0}}}
    assert stress_pull(under, True).z == 1.0 and stress_pull(under, False).z == 4.2
    assert stress_pull({"stress_score": {"z": 3.0}, "discrepancy": {}}, True).z == 3.0
    assert stress_pull({}, False) is None and stress_pull({"stress_score": {"z": math.nan}}, False) is None
    assert stress_pull({"stress_score": {"sigma_s": 2.0}}, False) is None


def test_the_stress_check_is_the_refit_s_e_t_against_this_one_in_its_sd():
    refit = {"E": 1900.0, "G": 5.0, "tau_max": 150.0, "Ea": 250.0}
    pull = StressPull(4.0, 2.0, refit)
    other = float(E_t(1.0, E=1900.0, G=5.0, tau_max=150.0, a_t=ARRHENIUS.factor(refit))[0])
    c = stress_check(pull, other - 1.5, 0.5, 1.0, MODES, DECADES, ARRHENIUS)
    assert c == {"score_z": 4.0, "sigma_s": 2.0, "shifted": pytest.approx(other),
                 "move": pytest.approx(1.5), "z": pytest.approx(3.0), "ok": False}
    assert stress_check(pull, other - 1.0, 0.5, 1.0, MODES, DECADES, ARRHENIUS)["ok"] is True
    assert stress_check(pull, other, 0.0, 1.0, MODES, DECADES, ARRHENIUS) is None
    assert STRESS_MOVE_Z == 2.576


# ---------------------------------------------------------------- the other checks

def test_the_local_and_width_checks_numbers():
    local = LocalEstimate(1000.0, 0.5, 12.0, 112.0)
    assert local_check(local, 1001.0) == {"local_mean": 1000.0, "local_sd": 0.5, "window_end": 12.0,
                                          "time_max": 112.0, "z": 2.0, "ok": True}
    assert local_check(local, 999.0)["z"] == -2.0
    assert width_check({"hdi_90": [75.0, 125.0], "median": 100.0}) == {"half_width": 0.25, "ok": True}
    assert INFORMATIVE == 0.25
    assert width_check({"hdi_90": [0.45, 0.55], "median": 0.5})["half_width"] == pytest.approx(0.1)
    assert width_check({"hdi_90": [-1.0, 1.0], "median": 0.0}) == {"half_width": math.inf, "ok": False}


def test_a_bound_move_in_an_sd_below_one_mpa_and_at_the_test_s_temperature():
    before = {"E": 1800.0, "G": 5.0, "tau_max": 150.0, "Ea": 250.0, "alpha": 0.4}
    after = {**before, "tau_max": 160.0, "Ea": 240.0}
    value = [float(E_t(1.0, E=p["E"], G=5.0, tau_max=p["tau_max"], alpha=0.4,
                       a_t=ARRHENIUS.factor(p))[0]) for p in (before, after)]
    moves = bound_moves([BoundRefit("tau_max", before, after)], 1.0, 0.5, MODES, DECADES, ARRHENIUS)
    assert moves == {"tau_max": pytest.approx((value[1] - value[0]) / 0.5)}


# ---------------------------------------------------------------- the rows and the curve

ROW_KEYS = {"t", "mean", "sd", "median", "hdi_90", "source", "resolved", "why", "checks"}
CHECK_KEYS = {"inside_window", "width", "shape", "stress", "local", "band", "start", "bounds",
              "prior", "noise_model", "converged"}


def _source(n=600, **fixed):
    rng = np.random.default_rng(9)
    drawn = {"E": rng.normal(2854.0, 5.0, n), "tau_max": rng.normal(5.79, 0.01, n)}
    return posterior_source(drawn, {"G": 2.32, **fixed}, True, None, False)


def _band(start=None) -> Band:
    t = np.linspace(0.4, 380.0, 200)
    X = np.column_stack([np.exp(-t / 50.0), t / 380.0, np.sin(t / 60.0)])
    return Band(np.ones(200, bool), t, t * 5e-3, None, X, ["E", "G", "tau_max"],
                {**POINT, "Ea": 250.0}, start=start)


def test_the_rows_carry_e_t_of_the_model_and_every_check_by_name():
    source = _source()
    start = StartCheck(1500.0, 1490.0, 5.0, 3.0, 1.7, (0.1, 0.5))
    local = {1.0: LocalEstimate(2000.0, 1.0, 10.0, 10.0)}
    refits = [BoundRefit("tau_max", dict(POINT), {**POINT, "tau_max": 6.0})]
    pull = StressPull(4.0, 2.0, {**POINT, "E": 2800.0})
    result = estimate(source, [1.0], "asked", WINDOW, _band(start), None, refits, False, MODES,
                      DECADES, local, None, pull)
    [row] = result.rows
    assert set(row) == ROW_KEYS and set(row["checks"]) == CHECK_KEYS
    held = E_t(1.0, E=source.draws["E"], tau_max=source.draws["tau_max"])[:, 0]
    stats = draw_stats(held)
    assert {k: row[k] for k in ("mean", "sd", "median")} == pytest.approx(
        {k: stats[k] for k in ("mean", "sd", "median")})
    assert row["hdi_90"] == pytest.approx(stats["hdi_90"])
    assert (row["t"], row["source"], row["resolved"], row["why"]) == (1.0, "posterior", [0.8, 380.0],
                                                                     "asked")
    c = row["checks"]
    assert c["width"] == width_check(stats) and c["shape"] is None
    assert c["stress"] == pytest.approx(stress_check(pull, held.mean(), stats["sd"], 1.0, MODES,
                                                     DECADES, AtTemperature()))
    assert c["local"] == pytest.approx(local_check(local[1.0], held.mean()))
    assert c["start"] == start.to_dict()
    assert c["bounds"] == pytest.approx(bound_moves(refits, 1.0, stats["sd"], MODES, DECADES))
    assert c["noise_model"] is False and c["converged"] is True and c["prior"] is None


def test_the_default_model_is_fifty_modes_over_six_decades():
    source = _source()
    [row] = estimate(source, [1.0], "asked", WINDOW, None, None, [], True).rows
    held = relaxation_modulus([1.0], source.draws["E"], 2.32, source.draws["tau_max"])[:, 0]
    assert row["mean"] == pytest.approx(held.mean(), rel=1e-12)


def test_at_another_temperature_the_band_is_judged_on_the_gradient_there():
    source = _source(Ea=250.0)
    band = _band()
    [row] = estimate(source, [1.0], "asked", WINDOW, band, None, [], True, MODES, DECADES,
                     at=ARRHENIUS).rows
    point = {**band.point, SHIFT_FACTOR: float(ARRHENIUS.factor(band.point)),
             LOG_SLOPES: ARRHENIUS.log_slopes(band.point)}
    g = gradient(point, band.free, [1.0], MODES, DECADES)[0]
    expected = band_check(band, g, WINDOW.origin)
    assert row["checks"]["band"]["n_eff"] == pytest.approx(expected["n_eff"])
    assert row["checks"]["band"] == {**expected, "n_eff": row["checks"]["band"]["n_eff"],
                                     "floor": row["checks"]["band"]["floor"]}
    assert row["temperature"] == 40.0
    a = float(ARRHENIUS.factor({"Ea": 250.0}))
    held = E_t(1.0, E=source.draws["E"], tau_max=source.draws["tau_max"], a_t=a)
    assert row["mean"] == pytest.approx(held.mean(), rel=1e-12)
    assert "temperature" not in estimate(source, [1.0], "", WINDOW, None, None, [], True).rows[0]


def test_the_spread_s_numbers_in_the_row_and_a_stress_shift_stops_the_pull():
    source = _source()
    spread = ExponentSpread(0.05, {"E": -2900.0}, 0.01)
    point = source.point()
    [row] = estimate(source, [5.0], "", WINDOW, None, spread, [], True, MODES, DECADES).rows
    assert row["spectrum_exponent"] == {
        "dE_dalpha": pytest.approx(spread.slope(point, [5.0], MODES, DECADES)[0]),
        "alpha_sd": 0.05, "added_sd": pytest.approx(spread.added_sd(point, [5.0], MODES, DECADES)[0])}
    assert row["checks"]["shape"]["followed"] is True
    asked = StressPull(4.0, 2.0, None)
    stopped = estimate(source, [5.0], "", WINDOW, None, spread, [], True, MODES, DECADES, pull=asked)
    assert stopped.rows[0]["checks"]["shape"]["followed"] is False
    assert stopped.rows[0]["checks"]["shape"]["ok"] is True
    assert stopped.rows[0]["median"] < row["median"]     # the pull (E(5 s) up) is not followed
    i = int(np.argmin(np.abs(np.asarray(stopped.curve["t"]) - 5.0)))
    followed_curve = estimate(source, [5.0], "", WINDOW, None, spread, [], True, MODES, DECADES).curve
    assert stopped.curve["q50"][i] < followed_curve["q50"][i]


def test_the_curve_spans_a_hundredth_of_the_shortest_time_to_the_longest_with_e_s_interval():
    source = _source(n=300)          # all of them on the curve (at most CURVE_DRAWS = 400)
    result = estimate(source, [1.0, 500.0], "", WINDOW, None, None, [], True, MODES, DECADES)
    curve = result.curve
    assert set(curve) == {"t", "q05", "q50", "q95", "resolved", "E_median", "E_hdi_90", "source"}
    t = np.asarray(curve["t"])
    assert t.size == 80 and t[0] == pytest.approx(0.008) and t[-1] == pytest.approx(500.0)
    e_t = E_t(t, E=source.draws["E"], tau_max=source.draws["tau_max"])
    for key, q in (("q05", 0.05), ("q50", 0.5), ("q95", 0.95)):
        np.testing.assert_allclose(curve[key], np.quantile(e_t, q, axis=0), rtol=1e-12)
    assert curve["E_median"] == pytest.approx(float(np.median(source.draws["E"])))
    assert curve["E_hdi_90"] == pytest.approx(draw_stats(source.draws["E"])["hdi_90"])
    assert curve["resolved"] == [0.8, 380.0] and curve["source"] == "posterior"
    # E fixed: its interval is the value itself
    fixed = posterior_source({"tau_max": source.draws["tau_max"]}, {"E": 2854.0, "G": 2.32}, True,
                             None, False)
    assert estimate(fixed, [1.0], "", WINDOW, None, None, [], True).curve["E_hdi_90"] == [2854.0] * 2
    two = Source("posterior", {"E": np.array([2800.0, 2900.0]), "tau_max": np.array([5.7, 5.8])},
                 {"G": 2.32}, True)
    assert estimate(two, [1.0], "", WINDOW, None, None, [], True).curve["E_hdi_90"] == [2800.0, 2900.0]


def test_a_flat_prior_shapes_nothing():
    rng = np.random.default_rng(2)
    drawn = {"E": rng.normal(2854.0, 5.0, 400), "tau_max": rng.normal(5.79, 0.01, 400)}
    flat = posterior_source(drawn, {"G": 2.32}, True, np.zeros(400), False)
    assert estimate(flat, [1.0], "", WINDOW, None, None, [], True).rows[0]["checks"]["prior"] is None
