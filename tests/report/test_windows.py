"""`report` builds for any run `fit` accepts: pre-yield windows, a relaxation
test with a tiny ramp, a window on the hold only (G on its bound), a 50-point test. Figures and
captions adapt to the window; the inset hides no data; the trace plot names its axes; the rank
caption describes what is drawn; the ISO text does not contradict itself; a standard modulus
above E and a relaxed modulus above E are remarked on."""

from __future__ import annotations

import html
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from support.drawing import figures_not_drawn
from support.runs import WIDE_RELAXATION_PRIORS, make_run, ramp_truth, small_ramp_relaxation_truth

from bayes_dnlr.cli import main
from bayes_dnlr.report import build_report
from bayes_dnlr.report import figures as figs
from bayes_dnlr.report.tables import _standard_how
from bayes_dnlr.standards import iso527_1_modulus

RELAXATION = {"relaxation_start": "auto"}
CASES = {   # name: (truth, data keys, parameters, sigma0)
    "pre-0.01": (ramp_truth(0.01), {}, None, 0.1),
    "pre-0.05": (ramp_truth(0.05), {}, None, 0.1),
    "pre-0.1": (ramp_truth(0.1), {}, None, 0.1),
    "relaxation": (small_ramp_relaxation_truth(), RELAXATION, WIDE_RELAXATION_PRIORS, 0.05),
    "hold-only": (small_ramp_relaxation_truth(), {**RELAXATION, "window": {"time_min": 2.0}},
                  WIDE_RELAXATION_PRIORS, 0.05),
    "fifty-points": (ramp_truth(1.0, n_points=50, stress_sd=0.3), {}, None, 0.3),
}
ALL_FIGURES = {"corner.png", "fit.png", "sensitivity.png", "sensitivity_xy.png", "trace.png", "rank.png"}
# the figures of the draws alone (the window does not enter them) are drawn for a run of three
# parameters and one of five; the other cases draw the figures of the curve and its window
DRAWS_DRAWN = ("pre-0.01", "relaxation")
CURVE_FIGURES = ("fit_plot", "sensitivity_plot", "sensitivity_xy_plot", "acf_plot")


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    """Each case simulated, fitted and sampled (tiny sampler) through the command line."""
    folder = tmp_path_factory.mktemp("windows")
    out = {}
    for name, (truth, data, parameters, sigma0) in CASES.items():
        path = make_run(folder, name, truth, data=data, parameters=parameters, sigma0=sigma0)
        assert main(["sample", "--quiet", str(path)]) == 0, name
        out[name] = path.parent
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_report_builds_with_every_figure(runs, name, monkeypatch):
    run = runs[name]
    if name not in DRAWS_DRAWN:
        figures_not_drawn(monkeypatch, keep=CURVE_FIGURES)
    assert main(["report", str(run)]) == 0
    made = {p.name for p in (run / "figures").glob("*.png")}
    assert ALL_FIGURES <= made and len(made) >= 6
    page = (run / "report.html").read_text()
    assert page.count("data:image/png;base64,") == len(made)
    assert "envelope" not in page                                # the rank plot draws none


@pytest.mark.parametrize("name", ["pre-0.01", "pre-0.05", "pre-0.1"])
def test_pre_yield_captions_do_not_assume_the_papers_hdpe(runs, name):
    page = (runs[name] / "report.html").read_text()
    assert "the bend near ε = 0.13" not in page and "paper's interval I, where" not in page
    assert "before the end of the paper's interval I (ε = 0.13)" in page
    assert "the inset zooms" not in page                         # the whole window is interval I
    assert "Circled: where the curve bends most" in page


def test_relaxation_with_a_tiny_ramp_is_drawn_against_time(runs):
    page = (runs["relaxation"] / "report.html").read_text()
    assert "coloured by time (log scale)" in page
    assert "the inset zooms on the ramp and the start of the hold" in page


def test_a_full_hdpe_curve_keeps_the_papers_marks(tmp_path):
    path = make_run(tmp_path, "hdpe", ramp_truth(1.0, n_points=600, stress_sd=0.3), sigma0=0.3)
    assert main(["fit", "--quiet", str(path)]) == 0
    assert main(["report", str(path.parent)]) == 0
    page = (path.parent / "report.html").read_text()
    assert "the bend near the end of the paper's interval I (ε = 0.13" in page
    assert "the inset zooms on ε ≤ 0.13, the paper's interval I" in page
    assert {"fit.png", "sensitivity.png", "sensitivity_xy.png"} <= {
        p.name for p in (path.parent / "figures").glob("*.png")}


def _capture(monkeypatch) -> list:
    figures = []

    def keep(fig, path):
        figures.append(fig)
        return Path(path)

    monkeypatch.setattr(figs, "save_figure", keep)
    return figures


def test_the_interval_i_inset_covers_no_data(monkeypatch, tmp_path):
    """A concave curve without hardening (like ETFE or a pre-necking polymer) fills the upper
    left of the axes, where the inset used to sit."""
    x = np.linspace(0.0, 0.65, 600)
    y = 40.0 * (1.0 - np.exp(-x / 0.05)) + 5.0 * x
    figures = _capture(monkeypatch)
    figs.fit_plot(x, y, tmp_path / "fit.png", window=np.ones(x.size, bool), gn_curve=y, sigma0=0.1,
                  inset_xmax=0.13)
    fig = figures[0]
    fig.canvas.draw()
    ax = fig.axes[0]
    [ins] = ax.child_axes
    box = ins.get_window_extent()
    pts = ax.transData.transform(np.column_stack([x, y]))
    inside = ((pts[:, 0] >= box.x0) & (pts[:, 0] <= box.x1) & (pts[:, 1] >= box.y0) & (pts[:, 1] <= box.y1))
    assert not inside.any()
    # the old place, the upper left, held data
    frac = (ax.transData + ax.transAxes.inverted()).transform(np.column_stack([x, y]))
    assert figs.covered(frac, (0.08, 0.5, 0.35, 0.42)) > 0
    legend = ax.get_legend().get_window_extent()
    assert not ((pts[:, 0] >= legend.x0) & (pts[:, 0] <= legend.x1)
                & (pts[:, 1] >= legend.y0) & (pts[:, 1] <= legend.y1)).any()


def test_trace_plot_names_and_units_on_every_panel(monkeypatch, tmp_path):
    rng = np.random.default_rng(0)
    draws = {"E": 2850 + 10 * rng.normal(size=(8, 200)), "tau_max": 5.8 + 0.1 * rng.normal(size=(8, 200))}
    figures = _capture(monkeypatch)
    figs.trace_plot(draws, tmp_path / "trace.png")
    axes = figures[0].axes
    assert [a.get_xlabel() for a in axes[0::2]] == [figs.LABELS["E"], figs.LABELS["tau_max"]]
    assert [a.get_ylabel() for a in axes[0::2]] == ["density (1/MPa)", "density (1/s)"]
    assert [a.get_ylabel() for a in axes[1::2]] == [figs.LABELS["E"], figs.LABELS["tau_max"]]
    assert all(a.get_xlabel() == "step after burn-in" for a in axes[1::2])


def test_iso_chord_text_does_not_contradict_itself():
    e = np.linspace(0.0, 0.024, 41)                # 0.06 % steps: 4 samples between 0.05 and 0.25 %
    r = iso527_1_modulus(e, 1000.0 * e)
    assert r.method == "chord"
    how = _standard_how(r)
    assert "2 samples" not in how and "chord between the stresses interpolated" in how
    assert "only 4 sample(s) between the two strains, fewer than the 5" in how


def test_a_standard_modulus_or_a_relaxed_modulus_above_e_is_remarked_on(runs, tmp_path, monkeypatch):
    run = tmp_path / "low-e"
    shutil.copytree(runs["pre-0.1"], run, ignore=shutil.ignore_patterns(
        "figures", "report.html", "summary.json", "posterior.nc", "chains.h5"))
    fit = json.loads((run / "fit.json").read_text())
    fit["estimate"]["E"] = 500.0                   # below the ISO modulus of this curve
    fit["estimate"]["G"] = 200.0                   # 3G = 600 MPa > E
    (run / "fit.json").write_text(json.dumps(fit))
    figures_not_drawn(monkeypatch)          # the page's text is read, not its figures
    page = html.unescape(build_report(run).read_text())
    assert re.search(r"ISO 527-1 \d+ MPa and ASTM D638 \d+ MPa above the model's instantaneous E = 500",
                     page)
    assert page.count("cannot exceed the instantaneous modulus") == 2     # headline and table note
    assert "3G = 600 MPa exceeds E = 500 MPa" in page
