"""compare: Table 3/5 layout across runs and the consistency of E across strain rates."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from bayes_dnlr.cli import main
from bayes_dnlr.errors import RunError
from bayes_dnlr.report.compare import compare_runs, consistency_of_e

CONFIG = """name: {name}
data:
  file: missing.csv
  columns: {{time: t_s, strain: eps, stress: s}}
  observable: stress
"""


def make_run(root: Path, name: str, rate: float, e: float, sd: float, tau: float = 5.0,
             posterior: bool = True) -> Path:
    """A run directory with fit.json (and summary.json) only: compare needs no data then."""
    d = root / name
    d.mkdir()
    (d / "config.yaml").write_text(CONFIG.format(name=name))
    names = ["E", "G", "tau_max"]
    fit = {"parameters": names, "estimate": {"E": e + 1.0, "G": 2.3, "tau_max": tau},
           "sd": {"E": sd * 1.02, "G": 0.001, "tau_max": 0.03}, "strain_rate": rate,
           "deborah_max": tau * rate}
    (d / "fit.json").write_text(json.dumps(fit))
    if posterior:
        post = {k: {"mean": v, "sd": s, "median": v, "hdi_90": [v - 1.6 * s, v + 1.6 * s],
                    "ess_bulk": 1000, "ess_tail": 1000, "r_hat": 1.001}
                for k, v, s in (("E", e, sd), ("G", 2.3, 0.001), ("tau_max", tau, 0.03))}
        summary = {"parameters": names, "posterior": post, "standards": {"iso527_1": 0.65 * e,
                                                                         "astm_d638": 0.6 * e},
                   "deborah_max": tau * rate, "sigma0": 0.3}
        (d / "summary.json").write_text(json.dumps(summary))
        # posterior.nc: normal draws with these means and sds (16 walkers x 400 steps)
        from bayes_dnlr.runs.outputs import build_datatree

        rng = np.random.default_rng(int(rate * 1e6))
        draws = np.stack([rng.normal(v, s_, (400, 16)) for v, s_ in ((e, sd), (2.3, 0.001),
                                                                       (tau, 0.03))], axis=-1)
        build_datatree(names, draws, np.zeros((400, 16))).to_netcdf(d / "posterior.nc",
                                                                     engine="h5netcdf")
    return d


@pytest.fixture
def three_runs(tmp_path) -> list[Path]:
    root = tmp_path / "runs"
    root.mkdir()
    # given out of strain-rate order on purpose
    return [make_run(root, "b-5e-3", 5e-3, 2850.0, 15.0, 6.0),
            make_run(root, "c-1e-2", 1e-2, 2800.0, 25.0, 3.2),
            make_run(root, "a-2.5e-3", 2.5e-3, 2900.0, 20.0, 11.0)]


def test_table_and_consistency_by_hand(three_runs, tmp_path):
    out = tmp_path / "out"
    comp = compare_runs(three_runs, out)
    assert [r["run"] for r in comp.rows] == ["a-2.5e-3", "b-5e-3", "c-1e-2"]   # by strain rate
    # weights 1/sd²: 1/400, 1/225, 1/625
    w = [1 / 400, 1 / 225, 1 / 625]
    e = [2900.0, 2850.0, 2800.0]
    mean = sum(wi * ei for wi, ei in zip(w, e, strict=True)) / sum(w)          # 2855.26 MPa
    chi2 = sum(((ei - mean) / s) ** 2 for ei, s in zip(e, (20, 15, 25), strict=True))   # 10.01
    c = comp.consistency
    assert c.weighted_mean == pytest.approx(mean, rel=1e-12)
    assert c.chi2 == pytest.approx(chi2, rel=1e-12) and c.dof == 2
    assert c.p_value == pytest.approx(math.exp(-chi2 / 2), rel=1e-9)   # χ² with 2 dof: sf = e^(-x/2)
    assert c.max_pair_sd == pytest.approx(100 / math.sqrt(400 + 625), rel=1e-12)   # 3.12
    assert set(c.max_pair) == {"a-2.5e-3", "c-1e-2"}
    assert c.spread == pytest.approx(100 / mean)
    assert c.verdict.startswith("No:")
    md = (out / "compare.md").read_text()
    assert md == comp.markdown()
    assert "| E posterior (MPa) | 2900 ± 20 | 2850 ± 15 | 2800 ± 25 |" in md
    assert "| De_max = tau_max·ε̇ (eq. 45) | 0.0275 | 0.0300 | 0.0320 |" in md
    assert "| ISO 527-1 / E | 0.650 | 0.650 | 0.650 |" in md
    rows = list(csv.DictReader((out / "compare.csv").open()))
    assert [r["run"] for r in rows] == ["a-2.5e-3", "b-5e-3", "c-1e-2"]
    assert float(rows[0]["E_post"]) == 2900.0 and float(rows[2]["E_gn"]) == 2801.0
    assert "sigma_inf_post" not in rows[0]                    # columns with no value are dropped


def test_one_e_at_the_one_level_of_agreement():
    """p = 0.03: consistent at the package's one level (1 %), where compare's own 5 % said no."""
    from bayes_dnlr.inference.analyses.agreement import P_AGREE

    rows = [{"run": "x", "E_post": 2850.0, "E_post_sd": 20.0},
            {"run": "y", "E_post": 2911.4, "E_post_sd": 20.0}]
    c = consistency_of_e(rows)
    assert P_AGREE < c.p_value < 0.05 and c.verdict.startswith("Yes:")
    assert f"at the {100 * P_AGREE:.0f} % level" in c.verdict


def test_consistent_runs_say_yes(tmp_path):
    rows = [{"run": f"r{i}", "E_post": 2850.0 + d, "E_post_sd": 20.0} for i, d in enumerate((-5, 0, 5))]
    c = consistency_of_e(rows)
    assert c.chi2 == pytest.approx(2 * (5 / 20) ** 2)
    assert c.verdict.startswith("Yes:")
    assert consistency_of_e(rows[:1]).p_value is None


def test_gauss_newton_only_runs_and_cli(tmp_path, capsys, monkeypatch):
    root = tmp_path / "runs"
    root.mkdir()
    a = make_run(root, "a", 5e-3, 2850.0, 15.0, posterior=False)
    b = make_run(root, "b", 1e-2, 2860.0, 15.0, posterior=False)
    monkeypatch.chdir(tmp_path)
    assert main(["compare", str(a), str(b)]) == 0          # writes beside the runs, not into cwd
    printed = capsys.readouterr().out
    assert "E Gauss-Newton (MPa)" in printed and "Yes:" in printed
    assert "outputs: runs/compare.md, runs/compare.csv" in printed   # says where, as typed
    assert (root / "compare.md").is_file() and (root / "compare.csv").is_file()
    assert not (tmp_path / "compare.md").exists()
    assert "no posterior yet" in (root / "compare.md").read_text()
    with pytest.raises(RunError):
        compare_runs([tmp_path / "nope"])
    from bayes_dnlr.report.compare import default_out_dir

    assert default_out_dir([root / "a", tmp_path / "other" / "b"]) == tmp_path.resolve()
    with pytest.raises(RunError, match="give compare --out DIR"):      # never the filesystem root
        default_out_dir(["/nowhere-a/x/run1", "/nowhere-b/y/run2"])


def _posterior_runs(root, e_of_rate):
    """Three single runs at 2.5e-3, 5e-3, 1e-2 1/s whose E posteriors are normal draws."""
    dirs = []
    for i, rate in enumerate((2.5e-3, 5e-3, 1e-2)):
        d = make_run(root, f"r{i}", rate, e_of_rate(rate), 12.0, posterior=True)
        dirs.append(d)
    return dirs


@pytest.mark.parametrize(("label", "e_of_rate", "verdict"), [
    ("one E", lambda rate: 2854.0, "consistent"),
    ("10 % per decade", lambda rate: 2854.0 * 1.1 ** math.log10(rate / 5e-3), "rate-dependent"),
])
def test_the_rate_question_is_answered_from_the_posteriors(tmp_path, label, e_of_rate, verdict):
    dirs = _posterior_runs(tmp_path, e_of_rate)
    comp = compare_runs(dirs)
    assert comp.rate is not None and comp.rate.verdict == verdict, comp.rate.words
    md = (tmp_path / "compare.md").read_text()
    assert "Savage-Dickey" in md and "% per decade" in md
    assert "The paper's way" in md                      # the χ² table stays


def test_replicates_at_one_rate_get_no_trend_per_decade(tmp_path):
    """Three specimens at one nominal rate (measured 1.16-1.22e-3 1/s, as on a real ETFE export):
    a trend per decade over 0.02 decades read +4.5e19 %; the rate question is left out and says
    why, and the χ² comparison stays."""
    dirs = [make_run(tmp_path, f"s{i}", rate, 1600.0 + 40 * i, 260.0)
            for i, rate in enumerate((1.16e-3, 1.18e-3, 1.22e-3))]
    comp = compare_runs(dirs)
    assert comp.rate is None
    assert comp.rate_note.startswith("the strain rates (0.00116-0.00122 1/s) span a factor 1.05")
    md = (tmp_path / "compare.md").read_text()
    assert "No rate question: the strain rates" in md and "per decade" in md
    assert "trend of E" not in md and "Savage-Dickey" not in md
    assert "weighted mean of 3 runs" in md


def test_each_runs_verdict_gives_one_finding_per_line(tmp_path):
    """compare.md lists each check of a run's verdict on its own line, as the report and the console
    do; compare.csv keeps the whole verdict in one column and no column of the points."""
    root = tmp_path / "runs"
    root.mkdir()
    runs = [make_run(root, "a", 2.5e-3, 2850.0, 15.0), make_run(root, "b", 1e-2, 2860.0, 15.0)]
    points = ["The 90 % predictive band holds 98 % of the points.",
              "The posterior of disc_length piles against its prior's high bound."]
    head = "The model describes this test, but do not use E's interval as it is."
    summary_path = runs[0] / "summary.json"
    summary = json.loads(summary_path.read_text())
    summary["checks"] = {"adequate": True, "trust_interval": False,
                         "verdict": " ".join([head, *points]), "verdict_points": points}
    summary_path.write_text(json.dumps(summary))
    comp = compare_runs(runs, out_dir=tmp_path / "out")
    lines = comp.markdown().splitlines()
    at = lines.index(f"a: {head}  ")
    assert lines[at + 1: at + 3] == [f"  - {p}  " for p in points]
    rows = list(csv.DictReader(open(tmp_path / "out" / "compare.csv")))
    assert rows[0]["verdict"] == " ".join([head, *points])
    assert "verdict_points" not in rows[0]


def test_runs_of_two_materials_get_one_answer_each(tmp_path):
    """E is compared within a material, never across two; each run's material, trust and E(t)
    are in the table and in compare.csv; an answer drawn from an untrusted run says so."""
    from support.drawn_runs import drawn_run, modulus_entry

    root = tmp_path / "runs"
    root.mkdir()
    runs = [drawn_run(root, "a-slow", 1500.0, 20.0, material="A", rate=2.5e-3, seed=1,
                      modulus=[modulus_entry(10.0, 1200.0, 15.0)]),
            drawn_run(root, "b-fast", 2500.0, 20.0, material="B", rate=1e-2, seed=2,
                      modulus=[modulus_entry(10.0, 2000.0, 25.0, trust=False)]),
            drawn_run(root, "a-fast", 1510.0, 20.0, material="A", rate=1e-2, seed=3, trust=False,
                      modulus=[modulus_entry(10.0, 1210.0, 15.0)]),
            drawn_run(root, "b-slow", 2490.0, 20.0, material="B", rate=2.5e-3, seed=4,
                      modulus=[modulus_entry(10.0, 1990.0, 25.0)])]
    comp = compare_runs(runs, tmp_path / "out")
    assert [r["run"] for r in comp.rows] == ["a-slow", "a-fast", "b-slow", "b-fast"]   # material, rate
    assert set(comp.materials) == {"A", "B"}
    a, b = comp.materials["A"].consistency, comp.materials["B"].consistency
    assert a.n == b.n == 2 and abs(a.weighted_mean - 1505) < 20 and abs(b.weighted_mean - 2495) < 20
    assert comp.consistency.weighted_mean is None               # no E across the two materials
    assert "Only 1 of these 2 runs' own checks trust E's interval (not: a-fast)" in a.verdict
    assert "Only" not in b.verdict
    md = (tmp_path / "out" / "compare.md").read_text()
    assert "**Is E the same at every strain rate (A)?**" in md and "(B)?**" in md
    assert "| material | A | A | B | B |" in md
    assert "| E(t) posterior (MPa) | 1200 ± 15 | 1210 ± 15 | 1990 ± 25 | 2000 ± 25 |" in md
    assert "| E(t) trusted | yes | yes | yes | no |" in md
    # the one test of agreement on E(t) at the time every run of the material resolves
    assert ("E(10.0 s), the modulus the data determine, at the time every run resolves: the runs "
            "agree (Q = 0.2 on 1 degree of freedom, p = 0.64, I² = 0 %), pooled 1205 ± 11 MPa.") in md
    assert "the runs agree (Q = 0.1 on 1 degree of freedom" in md
    assert "Not trusted by their own checks there: b-fast." in md
    rows = list(csv.DictReader(open(tmp_path / "out" / "compare.csv")))
    assert [r["material"] for r in rows] == ["A", "A", "B", "B"]
    assert rows[1]["checks_fired"] == "model_form" and rows[1]["trust_interval"] == "False"
    assert rows[3]["Et_trust"] == "False" and float(rows[0]["Et_mean"]) == 1200.0
