"""export: the small-strain Prony series against the DNLR model itself, the card files parsed back,
the refit's error, the 5 %/95 % cards around the median, and the errors that name what is wrong."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from support.finished_run import make_finished_run

from bayes_dnlr.cli import main
from bayes_dnlr.errors import BayesDnlrError, RunError
from bayes_dnlr.model import simulate
from bayes_dnlr.workflows.export import abaqus, ansys, lsdyna
from bayes_dnlr.workflows.export.cards import poisson_from_strains, ramp
from bayes_dnlr.workflows.export.prony import Prony, from_parameters, refit
from bayes_dnlr.workflows.export.run import export

PARAMS = {"E": 2854.0, "G": 2.32, "tau_max": 5.79}


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    """A 300-point synthetic test at 1e-2 1/s with a transverse strain of ν = 0.45, fitted and sampled."""
    return make_finished_run(tmp_path_factory.mktemp("runs"))


def _abaqus_prony(text: str) -> tuple[Prony, dict]:
    card = abaqus.parse(text)
    g = np.array([r[0] for r in card["rows"]])
    tau = np.array([r[2] for r in card["rows"]])
    e0 = card["E0"]
    return Prony(e0 * (1.0 - g.sum()), e0 * g, tau), card


# ------------------------------------------------------------------ the series against the model

def test_series_is_the_models_small_strain_limit():
    """eq. 18 with ε_HT ≈ 3ε: E(0) = E, E(∞) = 3G, and the step and ramp responses of the series
    match the DNLR model (the real eq. 18 with ε_HT) to far below 0.1 %."""
    p = from_parameters(**PARAMS)
    assert p.terms == 50
    assert p.e0 == pytest.approx(PARAMS["E"], rel=1e-12)
    assert p.e_inf == pytest.approx(3 * PARAMS["G"], rel=1e-12)
    assert p.modulus(1e6)[0] == pytest.approx(3 * PARAMS["G"], rel=1e-9)
    t = np.concatenate([[0.0, 1e-9], np.geomspace(1e-6, 1e3, 400)])
    step = np.where(t > 0, 1e-4, 0.0)
    model = simulate(t, step, PARAMS)
    assert np.max(np.abs(p.response(t, step)[1:] - model[1:]) / model[1:]) < 1e-4
    # the response to a step is the relaxation modulus itself
    assert np.max(np.abs(p.response(t, step)[2:] / 1e-4 - p.modulus(t[2:])) / p.modulus(t[2:])) < 1e-6


def test_from_parameters_refuses_a_stiffening_series():
    with pytest.raises(BayesDnlrError, match="3G"):
        from_parameters(E=5.0, G=2.0, tau_max=1.0)
    with pytest.raises(BayesDnlrError, match="tau_max"):
        from_parameters(E=2854.0, G=2.0, tau_max=-1.0)


def test_refit_fewer_terms_within_two_percent():
    full = from_parameters(**PARAMS)
    r = refit(full, 10, 0.002, 380.0)
    assert r.prony.terms <= 10 and np.all(r.prony.moduli > 0)
    assert r.prony.e_inf == full.e_inf
    assert r.prony.e0 == pytest.approx(full.e0, rel=1e-4)
    assert r.max_error < 0.02
    t = np.concatenate([[0.0], np.geomspace(0.002, 380.0, 300)])
    assert np.max(np.abs(r.prony.modulus(t) - full.modulus(t)) / full.modulus(t)) <= r.max_error * 1.5
    # three terms cannot follow seven decades: the refit says how far off it is
    assert refit(full, 3, 0.002, 380.0).max_error > 0.02


# ------------------------------------------------------------------ the exported files

def test_abaqus_card_reproduces_the_model_within_0_1_percent(finished_run, tmp_path):
    res = export(finished_run, "abaqus", out=tmp_path / "a")
    text = (tmp_path / "a" / "tiny_median.inp").read_text()
    assert "*ELASTIC, MODULI=INSTANTANEOUS" in text and "*VISCOELASTIC, TIME=PRONY" in text
    assert "NOT" in text and "user material" in text           # the limits, stated in the file
    prony, card = _abaqus_prony(text)
    median = res.cards.cards[1]
    assert median.label == "median"
    # numbers round-trip
    assert card["nu"] == pytest.approx(0.45, abs=0.01)          # from the transverse strain
    assert card["E0"] == pytest.approx(median.prony.e0, rel=1e-9)
    assert [r[0] for r in card["rows"]] == [r[1] for r in card["rows"]]      # g_i = k_i
    np.testing.assert_allclose([r[0] for r in card["rows"]], median.prony.ratios, rtol=1e-9)
    np.testing.assert_allclose([r[2] for r in card["rows"]], median.prony.times, rtol=1e-9)
    # the parsed card against the DNLR model at the card's parameters
    p = median.params
    params = {"E": p["E"], "G": p["G"], "tau_max": p["tau_max"]}
    t = np.concatenate([[0.0, 1e-9], np.geomspace(1e-6, 1e3, 400)])
    step = np.where(t > 0, 1e-4, 0.0)
    model = simulate(t, step, params)
    assert np.max(np.abs(prony.response(t, step)[1:] - model[1:]) / model[1:]) < 1e-3
    tr, er = ramp(res.cards.time_range.strain_rate, 0.002)
    model = simulate(tr, er, params)
    assert np.max(np.abs(prony.response(tr, er)[1:] - model[1:]) / model[1:]) < 1e-3


def test_lsdyna_card_round_trips_and_terms_10_within_2_percent(finished_run, tmp_path, capsys):
    rc = main(["export", str(finished_run), "--format", "ls-dyna", "--terms", "10", "--density", "950",
               "--out", str(tmp_path / "k")])
    out = capsys.readouterr().out
    assert rc == 0
    assert "--terms 10" in out and "max error of E(t)" in out
    text = (tmp_path / "k" / "tiny_median.k").read_text()
    assert text.startswith("*KEYWORD") and text.rstrip().endswith("*END")
    card = lsdyna.parse(text)
    res = export(finished_run, "ls-dyna", terms=10, density=950, out=tmp_path / "k")
    assert res.status == "up to date"
    median = res.cards.cards[1]
    nu = res.context.poisson.value
    assert card["ro"] == pytest.approx(950e-12, rel=1e-6)
    assert card["bulk"] == pytest.approx(median.prony.e0 / (3 * (1 - 2 * nu)), rel=1e-6)
    rows = np.array(card["rows"])
    assert rows.shape == (median.prony.terms + 1, 4) and rows.shape[0] <= lsdyna.MAX_TERMS
    assert rows[0, 1] == 0 and rows[0, 3] == 0                       # the long-term term
    np.testing.assert_allclose(rows[1:, 0], median.prony.moduli / (2 * (1 + nu)), rtol=1e-6)
    np.testing.assert_allclose(rows[1:, 1], 1 / median.prony.times, rtol=1e-6)
    np.testing.assert_allclose(rows[1:, 2], median.prony.moduli / (3 * (1 - 2 * nu)), rtol=1e-6)
    for line in text.splitlines():                                    # 10-character fields
        if not line.startswith(("$", "*")) and line[:1] == " ":
            assert len(line) % 10 == 0
    # the 10-term series against the full one: E(t) over the test's range, and the ramp
    rng = res.cards.time_range
    full = from_parameters(median.params["E"], median.params["G"], median.params["tau_max"])
    e0 = rows[:, 0].sum() * 2 * (1 + nu)
    short = Prony(rows[0, 0] * 2 * (1 + nu), rows[1:, 0] * 2 * (1 + nu), 1 / rows[1:, 1])
    assert short.e0 == pytest.approx(e0)
    t = np.concatenate([[0.0], np.geomspace(rng.t_lo, rng.t_hi, 300)])
    assert np.max(np.abs(short.modulus(t) - full.modulus(t)) / full.modulus(t)) < 0.02
    tr, er = ramp(rng.strain_rate, 0.002, t_first=rng.t_lo)
    assert np.max(np.abs(short.response(tr, er)[1:] - full.response(tr, er)[1:])
                  / full.response(tr, er)[1:]) < 0.02


def test_ansys_and_tables(finished_run, tmp_path):
    res = export(finished_run, "ansys", out=tmp_path / "n", draws=3)
    text = (tmp_path / "n" / "tiny_q95.mac").read_text()
    card = ansys.parse(text)
    q95 = res.cards.cards[2]
    assert card["ex"] == pytest.approx(q95.prony.e0, rel=1e-9)
    assert card["n_SHEAR"] == card["n_BULK"] == q95.prony.terms
    np.testing.assert_allclose([a for a, _ in card["SHEAR"]], q95.prony.ratios, rtol=1e-9)
    np.testing.assert_allclose([t for _, t in card["BULK"]], q95.prony.times, rtol=1e-9)
    assert sorted(p.name for p in (tmp_path / "n").iterdir()) == sorted(
        ["cards.csv", "tiny_median.mac", "tiny_q05.mac", "tiny_q95.mac", "tiny_draw001.mac",
         "tiny_draw002.mac", "tiny_draw003.mac"])
    res = export(finished_run, "json", out=tmp_path / "j")
    import json

    c = json.loads((tmp_path / "j" / "tiny_median.json").read_text())
    assert c["units"]["modulus"] == "MPa" and c["units"]["time"] == "s"
    assert c["E0"] == pytest.approx(res.cards.cards[1].prony.e0)
    assert len(c["terms"]) == 50
    csv = (tmp_path / "n" / "cards.csv").read_text().splitlines()
    assert csv[2].startswith("card,quantile_of_E") and len(csv) == 3 + 6


def test_quantile_cards_bracket_the_median(finished_run, tmp_path):
    from bayes_dnlr.runs.draws import load_run_draws

    res = export(finished_run, "csv", out=tmp_path / "c")
    E = load_run_draws(finished_run).values["E"]
    by = {c.label: c for c in res.cards.cards}
    for label, q in (("q05", 0.05), ("median", 0.5), ("q95", 0.95)):
        # a whole draw, the one nearest the quantile of E
        assert by[label].params["E"] == E[by[label].draw_index]
        assert abs(np.mean(E <= by[label].params["E"]) - q) < 0.01
    assert by["q05"].prony.e0 < by["median"].prony.e0 < by["q95"].prony.e0
    ch = res.cards.checks
    assert ch["E0_bracketed"] and ch["ramp_bracketed"]
    tr, er = ramp(res.cards.time_range.strain_rate, 0.002)
    lo, mid, hi = (by[k].prony.response(tr, er)[1:] for k in ("q05", "median", "q95"))
    assert np.all(lo <= mid) and np.all(mid <= hi)


def test_poisson_from_transverse_strain():
    e11 = np.linspace(0, 0.05, 500)
    nu, n, top = poisson_from_strains(e11, -0.42 * e11)
    assert nu == pytest.approx(0.42) and n == 199 and top <= 0.02
    nu, n, top = poisson_from_strains(e11[::40], -0.3 * e11[::40])      # coarse: the first 5 samples
    assert nu == pytest.approx(0.3) and n == 5 and top < 0.05
    with pytest.raises(BayesDnlrError, match="--nu"):
        poisson_from_strains(e11[:3], -0.4 * e11[:3])


# ------------------------------------------------------------------ errors that name what is wrong

def test_errors_name_the_key(finished_run, tmp_path, capsys):
    fit_only = tmp_path / "fit-only"
    shutil.copytree(finished_run, fit_only, ignore=shutil.ignore_patterns("posterior.nc", "summary.json"))
    with pytest.raises(RunError, match="not a finished run: summary.json, posterior.nc missing.*sample"):
        export(fit_only, "json")
    # ν = 0.5 from the data (the paper's isovolumic assumption) for a solver
    half = tmp_path / "half"
    shutil.copytree(finished_run, half, ignore=shutil.ignore_patterns("export"))
    resolved = half / "config.resolved.yaml"
    resolved.write_text(resolved.read_text().replace("eps22: e22", "eps22: e22_half"))
    with pytest.raises(BayesDnlrError, match=r"ν = 0.5.*Abaqus needs -1 < ν < 0.5"):
        export(half, "abaqus", out=tmp_path / "x")
    export(half, "csv", out=tmp_path / "x")          # a table may carry it (stated)
    with pytest.raises(BayesDnlrError, match="--nu: ν = 0.5"):
        export(finished_run, "ansys", nu=0.5, out=tmp_path / "y")
    with pytest.raises(BayesDnlrError, match="--terms 17 or fewer"):
        export(finished_run, "ls-dyna", density=950, out=tmp_path / "z")
    with pytest.raises(BayesDnlrError, match="--density"):
        export(finished_run, "ls-dyna", terms=5, out=tmp_path / "z")
    assert not (tmp_path / "x" / "tiny_median.inp").exists() and not (tmp_path / "z").exists()
    # an existing, different result is not overwritten without --force
    export(finished_run, "abaqus", nu=0.4, out=tmp_path / "w")
    before = (tmp_path / "w" / "tiny_median.inp").read_text()
    with pytest.raises(RunError, match="not overwritten.*--force"):
        export(finished_run, "abaqus", nu=0.3, out=tmp_path / "w")
    assert (tmp_path / "w" / "tiny_median.inp").read_text() == before
    export(finished_run, "abaqus", nu=0.3, out=tmp_path / "w", force=True)
    assert abaqus.parse((tmp_path / "w" / "tiny_median.inp").read_text())["nu"] == 0.3
    # the command line: one line, exit 2
    assert main(["export", str(fit_only), "--format", "abaqus"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "Traceback" not in err
