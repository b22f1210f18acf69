"""The report of a small run: every figure a valid PNG, the tables hold summary.json's numbers,
flags where posterior and linearization disagree, the fit-only case, cross-checks (Table 4)."""

from __future__ import annotations

import json
import re
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest

from bayes_dnlr.config import load_config
from bayes_dnlr.model import simulate
from bayes_dnlr.numbers import fmt, fmt_at
from bayes_dnlr.report import build_report

FIGURES = {"corner.png", "fit.png", "sensitivity.png", "sensitivity_xy.png", "trace.png", "rank.png",
           "acf.png", "modulus.png"}
CONFIG = """name: tiny
data:
  file: tiny.csv
  columns: {time: t_s, strain: eps, stress: s}
  observable: stress
noise: {sigma0: 0.3}
sampler: {walkers: 12, max_steps: 300, target_ess: 100, seed: 1, checkpoint_every: 100}
truth:
  params: {E: 2854.0, G: 2.32, tau_max: 3.15}
  strain_rate: 1.0e-2
  strain_max: 1.0
  n_points: 300
"""


def _png_size(path: Path) -> tuple[int, int]:
    """Width and height from a PNG's signature and IHDR chunk (raises if it is not a PNG)."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n", f"{path.name} is not a PNG"
    assert head[12:16] == b"IHDR"
    return struct.unpack(">II", head[16:24])


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    """A 300-point synthetic test (E 2854, G 2.32, tau_max 3.15 at 1e-2 1/s) fitted and sampled."""
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.sample import sample

    d = tmp_path_factory.mktemp("runs") / "tiny"
    d.mkdir()
    rate, n = 1e-2, 300
    t = np.linspace(0.0, 1.0 / rate, n)
    eps = rate * t
    s = simulate(t, eps, {"E": 2854.0, "G": 2.32, "tau_max": 3.15})
    rng = np.random.default_rng(0)
    np.savetxt(d / "tiny.csv", np.column_stack([t, eps + rng.normal(0, 1e-4, n), s + rng.normal(0, 0.3, n)]),
               delimiter=",", header="t_s,eps,s", comments="")
    (d / "config.yaml").write_text(CONFIG)
    cfg = load_config(d / "config.yaml")
    fit(cfg)
    sample(cfg, progress=False)
    return d


def _copy(src: Path, dst: Path, drop: tuple[str, ...] = ("figures",)) -> Path:
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("report.html", *drop))
    return dst


@pytest.fixture(scope="module")
def reported(finished_run, tmp_path_factory) -> Path:
    """A copy of the finished run with its report, every figure drawn. A test that edits an input
    copies it with its figures: its report draws again only the figures of the inputs it changes
    (the others hold the same key: figure_cache.py), 2.5 s of drawing each."""
    run = _copy(finished_run, tmp_path_factory.mktemp("reported") / "tiny")
    assert build_report(run) == run / "report.html"
    return run


def test_report_figures_and_numbers(reported):
    run = reported
    out = run / "report.html"
    figs = {p.name for p in (run / "figures").glob("*.png")}
    assert figs == FIGURES
    for name in FIGURES:
        w, h = _png_size(run / "figures" / name)
        assert w > 200 and h > 150, name
    page = out.read_text()
    assert page.count("data:image/png;base64,") == len(FIGURES)   # self-contained
    assert "src=\"http" not in page and "<script" not in page
    summary = json.loads((run / "summary.json").read_text())
    for name in summary["parameters"]:
        s = summary["posterior"][name]
        for key in ("mean", "median"):
            assert f">{fmt_at(s[key], s['sd'])}<" in page, (name, key)
        assert f">{fmt(s['sd'])}<" in page
        lo, hi = s["hdi_90"]
        assert f"[{fmt_at(lo, s['sd'])}, {fmt_at(hi, s['sd'])}]" in page
        gn = summary["gauss_newton"]
        if name in gn["estimate"]:              # the discrepancy hyperparameters have no GN estimate
            # at its own sd (the posterior's may fall in another decade)
            assert f">{fmt_at(gn['estimate'][name], gn['sd'][name])}<" in page
            assert f">{fmt(gn['sd'][name])}<" in page
    # posterior correlation beside Δ̃ (eq. 35), Err in %
    rho = summary["posterior_correlation"][0][2]
    assert f">{fmt(rho, 4) if abs(rho) < 0.9995 else f'{rho:.5f}'}<" in page
    err_e = summary["gauss_newton"]["delta_tilde"][0][0]
    assert f">{100 * err_e:.2f} %<" in page
    # standards (from summary.json) with the ratio to E, and De_max
    iso = summary["standards"]["iso527_1"]
    e_mean = summary["posterior"]["E"]["mean"]
    assert f">{fmt(iso)}<" in page and f">{iso / e_mean:.3f}<" in page
    assert "De_max" in page and "Residual diagnostics" in page
    assert "Durbin-Watson" in page


def test_disagreements_are_flagged_in_words(reported, tmp_path):
    run = _copy(reported, tmp_path / "tiny", drop=())
    summary = json.loads((run / "summary.json").read_text())
    gn = summary["gauss_newton"]
    # make the posterior sd of tau_max 30 % larger and ρ(E, G) 0.1 larger than the linearized ones
    summary["posterior"]["tau_max"]["sd"] = 1.3 * gn["sd"]["tau_max"]
    summary["posterior"]["G"]["sd"] = 1.05 * gn["sd"]["G"]          # within 15 %: no flag
    i, j = summary["parameters"].index("E"), summary["parameters"].index("G")
    fit = json.loads((run / "fit.json").read_text())
    r = fit["correlation"][fit["parameters"].index("E")][fit["parameters"].index("G")] + 0.1
    summary["posterior_correlation"][i][j] = summary["posterior_correlation"][j][i] = r
    (run / "summary.json").write_text(json.dumps(summary))
    page = build_report(run).read_text()
    assert "Where the linearization fails" in page
    assert "tau_max: the posterior sd" in page and "30 % larger" in page
    assert "underestimates this uncertainty" in page
    assert "ρ(E, G): posterior" in page
    assert "G: the posterior sd" not in page
    assert page.count('class="flag"') >= 2


def test_fit_only_report_says_the_posterior_is_missing(finished_run, tmp_path):
    run = _copy(finished_run, tmp_path / "tiny",
                drop=("figures", "summary.json", "posterior.nc", "chains.h5"))
    page = build_report(run).read_text()
    assert "No posterior yet" in page
    assert {p.name for p in (run / "figures").glob("*.png")} == {"fit.png", "sensitivity.png",
                                                                   "sensitivity_xy.png", "acf.png"}
    fit = json.loads((run / "fit.json").read_text())
    assert f">{fmt_at(fit['estimate']['G'], fit['sd']['G'])}<" in page
    assert "Parameters: least squares" in page


def test_number_formats():
    assert fmt(2854.3) == "2854" and fmt(5.7912) == "5.791" and fmt(0.0005876) == "0.0005876"
    assert fmt(None) == "–" and fmt(32) == "32" and fmt(2.5e-6) == "2.500e-06"
    assert fmt_at(2.3195047, 0.000606) == "2.31950"      # sd shown to two digits: 0.00061
    assert fmt_at(2869.389, 13.4) == "2869"
    assert fmt_at(5.761128, 0.0273) == "5.761"


def test_crosscheck_section_table_4(reported, tmp_path):
    run = _copy(reported, tmp_path / "tiny", drop=())
    cfg = (run / "config.resolved.yaml")
    text = cfg.read_text() + ("crosscheck:\n  manufacturer: 1200\n  pulse_echo: {modulus: 2780, sd: 40}\n"
                              "  nanoindentation: {S_m: 80000, h: 5.0e-6, F: 0.05}\n")
    cfg.write_text(text)
    page = build_report(run).read_text()
    assert "Table 4: the modulus at every time scale" in page
    fit = json.loads((run / "fit.json").read_text())
    e = json.loads((run / "summary.json").read_text())["posterior"]["E"]["mean"]
    assert f"{(2780 - e) / e * 100:+.1f} %" in page           # Table 4's discrepancy against E
    assert "<td>2281</td>" in page                           # eq. 44 value (2280.6 MPa)
    assert re.search(r"pulse-echo</th><td[^>]*>E&#x27;\(5 MHz\) \(every mode frozen: E\)</td>"
                     r"<td>2780 ± 40</td>", page)            # at the paper's 5 MHz, sd: 2 digits
    # added after the run: predicted from fit.json's analysis, and said so
    assert "linearized now from fit.json" in page
    assert f"<td>{fmt_at(fit['estimate']['E'], fit['sd']['E'])} ± " in page


def test_the_corner_axes_stop_at_the_prior_bounds_the_ellipses_would_pass():
    """A linearized sd of 0.8 for alpha in [0, 1] stretched its axis to [-0.7, 3.0] on a real curve,
    squeezing the posterior; the axis now stops near the bound, the posterior kept whole."""
    from bayes_dnlr.report.figures import _ranges

    rng = np.random.default_rng(0)
    samples = np.column_stack([rng.uniform(0.45, 1.0, 4000), rng.normal(2000.0, 250.0, 4000)])
    est, sd = np.array([1.0, 1900.0]), np.array([0.8, 390.0])
    free = _ranges(samples, est, sd, None)
    bounded = _ranges(samples, est, sd, None, [(0.0, 1.0), (100.0, 20000.0)])
    assert free[0][0] < -0.8 and free[0][1] > 2.8
    assert -0.06 <= bounded[0][0] < 0.0 and 1.0 < bounded[0][1] <= 1.06
    assert bounded[1] == free[1]                           # E's bounds are far: its axis unchanged
    assert bounded[0][0] <= samples[:, 0].min() and bounded[0][1] >= np.quantile(samples[:, 0], 0.998)
