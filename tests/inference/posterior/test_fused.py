"""The compiled all-walker log-likelihood (inference/posterior/fused.py) against the per-walker reference, and
its independence of the thread count (the same walkers' log-posterior to the bit with 1 and 2 threads and
in a forked child; a fixed seed gives the same chain and log-probs with 1 and 2 threads)."""

from __future__ import annotations

import numpy as np
import pytest
from support.forking import in_parent_and_forked_child
from support.likelihood import discrepancy_config, discrepancy_priors, white_config, wobbly
from support.sampling import TRUTH, TRUTH_RELAX, make_test

from bayes_dnlr.config import parse_config
from bayes_dnlr.inference.posterior.density import build_log_posterior
from bayes_dnlr.model import get_threads, set_threads
from bayes_dnlr.model.threads import available_threads


def _spread(center: np.ndarray, rel: np.ndarray, k: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return center * (1.0 + rel * rng.standard_normal((k, center.size)))


def _check_equal_to_reference(post, thetas: np.ndarray) -> None:
    fused = post.log_likelihood(thetas)
    ref = post.log_likelihood_reference(thetas)
    assert np.all(np.isfinite(ref))
    np.testing.assert_allclose(fused, ref, rtol=1e-9, atol=0)


def test_white_equals_the_per_walker_reference() -> None:
    test = make_test(seed=3)
    post = build_log_posterior(white_config(), test, sigma0=0.3)
    th = _spread(np.array([TRUTH[k] for k in post.names]), np.array([0.01, 0.02, 0.05]), 37)
    _check_equal_to_reference(post, th)


def test_white_relaxation_with_a_window_gap_and_sampled_sigma0() -> None:
    window = np.ones(700, bool)
    window[100:150] = False
    test = make_test(relaxation=True, window=window)
    cfg = white_config(relaxation=True, sigma0={"prior": "half-normal", "scale": 5.0})
    post = build_log_posterior(cfg, test, sigma0=None)
    center = np.array([*(TRUTH_RELAX[k] for k in post.names[:-1]), 0.3])
    th = _spread(center, np.full(center.size, 0.03), 19, seed=1)
    _check_equal_to_reference(post, th)


@pytest.mark.parametrize("kernel", ["exp", "matern32"])
@pytest.mark.parametrize("axis", ["time", "strain"])
def test_discrepancy_equals_the_per_walker_reference(kernel, axis) -> None:
    test = wobbly(make_test(n=600))         # jittered grid; a noisy strain axis is unsorted
    post = build_log_posterior(discrepancy_config(kernel, axis), test, sigma0=0.3,
                               discrepancy_priors=discrepancy_priors(1e3 if axis == "time" else 1.0))
    length = 12.0 if axis == "time" else 0.02
    center = np.array([2854.0, 2.32, 5.79, 0.5, length])
    th = _spread(center, np.array([0.01, 0.02, 0.05, 0.5, 0.5]), 21, seed=2)
    th[:, 3:] = np.abs(th[:, 3:])
    _check_equal_to_reference(post, th)


def test_pinned_discrepancy_on_a_relaxation_test() -> None:
    window = np.ones(700, bool)
    window[100:150] = False
    test = make_test(relaxation=True, window=window)
    raw = discrepancy_config("matern32", "time", relaxation=True).model_dump(mode="json", exclude_none=True)
    raw["noise"]["discrepancy"]["start"] = "pinned"
    post = build_log_posterior(parse_config(raw), test, sigma0=0.3,
                               discrepancy_priors=discrepancy_priors(1e3))
    center = np.array([*TRUTH_RELAX.values(), 0.5, 30.0])
    th = np.abs(_spread(center, np.full(center.size, 0.03), 11, seed=4))
    _check_equal_to_reference(post, th)


def test_bad_points_give_minus_inf_in_both_paths() -> None:
    test = make_test(n=300)
    post = build_log_posterior(discrepancy_config("exp", "time"), test, sigma0=0.3,
                               discrepancy_priors=discrepancy_priors(1e3))
    th = np.array([[2854.0, 2.32, 5.79, 0.5, 10.0],
                   [2854.0, 2.32, -1.0, 0.5, 10.0],      # invalid time constant
                   [1e300, 2.32, 5.79, 0.5, 10.0],       # overflowing stress
                   [2854.0, 2.32, 5.79, 0.5, -3.0],      # invalid length
                   [np.nan, 2.32, 5.79, 0.5, 10.0]])
    with np.errstate(all="ignore"):
        fused = post.log_likelihood(th)
    assert np.isfinite(fused[0])
    assert np.all(fused[1:] == -np.inf)
    white = build_log_posterior(white_config(), test, sigma0=0.3)
    with np.errstate(all="ignore"):
        lw = white.log_likelihood(th[:, :3])
    assert np.all(np.isfinite(lw[[0, 3]]))   # row 3 is bad only in its discrepancy length
    assert np.all(lw[[1, 2, 4]] == -np.inf)


def _chain(post, threads: int, steps: int = 25, walkers: int = 24, seed: int = 7) -> np.ndarray:
    import emcee

    assert set_threads(threads) == min(threads, available_threads())
    assert get_threads() == min(threads, available_threads())
    x0 = np.array([[*TRUTH.values(), 0.5, 12.0][: post.ndim]])
    z0 = post.priors.from_physical(x0)
    rng = np.random.default_rng(seed)
    p0 = z0 + 1e-3 * rng.standard_normal((walkers, post.ndim)) * np.maximum(np.abs(z0), 1.0)
    sampler = emcee.EnsembleSampler(walkers, post.ndim, post, moves=emcee.moves.DEMove(),
                                    vectorize=True)
    state = emcee.State(p0, random_state=np.random.RandomState(seed).get_state())
    sampler.run_mcmc(state, steps)
    return sampler.get_chain(), sampler.get_log_prob()


@pytest.mark.parametrize("disc", [False, True])
def test_one_or_two_threads_give_the_same_chain(disc) -> None:
    test = make_test(n=500, seed=9)
    if disc:
        post = build_log_posterior(discrepancy_config("exp", "time"), test, sigma0=0.3,
                                   discrepancy_priors=discrepancy_priors(1e3))
    else:
        post = build_log_posterior(white_config(), test, sigma0=0.3)
    try:
        one, lp_one = _chain(post, 1)
        two, lp_two = _chain(post, 2)
    finally:
        set_threads(None)
    assert np.any(one[-1] != one[0])          # the walkers moved
    np.testing.assert_array_equal(one, two)
    assert lp_one.tobytes() == lp_two.tobytes()      # the log-probs too, to the last bit


def test_thread_setting_is_capped_by_the_environment(monkeypatch) -> None:
    from bayes_dnlr.model.threads import use_threads

    try:
        monkeypatch.setenv("OMP_NUM_THREADS", "1")
        assert use_threads(2) == 1 and get_threads() == 1
        assert use_threads(None) == 1
        monkeypatch.delenv("OMP_NUM_THREADS")
        assert use_threads(None) == available_threads()
        assert use_threads(1) == 1 and get_threads() == 1
    finally:
        set_threads(None)


def test_thread_setting_in_config_and_cli() -> None:
    from pydantic import ValidationError

    from bayes_dnlr.cli import build_parser

    raw = {"name": "t", "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e",
                                                             "stress": "s"},
                                 "observable": "stress"}}
    assert parse_config(raw).sampler.threads is None
    assert parse_config({**raw, "sampler": {"threads": 2}}).sampler.threads == 2
    with pytest.raises((ValidationError, ValueError), match="threads"):
        parse_config({**raw, "sampler": {"threads": 0}})
    assert build_parser().parse_args(["sample", "c.yaml", "--threads", "1"]).threads == 1
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(["sample", "c.yaml", "--threads", "0"])
    assert exc.value.code == 2


def test_a_forked_child_computes_in_one_thread_with_the_same_values() -> None:
    """numba terminates a forked child that starts a parallel region when the parent used GNU
    OpenMP: the child takes the serial driver (the zygote of the crash tests forks like this)."""
    test = make_test(n=400, seed=2)
    post = build_log_posterior(discrepancy_config("exp", "time"), test, sigma0=0.3,
                               discrepancy_priors=discrepancy_priors(1e3))
    th = _spread(np.array([2854.0, 2.32, 5.79, 0.5, 12.0]), np.full(5, 0.01), 20)
    parent, child = in_parent_and_forked_child(lambda: post.log_likelihood(th))
    np.testing.assert_array_equal(child, parent)


def test_the_wait_policy_spins_only_when_a_core_is_free(monkeypatch):
    """threads._wait_policy: a short spin when no other task needs the second core, else passive
    (a spinning thread on a busy machine took the loop from 0.46 to 1.0 s; docs/performance.md)."""
    from bayes_dnlr.model import threads

    monkeypatch.setattr(threads.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(threads, "other_runnable", lambda: 0)
    assert threads._wait_policy() == {"OMP_WAIT_POLICY": "ACTIVE", "GOMP_SPINCOUNT": "30000"}
    monkeypatch.setattr(threads, "other_runnable", lambda: 1)
    assert threads._wait_policy() == {"OMP_WAIT_POLICY": "PASSIVE"}


@pytest.mark.parametrize("kernel", ["exp", "matern32"])
@pytest.mark.parametrize("relaxation", [False, True])
def test_orthogonal_discrepancy_equals_the_per_walker_reference(kernel, relaxation) -> None:
    """target: l2 samples with orthogonality columns (inference/discrepancy/orthogonal.py): the compiled call
    equals the reference, on a jittered grid (three columns) and on a relaxation test with a
    window gap and a pinned start (five columns)."""
    from bayes_dnlr.inference.discrepancy.gls import columns_for

    if relaxation:
        window = np.ones(700, bool)
        window[100:150] = False
        test = make_test(relaxation=True, window=window)
        raw = discrepancy_config(kernel, "time", relaxation=True).model_dump(mode="json", exclude_none=True)
        raw["noise"]["discrepancy"]["start"] = "pinned"
        cfg = parse_config(raw)
        center = np.array([*TRUTH_RELAX.values(), 0.5, 30.0])
    else:
        test = wobbly(make_test(n=600))
        cfg = discrepancy_config(kernel, "time")
        center = np.array([2854.0, 2.32, 5.79, 0.5, 12.0])
    estimate = dict(zip(cfg.free_parameters, center, strict=False))
    cols, _ = columns_for(cfg, test, estimate)
    assert cols.p == (5 if relaxation else 3)
    post = build_log_posterior(cfg, test, sigma0=0.3, discrepancy_priors=discrepancy_priors(1e3),
                               columns=cols.V)
    th = np.abs(_spread(center, np.full(center.size, 0.03), 19, seed=5))
    _check_equal_to_reference(post, th)
    plain = build_log_posterior(cfg, test, sigma0=0.3, discrepancy_priors=discrepancy_priors(1e3))
    assert np.all(np.abs(post.log_likelihood(th) - plain.log_likelihood(th)) > 1e-6)


def _posteriors() -> dict[str, object]:
    """The log-posteriors whose compiled paths differ: white on a uniform and on a jittered grid,
    a relaxation test with a window gap and a sampled σ0, the spectrum's exponent free, the
    discrepancy (exp, matern32 along the strain, a pinned start) and its orthogonal form."""
    from bayes_dnlr.inference.discrepancy.gls import columns_for

    gap = np.ones(700, bool)
    gap[100:150] = False
    relax = make_test(relaxation=True, window=gap)
    ramp, jittered = make_test(n=400, seed=4), wobbly(make_test(n=400, seed=5))
    pinned = discrepancy_config("matern32", "time", relaxation=True).model_dump(mode="json",
                                                                              exclude_none=True)
    pinned["noise"]["discrepancy"]["start"] = "pinned"
    alpha = white_config(parameters={"alpha": {"prior": "normal", "mean": 0.5, "sd": 0.05, "low": 0,
                                                "high": 1}})
    disc = discrepancy_config("exp", "time")
    cols, _ = columns_for(disc, jittered, {"E": 2854.0, "G": 2.32, "tau_max": 5.79})
    prior = discrepancy_priors(1e3)
    return {
        "white": build_log_posterior(white_config(), ramp, sigma0=0.3),
        "white, jittered grid": build_log_posterior(white_config(), jittered, sigma0=0.3),
        "white relaxation, sampled sigma0": build_log_posterior(
            white_config(relaxation=True, sigma0={"prior": "half-normal", "scale": 5.0}), relax,
            sigma0=None),
        "alpha free": build_log_posterior(alpha, ramp, sigma0=0.3),
        "exp": build_log_posterior(disc, jittered, sigma0=0.3, discrepancy_priors=prior),
        "matern32 on the strain": build_log_posterior(discrepancy_config("matern32", "strain"),
                                                      jittered, sigma0=0.3,
                                                      discrepancy_priors=discrepancy_priors(1.0)),
        "pinned relaxation": build_log_posterior(parse_config(pinned), relax, sigma0=0.3,
                                                 discrepancy_priors=prior),
        "orthogonal": build_log_posterior(disc, jittered, sigma0=0.3, discrepancy_priors=prior,
                                          columns=cols.V),
    }


def _walkers(post, k: int, seed: int, length: float) -> np.ndarray:
    """k walkers around the truth (the discrepancy's ``length``), in sampling coordinates."""
    center = {**TRUTH, **TRUTH_RELAX, "sigma0": 0.3, "alpha": 0.5, "disc_amplitude": 0.5,
              "disc_length": length}
    x = np.array([center[n] for n in post.names])
    z0 = post.priors.from_physical(x[None])
    rng = np.random.default_rng(seed)
    return z0 + 0.02 * rng.standard_normal((k, post.ndim)) * np.maximum(np.abs(z0), 1.0)


def test_the_log_posterior_of_the_same_walkers_does_not_depend_on_the_thread_count() -> None:
    """Bit for bit, 1 and 2 threads and a forked child (one thread, the serial functions): walker
    counts that group differently with 1 and 2 threads (lanes.lane_group), every compiled path.
    A resumed chain's log-probs once differed from its reference by 1 ulp on a busy machine."""
    posts = _posteriors()
    counts = (1, 3, 4, 7, 16, 17, 33)
    walkers = {name: [_walkers(post, k, i, 0.02 if "strain" in name else 12.0)
                      for i, k in enumerate(counts)] for name, post in posts.items()}

    def all_values(threads: int | None) -> dict[str, list[np.ndarray]]:
        if threads is not None:
            set_threads(threads)
        return {name: [post(z) for z in walkers[name]] for name, post in posts.items()}

    try:
        one, two = all_values(1), all_values(2)
    finally:
        set_threads(None)
    parent, child = in_parent_and_forked_child(lambda: all_values(None))
    for name in posts:
        for k, a, b, p, c in zip(counts, one[name], two[name], parent[name], child[name], strict=True):
            assert np.isfinite(a).sum() >= k - 1, (name, k)        # the walkers are mostly inside
            for other in (b, p, c):
                assert a.tobytes() == other.tobytes(), (name, k, np.max(np.abs(a - other)))
