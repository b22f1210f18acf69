"""sample(): outputs and their keys, reproducibility, refusal of stale chains, bad configs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from support.sampling import TRUTH, write_case

from bayes_dnlr.cli import main
from bayes_dnlr.config import ConfigError, load_config
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.mcmc.stopping import convergence
from bayes_dnlr.runs.chains import read_run
from bayes_dnlr.runs.sample import sample

CONTRACT_KEYS = {"parameters", "posterior", "posterior_correlation", "gauss_newton", "sigma0", "n_points",
                 "walkers", "steps", "autocorr_time", "wall_time_s", "standards", "deborah_max"}
POSTERIOR_KEYS = {"mean", "sd", "median", "hdi_90", "ess_bulk", "ess_tail", "r_hat"}
# One start for the fit each `sample` makes first: these synthetic ramps have one optimum, which the
# first start finds (every chain here was the same to the bit with fit's 8 restarts), and the
# restarts are fit's subject (tests/inference/lsq/test_identify.py), not these tests'; they cost each
# run 0.1-0.2 s of CPU.
ONE_START = {"fit": {"multistart": 0}}
# a short run of 300 points that stops at max_steps: the stopping rule's warnings and reproducibility
SHORT = {"n": 300, "sampler": {"max_steps": 60, "target_ess": 1e9, "checkpoint_every": 25},
         "extra": ONE_START}


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """One short run shared by several tests (300 steps at most; 300 points: the posterior of E is
    as close to the truth in its sd, for 0.8 s of CPU where 2000 points took 1.5 s)."""
    folder = tmp_path_factory.mktemp("quick")
    cfg_path = write_case(folder, n=300, extra=ONE_START,
                          sampler={"max_steps": 300, "target_ess": 300, "checkpoint_every": 50})
    cfg = load_config(cfg_path)
    post = sample(cfg, progress=False)
    return cfg, post


def test_outputs_and_summary_keys(quick_run) -> None:
    cfg, post = quick_run
    s = json.loads((cfg.run_dir / "summary.json").read_text())
    assert CONTRACT_KEYS <= set(s)
    assert s["parameters"] == ["E", "G", "tau_max"]
    for k in s["parameters"]:
        assert set(s["posterior"][k]) == POSTERIOR_KEYS
        lo, hi = s["posterior"][k]["hdi_90"]
        assert lo < s["posterior"][k]["median"] < hi
        assert s["autocorr_time"][k] > 1
    assert set(s["gauss_newton"]) >= {"estimate", "sd", "correlation", "delta_tilde"}
    assert np.asarray(s["posterior_correlation"]).shape == (3, 3)
    assert np.asarray(s["gauss_newton"]["delta_tilde"]).shape == (3, 3)
    assert s["walkers"] == 32 and s["n_points"] == 300 and s["sigma0"] == 0.3
    assert s["steps"] <= 300 and s["stop_reason"] in ("converged", "max_steps")
    assert set(s["standards"]) == {"iso527_1", "astm_d638"}
    # the posterior mean of E is close to the truth of the synthetic data (sd about 36 MPa)
    assert abs(s["posterior"]["E"]["mean"] - TRUTH["E"]) < 4 * s["posterior"]["E"]["sd"]
    assert post.summary == s


def test_datatree_holds_the_kept_draws_in_physical_units(quick_run) -> None:
    import arviz as az

    cfg, post = quick_run
    dt = az.from_netcdf(cfg.run_dir / "posterior.nc").load()
    run = read_run(cfg.run_dir / "chains.h5")
    burn = post.summary["burn_in"]
    tau = dt["posterior"]["tau_max"]
    assert dict(tau.sizes) == {"chain": 32, "draw": run.steps - burn}
    np.testing.assert_array_equal(tau.values, run.chain[burn:, :, 2].T)
    assert 3.0 < float(tau.mean()) < 10.0        # seconds, not ln(seconds)
    assert "lp" in dt["sample_stats"]
    assert post.datatree["posterior"]["E"].shape == (32, run.steps - burn)


def test_table_lists_every_parameter(quick_run) -> None:
    _, post = quick_run
    table = post.table()
    for k in ("E", "G", "tau_max", "R-hat", "ESS bulk", "Gauss-Newton", "90 % HDI", "tau"):
        assert k in table


def test_table_gives_the_verdict_one_check_per_line(quick_run) -> None:
    import copy
    import dataclasses

    _, post = quick_run
    checks = post.summary["checks"]
    lines = post.table().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("verdict: "))
    points = checks["verdict_points"]
    shown = []
    for line in lines[head + 1:]:           # the verdict's points, up to the next block (E(t)'s)
        if not line.startswith("  - "):
            break
        shown.append(line[4:])
    if len(points) >= 2:
        assert shown == points and " ".join([lines[head][9:], *points]) == checks["verdict"]
    else:
        assert shown == [] and lines[head] == f"verdict: {checks['verdict']}"
    # two checks with words: the first sentence, then one line each
    summary = copy.deepcopy(post.summary)
    two = ["The 90 % predictive band holds 12 % of the points.", "The chain has not converged."]
    summary["checks"].update(verdict="The model does not describe this test. " + " ".join(two),
                             verdict_points=two)
    lines = dataclasses.replace(post, summary=summary).table().splitlines()
    head = lines.index("verdict: The model does not describe this test.")
    assert lines[head + 1: head + 3] == [f"  - {t}" for t in two]


def test_finished_run_is_not_sampled_again(quick_run, capsys) -> None:
    cfg, post = quick_run
    chains = cfg.run_dir / "chains.h5"
    before = (chains.stat().st_mtime_ns, (cfg.run_dir / "summary.json").read_bytes())
    again = sample(load_config(cfg.source), progress=False)
    assert "nothing sampled" in again.note
    assert again.summary == post.summary
    assert (chains.stat().st_mtime_ns, (cfg.run_dir / "summary.json").read_bytes()) == before


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    """A run of SHORT, shared by the tests that read its chain or its warnings."""
    return sample(load_config(write_case(tmp_path_factory.mktemp("short"), **SHORT)), progress=False)


def test_same_seed_same_chain_other_seed_other_chain(tmp_path: Path, short_run) -> None:
    a = short_run
    b = sample(load_config(write_case(tmp_path / "b", **SHORT)), progress=False)
    other_seed = {**SHORT, "sampler": {**SHORT["sampler"], "seed": 7}}
    c = sample(load_config(write_case(tmp_path / "c", **other_seed)), progress=False)
    ca, cb, cc = (read_run(p.run_dir / "chains.h5") for p in (a, b, c))
    assert ca.steps == cb.steps == 60
    np.testing.assert_array_equal(ca.chain, cb.chain)
    np.testing.assert_array_equal(ca.log_prob, cb.log_prob)
    assert not np.array_equal(ca.chain, cc.chain)
    assert a.summary["stop_reason"] == "max_steps"
    assert any("not converged" in w for w in a.summary["warnings"])


def test_changed_config_or_data_is_refused_unless_restart(tmp_path: Path) -> None:
    path = write_case(tmp_path, n=300, sampler={"max_steps": 40, "target_ess": 1e9, "checkpoint_every": 20},
                      extra=ONE_START)
    sample(load_config(path), progress=False)
    raw = yaml.safe_load(path.read_text())
    raw["parameters"] = {"E": {"prior": "uniform", "low": 100, "high": 10000}}
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(RunError, match="parameters"):
        sample(load_config(path), progress=False)
    # max_steps is not part of the fingerprint: more steps extend the same chain
    raw = yaml.safe_load(path.read_text())
    raw.pop("parameters")
    raw["sampler"]["max_steps"] = 60
    path.write_text(yaml.safe_dump(raw))
    first = read_run(path.parent / "chains.h5").chain
    post = sample(load_config(path), progress=False)
    run = read_run(path.parent / "chains.h5")
    assert run.steps == 60 and post.summary["steps"] == 60
    np.testing.assert_array_equal(run.chain[:40], first)
    # another data file
    data = path.parent / "data.csv"
    data.write_text(data.read_text().replace("\n0,", "\n0.0,", 1) + "")
    lines = data.read_text().splitlines()
    lines[5] = lines[5] + "1"
    data.write_text("\n".join(lines) + "\n")
    with pytest.raises(RunError, match="data file"):
        sample(load_config(path), progress=False)
    post = sample(load_config(path), restart=True, progress=False)
    assert post.summary["steps"] == 60 and read_run(path.parent / "chains.h5").steps == 60


def test_sampled_sigma0(tmp_path: Path) -> None:
    path = write_case(tmp_path, noise={"prior": "half-normal", "scale": 5.0}, sigma=0.5,
                      sampler={"max_steps": 200, "target_ess": 1e9, "checkpoint_every": 100}, extra=ONE_START)
    post = sample(load_config(path), progress=False)
    s = post.summary
    assert s["parameters"] == ["E", "G", "tau_max", "sigma0"]
    assert s["sigma0_source"] == "sampled"
    assert s["posterior"]["sigma0"]["mean"] == pytest.approx(0.5, rel=0.05)
    assert s["sigma0"] == pytest.approx(s["posterior"]["sigma0"]["mean"])


def test_progress_bar_only_when_asked(tmp_path: Path, capsys) -> None:
    path = write_case(tmp_path, n=300, sampler={"max_steps": 20, "target_ess": 1e9, "checkpoint_every": 10},
                      extra=ONE_START)
    sample(load_config(path), progress=False)
    assert capsys.readouterr().err == ""
    sample(load_config(path), restart=True, progress=True)
    err = capsys.readouterr().err
    assert "step" in err and "20/20" in err


# ---------------------------------------------------------------- bad configs fail before sampling

def _bad(tmp_path: Path, mutate) -> tuple[int, str, Path]:
    path = write_case(tmp_path, sampler={"max_steps": 20, "checkpoint_every": 10})
    raw = yaml.safe_load(path.read_text())
    mutate(raw, path.parent)
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.parametrize(("mutate", "key"), [
    (lambda raw, d: raw["sampler"].update(walkrs=32), "sampler.walkrs"),
    (lambda raw, d: raw.update(parameters={"E": {"prior": "uniform", "low": 5000, "high": 100}}),
     "parameters.E"),
    (lambda raw, d: raw.update(parameters={"G": {"value": 2.3, "prior": "uniform", "low": 0,
                                                 "high": 5}}), "parameters.G"),
    (lambda raw, d: raw["sampler"].update(walkers=5), "sampler.walkers"),
    (lambda raw, d: (d / "data.csv").unlink(), "data.file"),
])
def test_bad_config_fails_before_sampling(tmp_path: Path, capsys, mutate, key: str) -> None:
    path = _bad(tmp_path, mutate)
    assert main(["sample", str(path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert key in err, err
    assert not (path.parent / "chains.h5").exists()
    assert not (path.parent / "fit.json").exists()


def test_walkers_check_counts_a_sampled_sigma0(tmp_path: Path) -> None:
    path = write_case(tmp_path, noise={"prior": "half-normal", "scale": 5.0},
                      sampler={"walkers": 7, "max_steps": 20})
    with pytest.raises(ConfigError, match=r"sampler\.walkers: 7 walkers for 4 sampled parameters"):
        sample(load_config(path), progress=False)


# ---------------------------------------------------------------- stopping rule

def test_convergence_rule_on_independent_draws() -> None:
    rng = np.random.default_rng(0)
    chain = rng.normal(size=(400, 32, 2))           # τ = 1: ESS = kept × walkers
    conv = convergence(chain, burn_in_tau=5, min_tau_multiple=50, target_ess=1000)
    assert conv.converged
    assert np.all(np.abs(conv.tau - 1.0) < 0.3)
    assert conv.burn_in <= 10 and conv.kept == 400 - conv.burn_in
    assert not convergence(chain, 5, 50, target_ess=1e6).converged
    # a strongly autocorrelated chain (AR(1), φ = 0.95: τ = 39) is not converged in 400 steps
    x = np.zeros((400, 32, 1))
    for i in range(1, 400):
        x[i] = 0.95 * x[i - 1] + rng.normal(size=(32, 1))
    conv = convergence(x, 5, 50, 1000)
    assert not conv.converged and conv.tau[0] > 15 and conv.needed_steps > 400


def test_one_sampler_per_run_directory(tmp_path: Path) -> None:
    from bayes_dnlr.runs.sample import _run_lock

    path = write_case(tmp_path, n=300, sampler={"max_steps": 20, "checkpoint_every": 10}, extra=ONE_START)
    cfg = load_config(path)
    with _run_lock(cfg.run_dir), pytest.raises(RunError, match="another `sample` is running"):
        sample(cfg, progress=False)
    assert not (cfg.run_dir / "chains.h5").exists()
    assert sample(cfg, progress=False).summary["steps"] == 20    # the lock is released


def test_sigma0_from_residuals_is_resolved_once_by_the_fit(tmp_path: Path) -> None:
    path = write_case(tmp_path, noise="residuals", sigma=0.4,
                      sampler={"max_steps": 40, "target_ess": 1e9, "checkpoint_every": 20}, extra=ONE_START)
    post = sample(load_config(path), progress=False)
    fit = json.loads((path.parent / "fit.json").read_text())
    assert post.summary["sigma0"] == fit["sigma0"]
    assert post.summary["sigma0_source"] == fit["sigma0_source"]
    assert fit["sigma0"] == pytest.approx(0.4, rel=0.05)
    assert post.summary["parameters"] == ["E", "G", "tau_max"]


def test_stale_fit_json_is_never_replaced_silently(tmp_path: Path) -> None:
    from bayes_dnlr.runs.fit import fit

    path = write_case(tmp_path, n=300, sampler={"max_steps": 40, "target_ess": 1e9, "checkpoint_every": 20},
                      extra=ONE_START)
    fit(load_config(path))
    before = (path.parent / "fit.json").read_text()
    raw = yaml.safe_load(path.read_text())
    raw["parameters"] = {"E": {"prior": "uniform", "low": 100, "high": 10000}}
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(RunError, match="fit.json was made from.*fit --force.*sample --restart"):
        sample(load_config(path), progress=False)
    assert (path.parent / "fit.json").read_text() == before
    assert not (path.parent / "chains.h5").exists()
    post = sample(load_config(path), restart=True, progress=False)
    assert post.summary["steps"] == 40
    assert (path.parent / "fit.json").read_text() != before


def test_not_converged_warning_names_the_failing_condition(short_run) -> None:
    text = " ".join(short_run.summary.get("warnings", []))
    assert "not converged: stopped at max_steps = 60" in text
    assert "ESS below 1000000000: E" in text
