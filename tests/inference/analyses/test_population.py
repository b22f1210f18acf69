"""Specimens as a population: the two-stage method, the `population` command on
finished runs, its named errors, and (slow) the coverage of mu_E and s_E."""

from __future__ import annotations

import json

import numpy as np
import pytest
from support.forking import in_parent_and_forked_child
from support.population import MU, PRIOR, S, coverage, draw_population
from support.runs import make_run, ramp_truth

E_SPECIMENS = (2700.0, 2850.0, 3000.0)



def test_two_stage_recovers_a_known_population_and_shrinks():
    from bayes_dnlr.inference.analyses.population import population

    rng = np.random.default_rng(3)
    draws = draw_population(rng, 8)
    pop = population(draws, dict.fromkeys(draws, PRIOR))
    assert abs(pop.mu["mean"] - MU) < 3 * pop.mu["sd"]
    assert pop.s["hdi_90"][0] < S < pop.s["hdi_90"][1]
    assert pop.passed
    for k in draws:
        own, shrunk = pop.specimens[k]["own"], pop.specimens[k]["shrunk"]
        # shrunk towards the population mean (the same draws, reweighted), and less uncertain
        assert abs(shrunk["mean"] - pop.mu["mean"]) <= abs(own["mean"] - pop.mu["mean"])
        assert shrunk["sd"] <= own["sd"]


def test_specimens_that_agree_leave_the_spread_unresolved_and_the_page_says_so():
    """Three specimens 1 sd apart: the HDI of s starts at 0 and the page says s is only bounded;
    eight specimens 100 MPa apart with 25-60 MPa posteriors resolve it, and the page is silent."""
    from bayes_dnlr.inference.analyses.population import population
    from bayes_dnlr.workflows.population.page import markdown
    from bayes_dnlr.workflows.population.run import UNLABELLED, PopulationRun

    rng = np.random.default_rng(7)
    agree = {f"s{k}": rng.normal(1600.0 + 50.0 * k, 260.0, 4000) for k in range(3)}
    pop = population(agree, dict.fromkeys(agree, PRIOR))
    assert not pop.spread_resolved and pop.to_dict()["s_resolved"] is False
    page = markdown(PopulationRun({UNLABELLED: pop}, {}, {}, wall_time_s=0.1))
    assert "s is consistent with no spread at all, and 3 specimens only bound it" in page
    draws = draw_population(np.random.default_rng(3), 8)
    apart = population(draws, dict.fromkeys(draws, PRIOR))
    assert apart.spread_resolved
    assert "consistent with no spread" not in markdown(PopulationRun({UNLABELLED: apart}, {}, {},
                                                                     wall_time_s=0.1))


def test_monte_carlo_check_fails_with_too_few_draws():
    """A population far narrower than each specimen's posterior leaves few effective draws."""
    from bayes_dnlr.inference.analyses.population import population

    rng = np.random.default_rng(5)
    draws = {f"s{k}": rng.normal(2850.0 + rng.normal(0, 1.0), 400.0, 60) for k in range(8)}
    pop = population(draws, dict.fromkeys(draws, PRIOR))
    mc = pop.to_dict()["monte_carlo_check"]
    assert set(mc) >= {"effective_draws", "log_likelihood_variance", "passed"}
    assert min(pop.effective_draws.values()) < 60


def test_a_forked_child_computes_the_grid_in_one_thread_with_the_same_values():
    """numba terminates a forked child that starts a parallel region when its parent used GNU
    OpenMP (a batch forked by a fork server warms this function up): after a threaded call here,
    a forked child takes the serial driver and gets the same grid."""
    from bayes_dnlr.inference.analyses.population import add_log_mean_weight

    rng = np.random.default_rng(4)
    x, logpi = rng.normal(MU, 50.0, 300), np.full(300, -7.0)
    mu_grid, s_grid = np.linspace(MU - 300, MU + 300, 40), np.linspace(5.0, 200.0, 30)

    def grid() -> np.ndarray:
        logL = np.zeros((mu_grid.size, s_grid.size))
        add_log_mean_weight(x, logpi, mu_grid, s_grid, logL)
        return logL

    parent, child = in_parent_and_forked_child(grid)
    np.testing.assert_array_equal(child, parent)


def test_grid_posterior_of_s_matches_the_exact_one():
    """Normal specimens (own sd 25 MPa, flat prior): L(μ, s) = Π N(c_k | μ, s² + 25²) exactly. The
    grid's posterior mean and HDI of s agree with that posterior's on a fine uniform grid (the
    first grid's s points are not equally spaced: each is weighted by its cell)."""
    from bayes_dnlr.inference.analyses.population import population

    rng = np.random.default_rng(21)
    centres = rng.normal(MU, 100.0, 6)
    draws = {f"s{k}": rng.normal(c, 25.0, 1000) for k, c in enumerate(centres)}
    pop = population(draws, dict.fromkeys(draws, PRIOR))
    mu = np.linspace(MU - 600, MU + 600, 1201)[:, None]
    s = np.linspace(0.05, 800.0, 4000)[None, :]
    v = s * s + 25.0 ** 2
    logp = sum(-0.5 * (c - mu) ** 2 / v - 0.5 * np.log(v) for c in centres)
    logp = logp - 0.5 * (s / pop.s_prior_scale) ** 2
    ps = np.exp(logp - logp.max()).sum(axis=0)
    ps /= ps.sum()
    exact_mean = float(ps @ s[0])
    assert pop.s["mean"] == pytest.approx(exact_mean, rel=0.03)
    cdf = np.cumsum(ps)
    assert pop.s["median"] == pytest.approx(float(np.interp(0.5, cdf, s[0])), rel=0.03)


def test_many_specimens_get_a_grid_fine_enough_for_their_narrow_posterior(tmp_path):
    """A batch of 150 specimens: μ's sd (about 8 MPa) is below the first grid's step (about 13 MPa);
    the second, zoomed grid resolves it: μ's 90 % HDI is 2 × 1.645 sd wide, as for a normal. 25
    draws per specimen: the figures checked are those of 100 draws within 1 % (over 8 seeds), and
    cost a quarter."""
    from bayes_dnlr.inference.analyses.population import population

    rng = np.random.default_rng(11)
    centres = rng.normal(MU, 100.0, 150)
    draws = {f"s{k}": rng.normal(c, 25.0, 25) for k, c in enumerate(centres)}
    pop = population(draws, dict.fromkeys(draws, PRIOR))
    step = float(np.diff(pop.grid["mu"])[0])
    expected_sd = float(np.hypot(centres.std(ddof=1), 25.0) / np.sqrt(centres.size))
    assert step < pop.mu["sd"] / 5
    assert pop.mu["sd"] == pytest.approx(expected_sd, rel=0.15)
    lo, hi = pop.mu["hdi_90"]
    assert hi - lo == pytest.approx(2 * 1.645 * pop.mu["sd"], rel=0.1)
    assert abs(pop.mu["median"] - pop.mu["mean"]) < 0.2 * pop.mu["sd"]
    assert pop.s["hdi_90"][0] < 100.0 < pop.s["hdi_90"][1]
    # the figure of a batch this size keeps a readable height (rows narrower past 40 specimens)
    from PIL import Image

    from bayes_dnlr.workflows.population.page import figure
    from bayes_dnlr.workflows.population.run import UNLABELLED, PopulationRun

    png = figure(PopulationRun({UNLABELLED: pop}, {k: k for k in draws}, dict.fromkeys(draws, "")),
                 tmp_path / "p.png")
    assert Image.open(png).size[1] < 3000                  # 70 inches (7700 px) with 8 specimens' rows


@pytest.fixture(scope="module")
def specimens(tmp_path_factory):
    """Three finished single-test runs with different true E (tiny chains)."""
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.sample import sample

    root = tmp_path_factory.mktemp("pop")
    dirs = []
    for i, e in enumerate(E_SPECIMENS, start=1):
        truth = ramp_truth(0.5, n_points=150, params={"E": e, "G": 2.32, "tau_max": 5.79})
        truth["seed"] = 40 + i
        path = make_run(root, f"spec-{i}", truth, sampler={"max_steps": 200, "target_ess": 100})
        sample(load_config(path), progress=False)
        dirs.append(path.parent)
    return root, dirs


def test_population_command_writes_json_md_and_figure(specimens, cli_here):
    root, dirs = specimens
    r = cli_here("population", *map(str, dirs))
    assert r.returncode == 0, r.stderr
    data = json.loads((root / "population.json").read_text())
    assert data["specimens"] == ["spec-1", "spec-2", "spec-3"]
    assert data["truth"] == {f"spec-{i}": e for i, e in enumerate(E_SPECIMENS, start=1)}
    assert data["mu"]["hdi_90"][0] < np.mean(E_SPECIMENS) < data["mu"]["hdi_90"][1]
    assert data["s"]["mean"] > 50           # the specimens differ by 150 MPa, far beyond their sd
    assert data["monte_carlo_check"]["passed"]
    assert "two-stage" in data["method"]
    for k in data["specimens"]:
        assert {"own", "shrunk"} <= set(data["shrunk"][k])
    assert (root / "population.png").stat().st_size > 10_000
    md = (root / "population.md").read_text()
    assert "Monte Carlo check: passed" in md
    # E 5 % apart, E(2 s) far beyond their sd: the tests do not agree, so no "E of the material"
    het = data["heterogeneity"]
    assert het["quantity"] == "E(2.00 s)" and het["passed"] is False and het["I2"] > 0.9
    assert "E of the material" not in md and "Pooled E of these 3 tests (not shown as a material's" in md
    assert "**E(2.00 s) of these 3 tests (not a material's):" in md
    # the same runs again: the same file, no refusal
    assert cli_here("population", *map(str, dirs)).returncode == 0


def _one_error(r) -> str:
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    return lines[0]


def test_population_never_replaces_a_result_from_other_runs(specimens, tmp_path, cli_here):
    root, dirs = specimens
    out = tmp_path / "out"
    assert cli_here("population", *map(str, dirs), "--out", str(out)).returncode == 0
    before = (out / "population.json").read_text()
    line = _one_error(cli_here("population", *map(str, dirs[:2]), "--out", str(out)))
    assert "population.json exists and was made from other runs" in line and "--force" in line
    assert (out / "population.json").read_text() == before
    assert cli_here("population", *map(str, dirs[:2]), "--out", str(out), "--force").returncode == 0
    assert json.loads((out / "population.json").read_text())["specimens"] == ["spec-1", "spec-2"]


def test_population_errors_name_the_run(specimens, tmp_path, cli_here):
    root, dirs = specimens
    assert "at least two" in _one_error(cli_here("population", str(dirs[0]), "--out", str(tmp_path)))
    assert "given twice" in _one_error(cli_here("population", str(dirs[0]), str(dirs[0]),
                                           "--out", str(tmp_path)))
    unfinished = make_run(tmp_path, "raw", ramp_truth(0.5, n_points=150)).parent
    line = _one_error(cli_here("population", str(dirs[0]), str(unfinished), "--out", str(tmp_path)))
    assert str(unfinished) in line and "not a finished run" in line
    assert not (tmp_path / "population.json").exists()


@pytest.mark.slow
def test_population_coverage_reduced():
    """20 populations of 8 specimens (benchmarks/population.py runs 100): each 90 % interval holds
    the truth in at least 14 of 20 (P(X ≤ 13) = 0.002 for a calibrated 90 % interval) and at
    most 20."""
    c = coverage(20, seed0=5000)
    assert c["mu"] >= 0.7 and c["s"] >= 0.7, c
    assert c["mc_passed"] == 1.0
