"""`sample` never blocks a run: a stuck walker is a finding of the
stopping rule, not a NaN crash on every resume; walkers start inside the prior support even when
the estimate sits in a corner of the prior box; a stale fit.json names what `sample` offers."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
import yaml
from support.sampling import write_case

from bayes_dnlr.cli import main
from bayes_dnlr.config import load_config
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.mcmc.ensemble import start_ensemble
from bayes_dnlr.inference.mcmc.stopping import convergence, shortfall
from bayes_dnlr.inference.posterior.priors import Prior, PriorSet
from bayes_dnlr.runs.chains import read_run
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.runs.sample import sample

TINY = {"walkers": 12, "max_steps": 100, "target_ess": 50, "checkpoint_every": 50}


def _ar1(steps: int, walkers: int, ndim: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.zeros((steps, walkers, ndim))
    for i in range(1, steps):
        x[i] = 0.8 * x[i - 1] + rng.normal(size=(walkers, ndim))
    return x


def test_a_stuck_walker_is_a_finding_not_a_nan_crash():
    chain = _ar1(400, 12, 3)
    chain[:, 4, :] = chain[0, 4, :]             # walker 4 never moves (every proposal rejected)
    conv = convergence(chain, burn_in_tau=3, min_tau_multiple=10, target_ess=50)
    assert not conv.converged
    assert conv.stuck == {0: [4], 1: [4], 2: [4]}
    assert np.all(np.isfinite(conv.tau)) and isinstance(conv.needed_steps, int)
    text = shortfall(conv, ["E", "G", "tau_max"], 50, 10)
    assert "1 walker(s) (4) did not move in E, G, tau_max" in text
    # the same chain without the stuck walker converges: the stuck walker alone decides
    ok = convergence(np.delete(chain, 4, axis=1), burn_in_tau=3, min_tau_multiple=10, target_ess=50,
                     check_arviz=False)
    assert ok.converged and not ok.stuck


def test_a_parameter_no_walker_moves_in_gives_an_infinite_tau_not_nan():
    chain = _ar1(200, 8, 2)
    chain[:, :, 1] = 7.0                        # every walker frozen in the second parameter
    conv = convergence(chain, burn_in_tau=3, min_tau_multiple=10, target_ess=50)
    assert math.isinf(conv.tau[1]) and math.isfinite(conv.tau[0])
    assert conv.ess[1] == 0 and not conv.converged
    assert sorted(conv.stuck[1]) == list(range(8))
    assert conv.needed_steps > 200


def test_a_run_with_a_stuck_walker_resumes_and_finishes(tmp_path):
    """The chain of an interrupted run holds a walker that never moved: every resume crashed with
    'cannot convert float NaN to integer' before; now the run continues and finishes."""
    path = write_case(tmp_path, "stuck", n=300, sampler=TINY)
    cfg = load_config(path)
    sample(cfg, progress=False)
    chains = cfg.run_dir / "chains.h5"
    with h5py.File(chains, "r+") as f:          # walker 0 stuck for the whole chain, run interrupted
        f["chain"][:, 0, :] = f["chain"][-1, 0, :]
        f["log_prob"][:, 0] = f["log_prob"][-1, 0]
        f["accepted"][:, 0] = 0
        f.attrs["status"] = "running"
        if "finish" in f:                       # the finish record (chains format /2) is dropped
            f["finish"].resize((0,))
    stored = read_run(chains)
    assert not stored.finished
    conv = convergence(stored.chain, 3, 10, 50)
    assert all(ws == [0] for ws in conv.stuck.values())
    raw = yaml.safe_load(path.read_text())
    raw["sampler"]["max_steps"] = 150
    path.write_text(yaml.safe_dump(raw))
    post = sample(load_config(path), progress=False)
    run = read_run(chains)
    assert run.finished and run.steps == 150
    np.testing.assert_array_equal(run.chain[:100], stored.chain)
    assert post.summary["steps"] == 150
    assert main(["report", str(cfg.run_dir)]) == 0


def _box(ndim: int) -> PriorSet:
    names = ["E", "G", "tau_max", "sigma_inf", "tau_max_R"][:ndim]
    kinds = ["uniform", "uniform", "log-uniform", "uniform", "log-uniform"][:ndim]
    priors = []
    for name, kind in zip(names, kinds, strict=True):
        low, high = (0.01, 100.0) if kind == "log-uniform" else (0.0, 1.0)
        log_norm = math.log(math.log(high / low)) if kind == "log-uniform" else 0.0
        priors.append(Prior(name, kind, low, high, log_space=kind == "log-uniform", _log_norm=log_norm))
    return PriorSet(tuple(priors))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_walkers_start_inside_the_support_from_a_corner_of_the_prior_box(seed):
    """Estimate in the corner of a 5-D box (every parameter on its lower bound): 1 draw in 32
    lands inside, and 100 redraws left a walker outside for most seeds before."""
    priors = _box(5)
    x0 = np.array([p.low for p in priors.priors])
    cov = np.diag([0.1, 0.1, 1e-4, 0.1, 1e-4]) ** 2 * 100
    coords, lp = start_ensemble(priors.log_prior, priors, x0, cov, 32, seed)
    assert coords.shape == (32, 5) and np.all(np.isfinite(lp))
    x = priors.to_physical(coords)
    lo = np.array([p.low for p in priors.priors])
    hi = np.array([p.high for p in priors.priors])
    assert np.all(x >= lo) and np.all(x <= hi)
    assert len({tuple(c) for c in coords}) == 32                  # distinct walkers
    assert np.all(np.ptp(coords, axis=0) > 0)                     # no collapsed coordinate
    again, _ = start_ensemble(priors.log_prior, priors, x0, cov, 32, seed)
    np.testing.assert_array_equal(coords, again)                  # deterministic for a seed


def test_a_parameter_without_a_variance_still_gets_a_spread():
    priors = _box(3)
    x0 = np.array([0.5, 0.0, 1.0])
    cov = np.diag([1e-4, np.nan, 1e-6])
    cov[1, 0] = cov[0, 1] = np.nan
    coords, lp = start_ensemble(priors.log_prior, priors, x0, cov, 16, 5)
    assert np.all(np.isfinite(lp)) and np.all(coords[:, 1] >= 0) and np.ptp(coords[:, 1]) > 0
    assert np.std(coords[:, 0]) < 0.05


def test_a_changed_fit_method_points_at_what_sample_offers(tmp_path):
    path = write_case(tmp_path, "method", n=300, sampler=TINY)
    fit(load_config(path))
    raw = yaml.safe_load(path.read_text())
    raw["fit"] = {"method": "gauss-newton"}
    path.write_text(yaml.safe_dump(raw))
    cfg = load_config(path)
    with pytest.raises(RunError) as err:
        sample(cfg, progress=False)
    text = str(err.value)
    assert "pass --force" not in text and "sections fit" in text
    assert f"python -m bayes_dnlr fit --force {path}" in text and "sample --restart" in text
    assert not (cfg.run_dir / "chains.h5").exists()
    # following the advice works
    assert main(["fit", "--force", "--quiet", str(path)]) == 0
    assert sample(load_config(path), progress=False).summary["steps"] == TINY["max_steps"]


def test_the_independence_moves_are_left_out_where_the_linearization_meets_a_bound():
    """Inside the box the linearization is the independence moves' proposal (z0, an invertible root
    of the covariance in sampling coordinates); an estimate within 1 sd of a bound, or on it with
    no variance, is not clear of it: the posterior is cut there and the linearization is not."""
    from bayes_dnlr.inference.mcmc.ensemble import clear_of_bounds, linearized_root

    priors = _box(3)
    cov = np.diag([0.01, 0.01, 0.04]) ** 2
    x0 = np.array([0.5, 0.5, 1.0])
    z0, root = linearized_root(priors, x0, cov)
    np.testing.assert_allclose(z0, priors.from_physical(x0))
    np.testing.assert_allclose(root @ root.T, cov * np.outer(priors.jacobian(x0), priors.jacobian(x0)),
                               rtol=1e-10, atol=1e-14)
    assert clear_of_bounds(priors, z0, root)

    def clear(x, c=cov, which=None):
        return clear_of_bounds(priors, *linearized_root(priors, np.array(x), c), which)

    assert not clear([0.5, 0.005, 1.0])                    # 0.5 sd from 0
    assert clear([0.5, 0.015, 1.0])                        # 1.5 sd
    assert not clear([0.5, 0.5, 0.02])                     # log space: ln 0.02 - 2 < ln 0.01
    assert clear([0.5, 0.5, 0.05])                         # ln 0.05 - 0.8 > ln 0.01
    assert clear([0.5, 0.005, 1.0], which=[0, 2])          # the parameters asked about only
    held = np.diag([1e-4, np.nan, 1e-6])
    assert not clear([0.5, 0.0, 1.0], held)
