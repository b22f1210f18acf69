"""The compiled kernel: step levels, the one-set stress, the parallel batch, threads,
and simulate's reuse of the prepared grid. The physics itself is held against Radau and closed
forms in test_dnlr.py; here every decay path is held against the same Radau reference."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from support.model import RELAX, TABLE3_5E3, jittered, ramp, reference, rel_err

import bayes_dnlr as bd
from bayes_dnlr.model import DNLR, cached_model, default_threads, get_threads, grid, kernel, set_threads
from bayes_dnlr.model import threads as threads_module
from bayes_dnlr.numba_cache import depend_on

NAMES = ["E", "G", "tau_max", "sigma_inf", "tau_max_R"]


def paths(model: DNLR) -> dict[str, int]:
    """How many steps of the model take each decay path."""
    g = model.kernel_args
    ig = g.level
    exact = np.zeros(ig.size, dtype=bool)
    exact[: g.n_tensile] = g.exact_t
    exact[g.n_tensile:] = g.exact_r
    return {"exact": int(exact.sum()), "level": int(((ig >= 0) & ~exact).sum()),
            "full exp": int((ig < 0).sum()), "rho != 0": int((g.steps[:, kernel.RHO] != 0).sum())}


def force_path(monkeypatch, path: str) -> None:
    """Make step_levels choose one path for jittered grids."""
    if path == "level":
        monkeypatch.setattr(grid, "MIN_LEVEL_COUNT", 1)
    elif path == "full exp":
        monkeypatch.setattr(grid, "MIN_LEVEL_COUNT", 10**9)


# ------------------------------------------------------------------------- the decay routines

def test_decay_is_exp_to_a_few_ulp():
    x = np.concatenate([np.linspace(0.0, 40.0, 20001), np.geomspace(1e-18, 1.0, 500)])
    a = np.empty_like(x)
    om = np.empty_like(x)
    for i, xi in enumerate(x):
        a[i], om[i] = kernel.decay(xi)
    assert np.max(np.abs(a / np.exp(-x) - 1)) < 5e-16
    pos = x > 0
    assert np.max(np.abs(om[pos] / -np.expm1(-x[pos]) - 1)) < 1e-15    # 1 - e^-x, also for tiny x
    assert om[x == 0].tolist() == [0.0]


def test_level_correction_matches_expm1():
    # 1 - exp(-ρ/tau) by Horner in 1/tau with the step's coefficients; |ρ/tau| <= 0.2 by design
    rng = np.random.default_rng(4)
    rho = rng.uniform(-1e-3, 1e-3, 4000)
    itau = np.abs(rho).max() ** -1 * rng.uniform(0.0, 0.2, 4000)
    z = rho * itau
    u = np.array([kernel._one_minus_exp_small(it, *kernel._rho_powers(r))
                  for it, r in zip(itau, rho, strict=True)])
    exact = -np.expm1(-z)
    # truncation after z^6/6!: the error is |z|^7/7! (1 + O(z)), plus rounding
    assert np.all(np.abs(u - exact) <= 1.3 * np.abs(z) ** 7 / 5040 + 4e-16 * np.abs(exact))


# -------------------------------------------------------------------------------- step levels

def test_step_levels_exact_for_few_distinct_steps():
    steps = np.tile([0.1, 0.2, 0.15], 100)
    levels, index, rho, exact = grid.step_levels(steps)
    assert exact and levels.tolist() == [0.1, 0.15, 0.2]
    np.testing.assert_array_equal(levels[index], steps)
    assert not rho.any()


def test_step_levels_quantize_jitter_within_spacing():
    steps = 0.19 * (1 + np.random.default_rng(0).uniform(-0.15, 0.15, 5000))
    levels, index, rho, exact = grid.step_levels(steps)
    assert not exact
    assert 50 <= levels.size <= 70                        # ln(1.35)/0.005 = 60 levels
    ok = index >= 0
    np.testing.assert_allclose(levels[index[ok]] + rho[ok], steps[ok], rtol=1e-15)
    assert np.max(np.abs(rho[ok]) / levels[index[ok]]) <= np.expm1(grid.LEVEL_SPACING / 2) * (1 + 1e-9)
    counts = np.bincount(index[ok])
    assert counts.min() >= grid.MIN_LEVEL_COUNT
    # the level count does not grow with the number of steps: work memory is O(N·levels)
    more = 0.19 * (1 + np.random.default_rng(1).uniform(-0.15, 0.15, 200_000))
    assert grid.step_levels(more)[0].size <= levels.size + 2


def test_prepared_grid_is_linear_in_q():
    sizes = {}
    for q in (1000, 16000):
        t, e = jittered(q, 0.15)
        m = DNLR(t, e)
        sizes[q] = sum(a.nbytes for a in m.kernel_args if isinstance(a, np.ndarray))
        levels = m.kernel_args.levels.size
        assert levels < 80
    per_point = (sizes[16000] - sizes[1000]) / 15000
    # 6 floats, ln Δ (the shifted model's reduced steps) and one index per step
    assert per_point <= 8 * 8 + 1


# ------------------------------------------------------- every decay path against Radau

RADAU_PARAMS = {**RELAX, "tau_max_R": 40.0}


@pytest.fixture(scope="module")
def jittered_radau():
    """The jittered ramp and hold, and its Radau reference (seconds of solve_ivp): computed once for
    the three decay paths, which must all give it."""
    t, e = jittered(160, 0.15, hold=250.0, n_hold=60)
    return t, e, reference(t, e, RADAU_PARAMS, relaxation_start=380.0)


@pytest.mark.parametrize("path", ["default", "level", "full exp"])
def test_jittered_ramp_then_hold_against_radau_on_every_path(monkeypatch, path, jittered_radau):
    t, e, ref = jittered_radau
    force_path(monkeypatch, path)
    model = DNLR(t, e, relaxation_start=380.0)
    used = paths(model)
    if path == "level":
        assert used["level"] == t.size - 1 and used["rho != 0"] > 0.9 * used["level"]
    elif path == "full exp":
        assert used["full exp"] == t.size - 1
    params = RADAU_PARAMS
    s = model.stress(params)
    assert rel_err(s[1:], ref[1:]) < 1e-8
    b = model.basis(params["tau_max"], params["tau_max_R"]).values
    via_basis = params["E"] * b[:, 0] + params["G"] * b[:, 1] + params["sigma_inf"] * b[:, 2]
    assert rel_err(via_basis[1:], ref[1:]) < 1e-8


def test_paths_agree_with_each_other(monkeypatch):
    t, e = jittered(1200, 0.15, seed=5, hold=300.0, n_hold=400)
    out = {}
    for path in ("level", "full exp"):
        with monkeypatch.context() as mp:
            force_path(mp, path)
            out[path] = DNLR(t, e, relaxation_start=380.0).stress(RELAX)
    scale = np.abs(out["full exp"]).max()
    assert np.max(np.abs(out["level"] - out["full exp"])) < 1e-13 * scale


def test_uniform_grid_takes_the_exact_path():
    t, e = ramp(5e-3, 1.9, 2000)
    used = paths(DNLR(t, e))
    assert used["exact"] == t.size - 1 and used["rho != 0"] == 0


# ------------------------------------------------------------ stress_into against the basis

def grids():
    t, e = ramp(5e-3, 2.0, 300, hold=200.0, n_hold=100)
    yield "uniform, hold", t, e, 400.0
    t, e = jittered(2000, 0.15, hold=300.0, n_hold=500)
    yield "jittered, hold", t, e, 380.0
    t, e = jittered(150, 0.3)
    yield "jittered short", t, e, None
    t = np.linspace(0.0, 100.0, 101)
    yield "relaxation from the first step", t, np.full(t.size, 0.2), -1.0


@pytest.mark.parametrize("tau", [(0.3, 0.1), (5.79, 40.0), (300.0, 2000.0)])
@pytest.mark.parametrize("case", list(grids()), ids=lambda c: c[0])
def test_stress_into_equals_basis_combination(case, tau):
    _, t, e, t_switch = case
    model = DNLR(t, e, relaxation_start=t_switch)
    params = {"E": 2854.0, "G": 2.32, "tau_max": tau[0], "sigma_inf": 75.0, "tau_max_R": tau[1]}
    b = model.basis(tau[0], tau[1] if model.has_relaxation else None).values
    via_basis = params["E"] * b[:, 0] + params["G"] * b[:, 1]
    if model.has_relaxation:
        via_basis += params["sigma_inf"] * b[:, 2]
    s = model.stress(params)
    assert np.max(np.abs(s - via_basis) / np.maximum(np.abs(via_basis), 1e-3)) < 1e-12


def test_gradients_on_quantized_levels_match_finite_differences(monkeypatch):
    monkeypatch.setattr(grid, "MIN_LEVEL_COUNT", 1)
    t, e = jittered(400, 0.15, hold=200.0, n_hold=100)
    m = DNLR(t, e, relaxation_start=380.0)
    assert paths(m)["level"] > 0.9 * (t.size - 1)     # the rest: steps > 2x the shortest
    b = m.basis(5.79, 40.0, grad=True)
    step = 1e-5
    lt, lr = np.log(5.79), np.log(40.0)
    fd_t = (m.basis(np.exp(lt + step), 40.0).values - m.basis(np.exp(lt - step), 40.0).values) / (2 * step)
    fd_r = (m.basis(5.79, np.exp(lr + step)).values - m.basis(5.79, np.exp(lr - step)).values) / (2 * step)
    scale = np.abs(b.values).max(axis=0) + 1e-30
    assert np.max(np.abs(b.grad_tau_max - fd_t) / scale) < 1e-7
    assert np.max(np.abs(b.grad_tau_max_R - fd_r) / scale) < 1e-7


# ----------------------------------------------------------------- the calling convention

# cached on disk as the package's compiled functions are (3 s of compiling in every session), and
# keyed also on the kernel's source, which it compiles into itself (numba_cache.depend_on)
@njit(cache=True)
def _loop_over_sets(theta, prepared, out):
    # theta columns in NAMES order (E, G, tau_max, sigma_inf, tau_max_R); stress_into takes
    # (E, G, sigma_inf, tau_max, tau_max_R, alpha)
    ok = 0
    for r in range(theta.shape[0]):
        ok += kernel.stress_into(theta[r, 0], theta[r, 1], theta[r, 3], theta[r, 2], theta[r, 4],
                                 0.5, prepared, out[r])
    return ok


depend_on(_loop_over_sets, kernel)


def sets(k: int, seed: int = 2) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(2000, 3000, k), rng.uniform(1, 3, k), rng.uniform(2, 10, k),
                            rng.uniform(50, 100, k), rng.uniform(10, 50, k)])


def test_stress_into_from_other_njit_code_follows_the_documented_convention():
    t, e = jittered(500, 0.15, hold=100.0, n_hold=50)
    m = DNLR(t, e, relaxation_start=380.0)
    theta = sets(6)
    out = np.empty((6, m.n_points))
    assert _loop_over_sets(theta, m.kernel_args, out) == 6
    np.testing.assert_array_equal(out, m.stress_batch(theta, NAMES))
    for k in range(6):
        np.testing.assert_array_equal(out[k], m.stress(dict(zip(NAMES, theta[k], strict=True))))


def test_invalid_time_constants_give_nan_and_false_not_a_crash():
    t, e = ramp(5e-3, 1.0, 100, hold=50.0, n_hold=20)
    m = DNLR(t, e, relaxation_start=200.0)
    out = np.zeros(m.n_points)
    for bad in ((-1.0, 10.0), (np.nan, 10.0), (5.0, 0.0), (5.0, np.inf)):
        assert not kernel.stress_into(2000.0, 2.0, 50.0, bad[0], bad[1], 0.5, m.kernel_args, out)
        assert np.isnan(out).all()
    theta = sets(3)
    theta[1, 4] = -3.0
    with pytest.raises(ValueError, match="row 1 of theta"):
        m.stress_batch(theta, NAMES)
    tensile = DNLR(t, e)      # no relaxation: tau_max_R is ignored
    assert kernel.stress_into(2000.0, 2.0, 0.0, 5.0, -1.0, 0.5, tensile.kernel_args, out)


# ------------------------------------------------------------------------ batch and threads

def test_batch_is_bit_identical_with_one_and_two_threads():
    t, e = jittered(3000, 0.15, hold=200.0, n_hold=300)
    m = DNLR(t, e, relaxation_start=380.0)
    theta = sets(9)
    before = get_threads()
    try:
        assert set_threads(1) == 1
        one = m.stress_batch(theta, NAMES)
        two_threads = set_threads(2)
        two = m.stress_batch(theta, NAMES)
    finally:
        set_threads(before)
    assert two_threads == min(2, threads_module.available_threads())
    np.testing.assert_array_equal(one, two)
    for k in (0, 4, 8):
        np.testing.assert_array_equal(one[k], m.stress(dict(zip(NAMES, theta[k], strict=True))))


def test_batch_names_in_any_order_and_tensile_only():
    t, e = ramp(5e-3, 1.9, 400)
    m = DNLR(t, e)
    theta = sets(4)[:, [2, 0, 1]]            # tau_max, E, G
    out = m.stress_batch(theta, ["tau_max", "E", "G"])
    for k in range(4):
        np.testing.assert_array_equal(
            out[k], m.stress({"E": theta[k, 1], "G": theta[k, 2], "tau_max": theta[k, 0]}))


def test_set_threads_validates_and_caps(monkeypatch):
    before = get_threads()
    try:
        with pytest.raises(ValueError, match=">= 1"):
            set_threads(0)
        with pytest.raises(ValueError, match="positive integer"):
            set_threads(1.5)
        assert set_threads(10**6) == threads_module.available_threads()
        monkeypatch.setenv("OMP_NUM_THREADS", "1")
        assert default_threads() == 1
        assert set_threads() == 1 and get_threads() == 1
        monkeypatch.setenv("OMP_NUM_THREADS", "junk")
        assert default_threads() == threads_module.available_threads()
    finally:
        set_threads(before)


def test_omp_num_threads_is_honoured_in_a_fresh_process():
    import os
    import subprocess
    import sys

    code = ("import numpy as np\nfrom bayes_dnlr.model import DNLR, get_threads\n"
            "m = DNLR(np.linspace(0, 10, 50), np.linspace(0, 0.05, 50))\n"
            "m.stress_batch(np.array([[2000.0, 2.0, 5.0]]), ['E', 'G', 'tau_max'])\n"
            "print(get_threads())\n")
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=env).stdout
    assert out.strip() == "1"


# ----------------------------------------------------------------------- simulate's cache

def test_simulate_reuses_the_model_and_never_goes_stale():
    t, e = jittered(300, 0.15)
    first = bd.simulate(t, e, TABLE3_5E3)
    model = cached_model(t, e)
    assert cached_model(t.copy(), e.copy()) is model            # same values: same model
    np.testing.assert_array_equal(bd.simulate(t, e, TABLE3_5E3), first)
    e[150:] *= 1.01                                              # changed in place
    changed = bd.simulate(t, e, TABLE3_5E3)
    assert cached_model(t, e) is not model
    np.testing.assert_array_equal(changed, DNLR(t, e).stress(TABLE3_5E3))
    assert not np.array_equal(changed, first)
    assert cached_model(t, e, modes=20) is not cached_model(t, e)
    np.testing.assert_array_equal(bd.simulate(t, e, TABLE3_5E3, modes=20),
                                  DNLR(t, e, modes=20).stress(TABLE3_5E3))


def test_simulate_cache_keeps_the_last_inputs_only():
    models = [cached_model(np.linspace(0, 10 + k, 30), np.linspace(0, 0.05, 30)) for k in range(12)]
    assert cached_model(np.linspace(0, 21, 30), np.linspace(0, 0.05, 30)) is models[-1]
    assert cached_model(np.linspace(0, 10, 30), np.linspace(0, 0.05, 30)) is not models[0]
    with pytest.raises(ValueError, match="increase strictly"):
        cached_model(np.array([0.0, 1.0, 1.0]), np.zeros(3))


_FRESH_OR_CACHED = r"""
import hashlib, sys
import numpy as np
from bayes_dnlr.model import DNLR
rng = np.random.default_rng(3)
for jitter, wiggle in ((0.0, 0.0), (0.0, 1e-4), (0.15, 1e-4)):
    h = 0.95 * (1 + jitter * rng.uniform(-1, 1, 399))
    t = np.concatenate([[0.0], np.cumsum(h)])
    m = DNLR(t, 5e-3 * t + wiggle * np.sin(t / 7.0), 50, 6)
    print(hashlib.sha256(m.stress({"E": 2854.0, "G": 2.32, "tau_max": 5.79}).tobytes()).hexdigest())
"""


@pytest.mark.slow
def test_the_first_compile_and_the_cached_code_give_the_same_stress(tmp_path) -> None:
    """The stress of a process that compiles the kernel and of one that loads it from numba's cache
    are the same to the bit, on uniform and jittered grids (with fused multiply-adds allowed, the
    two differed by 1 ulp on uniform grids, and so did the first run's chain from every later one)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    runs = [subprocess.run([sys.executable, "-c", _FRESH_OR_CACHED], env=env, capture_output=True,
                           text=True, check=True).stdout.split() for _ in range(2)]
    assert any(tmp_path.rglob("*.nbi"))             # the second run loaded what the first compiled
    assert len(runs[0]) == 3
    assert runs[0] == runs[1]


def test_the_kernel_does_not_contract_into_fused_multiply_adds() -> None:
    """The cheap guard of the test above (which compiles the kernel afresh, minutes of the slow
    suite): "contract" is what made compiled and cached code differ."""
    assert "contract" not in kernel.FASTMATH
