"""The one E(t) estimator (inference/modulus_estimate.py): its two sources, the exponent's spread,
the bound move, the rows and their checks."""

from __future__ import annotations

import numpy as np
import pytest

from bayes_dnlr.inference.checks.band import Band
from bayes_dnlr.inference.modulus_estimate import (
    NO_PRIOR,
    BoundRefit,
    ExponentSpread,
    apply_spread,
    bound_moves,
    estimate,
    exponent_spread,
    fit_source,
    gradient,
    modulus_draws,
    posterior_source,
)
from bayes_dnlr.inference.modulus_window import ResolvedWindow
from bayes_dnlr.model.modulus import relaxation_modulus

POINT = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}
WINDOW = ResolvedWindow(shortest=0.8, longest=380.0, origin=0.0, step=0.4, how="two steps")


def test_the_gradient_is_the_finite_difference_of_e_t():
    names = ["E", "G", "tau_max", "alpha"]
    point = {**POINT, "alpha": 0.45}
    times = [0.3, 1.0, 7.0]
    g = gradient(point, names, times)
    for j, k in enumerate(names):
        h = 1e-6 * max(abs(point[k]), 1.0)

        def at(v, k=k):
            p = {**point, k: v}
            return relaxation_modulus(times, p["E"], p["G"], p["tau_max"], p["alpha"])

        np.testing.assert_allclose(g[:, j], (at(point[k] + h) - at(point[k] - h)) / (2 * h), rtol=1e-5)


def test_the_fit_s_laplace_draws_give_the_delta_method_s_sd_where_it_is_small():
    names = ["E", "G", "tau_max"]
    sd = np.array([3.0, 0.002, 0.01])
    corr = np.array([[1.0, -0.2, -0.99], [-0.2, 1.0, 0.2], [-0.99, 0.2, 1.0]])
    cov = corr * np.outer(sd, sd)
    source = fit_source(POINT, cov, names, {}, True, False, n=20000)
    values = modulus_draws(source.columns(), [1.0])[:, 0]
    g = gradient(POINT, names, [1.0])[0]
    assert values.std() == pytest.approx(np.sqrt(g @ cov @ g), rel=0.03)
    assert values.mean() == pytest.approx(relaxation_modulus([1.0], *POINT.values())[0], rel=1e-4)
    # the same draws every time (seeded), and no prior to check
    again = fit_source(POINT, cov, names, {}, True, False, n=20000)
    np.testing.assert_array_equal(again.draws["E"], source.draws["E"])
    assert source.log_prior is None and source.lacks == {"prior": NO_PRIOR}


def test_a_wide_time_constant_is_drawn_in_log_space_and_never_negative():
    names = ["E", "tau_max"]
    cov = np.diag([10.0**2, 8.0**2])             # sd of tau_max larger than tau_max
    source = fit_source({"E": 2000.0, "tau_max": 5.0}, cov, names, {"G": 1.0}, True, False)
    assert np.all(source.draws["tau_max"] > 0)
    assert np.median(source.draws["tau_max"]) == pytest.approx(5.0, rel=0.1)
    assert source.columns()["G"] == 1.0 and source.columns()["alpha"] == 0.5


def test_an_unidentified_covariance_entry_counts_as_no_spread():
    cov = np.array([[4.0, np.nan], [np.nan, np.nan]])
    source = fit_source({"E": 2000.0, "tau_max": 5.0}, cov, ["E", "tau_max"], {}, True, False)
    assert np.all(np.isfinite(source.draws["E"])) and np.ptp(source.draws["tau_max"]) == 0


def test_the_exponent_s_spread_is_the_slope_along_the_refit_times_alpha_s_sd():
    point = {"E": 2854.0, "G": 2.32, "tau_max": 5.79, "alpha": 0.5}
    block = {"sampled": False, "derivative": {"E": -2900.0, "G": 0.05, "tau_max": -1.7},
             "score": {"sd": 0.05}}
    fit = {"spectrum_exponent": block, "discrepancy": {"alpha_score": {"sd": 0.2}}}
    s = exponent_spread(fit, False)
    g = gradient(point, ["E", "G", "tau_max", "alpha"], [1.0, 10.0])
    slope = g[:, 3] + g[:, 0] * -2900.0 + g[:, 1] * 0.05 + g[:, 2] * -1.7
    np.testing.assert_allclose(s.slope(point, [1.0, 10.0], 50, 6.0), slope)
    np.testing.assert_allclose(s.added_sd(point, [1.0, 10.0], 50, 6.0), np.abs(slope) * 0.05)
    # under the discrepancy, the score test on the whitened residuals gives alpha's sd
    assert exponent_spread(fit, True).alpha_sd == 0.2
    assert exponent_spread({"spectrum_exponent": {**block, "sampled": True}}, False) is None
    assert exponent_spread({}, False) is None
    # the spread keeps the median and adds about the sd asked, never a negative modulus
    values = np.full((20000, 2), 1000.0)
    out = apply_spread(values, np.array([0.0, 10.0]))
    np.testing.assert_array_equal(out[:, 0], 1000.0)
    assert out[:, 1].std() == pytest.approx(10.0, rel=0.05)
    assert np.median(out[:, 1]) == pytest.approx(1000.0, abs=0.5)
    assert np.all(apply_spread(values, np.array([5000.0, 5000.0])) > 0)
    huge = apply_spread(values, np.array([1e9, 1e9]))
    assert np.all(np.isfinite(huge)) and np.all(huge > 0)


def test_e_t_s_move_when_a_bound_is_widened_is_its_own_refit_s():
    before, after = {"E": 2000.0, "tau_max": 50.0}, {"E": 2100.0, "tau_max": 40.0}
    expected = (relaxation_modulus([1.0], 2100.0, 0.0, 40.0)[0]
                - relaxation_modulus([1.0], 2000.0, 0.0, 50.0)[0]) / 10.0
    moves = bound_moves([BoundRefit("tau_max", before, after)], 1.0, 10.0, 50, 6.0)
    assert moves == {"tau_max": pytest.approx(expected)}
    assert bound_moves([BoundRefit("tau_max", before, after)], 1.0, 0.0, 50, 6.0) == {}


def _band(inside: np.ndarray) -> Band:
    t = np.linspace(0.4, 380.0, inside.size)
    X = np.column_stack([np.exp(-t / 50.0), t / 380.0, np.sin(t / 60.0)])
    return Band(inside, t, t * 5e-3, None, X, ["E", "G", "tau_max"], dict(POINT))


def test_both_sources_give_rows_with_the_same_checks_and_the_fit_says_what_it_lacks():
    rng = np.random.default_rng(3)
    drawn = {"E": rng.normal(2854.0, 5.0, 4000), "tau_max": rng.normal(5.79, 0.01, 4000)}
    log_prior = -0.5 * ((drawn["E"] - 2800.0) / 50.0) ** 2          # an informative prior on E
    post = posterior_source(drawn, {"G": 2.32}, True, log_prior, False)
    fit = fit_source(POINT, np.diag([25.0, 1e-6, 1e-4]), ["E", "G", "tau_max"], {}, False, True)
    band = _band(np.ones(200, bool))
    for source in (post, fit):
        result = estimate(source, [1.0, 1000.0], "asked", WINDOW, band, None, [], True)
        near, far = result.rows
        assert near["source"] == source.kind and near["checks"]["inside_window"]
        assert not far["checks"]["inside_window"]
        assert near["checks"]["band"]["ok"] and near["checks"]["band"]["share"] == 1.0
        assert near["hdi_90"][0] < near["median"] < near["hdi_90"][1]
        assert result.curve["q05"][0] <= result.curve["q50"][0] <= result.curve["q95"][0]
    post_row = estimate(post, [1.0], "asked", WINDOW, band, None, [], True).rows[0]
    fit_row = estimate(fit, [1.0], "asked", WINDOW, band, None, [], True).rows[0]
    assert post_row["checks"]["prior"] is not None and "lacks" not in post_row
    assert fit_row["checks"]["prior"] is None and fit_row["lacks"] == {"prior": NO_PRIOR}
    assert fit_row["checks"]["converged"] is False and post_row["checks"]["converged"] is True
    # a band that misses every sample fails, wherever the information lies
    missed = estimate(fit, [1.0], "asked", WINDOW, _band(np.zeros(200, bool)), None, [], True)
    assert not missed.rows[0]["checks"]["band"]["ok"]


def test_the_spread_widens_the_rows_and_the_curve_alike():
    fit = fit_source(POINT, np.diag([25.0, 1e-6, 1e-4]), ["E", "G", "tau_max"], {}, True, False)
    plain = estimate(fit, [1.0], "asked", WINDOW, None, None, [], True)
    wide = estimate(fit, [1.0], "asked", WINDOW, None, ExponentSpread(0.1, {"E": -2900.0}), [], True)
    assert wide.rows[0]["sd"] > 2 * plain.rows[0]["sd"]
    assert wide.rows[0]["spectrum_exponent"]["added_sd"] > 0
    i = int(np.argmin(np.abs(np.asarray(wide.curve["t"]) - 1.0)))
    assert (wide.curve["q95"][i] - wide.curve["q05"][i]) > 2 * (plain.curve["q95"][i] - plain.curve["q05"][i])


def test_e_t_at_another_temperature_is_the_reference_curve_at_times_over_a_t_and_so_its_gradient():
    from bayes_dnlr.inference.modulus_estimate import LOG_SLOPES, SHIFT_FACTOR, AtTemperature
    from bayes_dnlr.model.shift import temperature_shift

    at = AtTemperature("arrhenius", 20.0, 40.0)
    point = {**POINT, "Ea": 250.0}
    a = temperature_shift(40.0, "arrhenius", 20.0, Ea=250.0)
    assert at.factor(point) == pytest.approx(a) and not AtTemperature("arrhenius", 20.0, 20.0).shifted
    shifted = {**point, SHIFT_FACTOR: a, LOG_SLOPES: at.log_slopes(point)}
    times = [0.01, 0.1]
    np.testing.assert_allclose(modulus_draws(shifted, times)[0],
                               relaxation_modulus(np.array(times) / a, *POINT.values()), rtol=1e-12)
    g = gradient(shifted, ["tau_max", "Ea"], times)
    for j, k in enumerate(["tau_max", "Ea"]):
        h = 1e-6 * point[k]

        def at_value(v, k=k):
            p = {**point, k: v}
            return relaxation_modulus(times, p["E"], p["G"], p["tau_max"],
                                      shift_factor=at.factor(p))

        np.testing.assert_allclose(g[:, j], (at_value(point[k] + h) - at_value(point[k] - h)) / (2 * h),
                                   rtol=1e-5)


def test_an_interval_wider_than_a_quarter_of_e_t_says_little():
    from bayes_dnlr.inference.modulus_estimate import INFORMATIVE, width_check

    assert width_check({"hdi_90": [90.0, 110.0], "median": 100.0}) == {"half_width": 0.1, "ok": True}
    wide = width_check({"hdi_90": [70.0, 130.0], "median": 100.0})
    assert wide["half_width"] == pytest.approx(0.3) and not wide["ok"] and INFORMATIVE == 0.25


def test_the_local_check_is_its_gap_in_the_local_sd():
    from bayes_dnlr.inference.modulus_estimate import LocalEstimate, local_check

    local = LocalEstimate(1000.0, 10.0, 5.0, 5.0)
    assert local_check(local, 1020.0)["ok"] and local_check(local, 1020.0)["z"] == pytest.approx(2.0)
    assert not local_check(local, 1030.0)["ok"]
    assert local_check(None, 1.0) is None and local_check(LocalEstimate(1.0, 0.0, 1.0, 1.0), 2.0) is None
    # the value reported after the exponent's pull must agree with the start too
    pulled = local_check(local, 1010.0, 970.0)
    assert pulled["z"] == pytest.approx(1.0) and pulled["z_reported"] == pytest.approx(-3.0)
    assert not pulled["ok"]
    assert local_check(local, 1010.0, 1015.0)["ok"] and "z_reported" not in local_check(local, 1010.0, 1010.0)


def test_the_exponent_s_pull_is_followed_only_where_small_and_never_where_the_data_ask_for_a_stress_shift():
    from bayes_dnlr.inference.modulus_estimate import followed

    held = np.full((4000, 2), 1000.0) * np.exp(0.01 * np.random.default_rng(0).standard_normal((4000, 2)))
    spread = ExponentSpread(0.05, {"E": -2900.0}, step=0.05)
    point = {**POINT, "alpha": 0.5}
    values, checks = followed(held, spread, point, [1.0, 100.0], 50, 6.0)
    still, not_followed = followed(held, spread, point, [1.0, 100.0], 50, 6.0, follow=False)
    assert not any(c["followed"] for c in not_followed)
    assert [c["z"] for c in not_followed] == [c["z"] for c in checks]
    for i, c in enumerate(checks):
        assert c["followed"] == c["ok"] == (abs(c["z"]) <= 2.576)
        # the move is the pull's shift of the median; the spread widens the held draws
        assert np.median(values[:, i]) - np.median(still[:, i]) == pytest.approx(
            c["move"] if c["followed"] else 0.0, rel=0.02, abs=1e-6)
        assert still[:, i].std() >= 0.999 * held[:, i].std() and np.all(still[:, i] > 0)
    # the move is linearized along the path: slope × pull
    assert checks[0]["move"] == pytest.approx(float(spread.slope(point, [1.0], 50, 6.0)[0]) * 0.05)


def test_the_stress_check_compares_the_refit_s_e_t_in_this_one_s_sd():
    from bayes_dnlr.inference.modulus_estimate import AtTemperature, StressPull, stress_check

    refit = {"E": 2000.0, "G": 0.0, "tau_max": 50.0, "sigma_s": 2.0}
    other = relaxation_modulus([1.0], 2000.0, 0.0, 50.0)[0]
    pull = StressPull(5.0, 2.0, refit)
    c = stress_check(pull, other - 30.0, 10.0, 1.0, 50, 6.0, AtTemperature())
    assert c["move"] == pytest.approx(30.0) and c["z"] == pytest.approx(3.0) and not c["ok"]
    assert stress_check(StressPull(1.0, 2.0, refit), 0.0, 10.0, 1.0, 50, 6.0, AtTemperature()) is None
    assert stress_check(StressPull(5.0, None, None), 0.0, 10.0, 1.0, 50, 6.0, AtTemperature()) is None


def test_a_pull_that_would_take_e_t_through_zero_is_not_followed_however_wide_its_spread():
    from bayes_dnlr.inference.modulus_estimate import followed

    # late times: E(t) small and loosely held, so a move larger than E(t) is still within 2.576 sd
    held = np.full((4000, 1), 5.0) * np.exp(2.0 * np.random.default_rng(1).standard_normal((4000, 1)))
    spread = ExponentSpread(0.05, {"E": -2900.0}, step=-0.05)
    point = {**POINT, "alpha": 0.5}
    move = float(spread.move(point, [1.0], 50, 6.0)[0])
    assert move < -float(np.median(held))          # the case at hand
    values, checks = followed(held, spread, point, [1.0], 50, 6.0)
    assert not checks[0]["followed"]
    assert np.all(np.isfinite(values)) and np.all(values > 0)


def test_the_exponent_s_path_carries_to_another_point_in_relative_time_constants():
    """A test alone of a run at several temperatures holds its temperature law's parameters, so its
    fit puts tau_max elsewhere (16.9 s against the run's 5.7 s on the three-temperature benchmark):
    d ln tau_max/dα is what carries over, not dtau_max/dα (applied at 5.7 s it moved tau_max ×0.025
    and E(10 s) at 10 °C to 9 MPa, below E(100 s))."""
    fit = {"estimate": {"E": 2642.0, "G": 2.2, "tau_max": 16.87},
           "spectrum_exponent": {"derivative": {"E": 364.6, "G": -3.0, "tau_max": -166.3},
                                 "score": {"sd": 0.141, "step": 0.127}}}
    spread = exponent_spread(fit, False)
    assert spread.scale == {"tau_max": 16.87}
    point = {"E": 2748.0, "G": 2.3, "tau_max": 5.7}
    at = spread.at(point)
    assert at["tau_max"] == pytest.approx(-166.3 * 5.7 / 16.87) and at["E"] == 364.6
    same = ExponentSpread(0.141, at, 0.127)        # the derivative taken at the point itself
    times = [0.1, 1.0, 10.0]
    assert np.allclose(spread.move(point, times, 50, 6.0), same.move(point, times, 50, 6.0))
    assert np.allclose(spread.slope(point, times, 50, 6.0), same.slope(point, times, 50, 6.0))
    base = relaxation_modulus(times, 2748.0, 2.3, 5.7)
    moved = base + spread.move(point, times, 50, 6.0)
    absolute = base + ExponentSpread(0.141, spread.derivative, 0.127).move(point, times, 50, 6.0)
    # at 1 s (E(1 s) at ½ is 1258 MPa) the relative derivative moves E(t) by about 480 MPa; the
    # absolute one by 1840, through zero
    assert moved[1] > 0.4 * base[1] and absolute[1] < 0.0
    own = {"E": 2642.0, "G": 2.2, "tau_max": 16.87}  # at the fit's own point: the derivative as given
    assert spread.at(own) == pytest.approx(fit["spectrum_exponent"]["derivative"])


@pytest.mark.parametrize("step", [-0.6, 0.55])
def test_a_pull_past_the_family_s_edge_is_not_followed_and_its_move_is_still_weighed(step):
    from bayes_dnlr.inference.modulus_estimate import followed

    # held loosely: the move is well within E(t)'s sd, which alone would let it be followed
    held = np.full((4000, 1), 1000.0) * np.exp(0.3 * np.random.default_rng(2).standard_normal((4000, 1)))
    point = {**POINT, "alpha": 0.5}
    spread = ExponentSpread(0.05, {"E": -2900.0}, step=step)
    values, [check] = followed(held, spread, point, [1.0], 50, 6.0)
    assert abs(check["z"]) < 2.576 and check["alpha_pulled"] in (0.0, 1.0)
    assert not check["inside_family"] and check["ok"] and not check["followed"]
    still, _ = followed(held, spread, point, [1.0], 50, 6.0, follow=False)
    np.testing.assert_array_equal(values, still)          # E(t) at ½ with its spread
    inside = ExponentSpread(0.05, {"E": -2900.0}, step=0.45)
    _, [kept] = followed(held, inside, point, [1.0], 50, 6.0)
    assert kept["inside_family"] and kept["ok"] and kept["followed"]
    # a move too large for E(t)'s sd fails the check past the edge as inside it
    tight = held[:, :1] * 0 + 1000.0 * np.exp(1e-3 * np.random.default_rng(3).standard_normal((4000, 1)))
    _, [far] = followed(tight, spread, point, [1.0], 50, 6.0)
    assert abs(far["z"]) > 2.576 and not far["ok"] and not far["followed"]
