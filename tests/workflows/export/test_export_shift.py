"""export of a shifted model (``model.shift``): each format's cards carry the temperature law where
the format has one (Abaqus *TRS, Ansys TB,SHIFT, LS-DYNA MAT_076's TREF/A/B), the numbers parse
back, and the shift factor the solver computes from them is the model's; what a format cannot
carry (the Eyring stress shift everywhere, WLF in LS-DYNA) is said in the card and the summary; a
run without a shift writes what it wrote before, byte for byte."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from support.export_cards import SHIFT_VALUES, fixed_cards, fixed_context, fixed_set, shifted
from support.finished_run import make_finished_run
from support.shifted_run import make_shifted_run

from bayes_dnlr.model import simulate
from bayes_dnlr.model.shift import Shift, temperature_shift
from bayes_dnlr.runs.draws import load_run_draws
from bayes_dnlr.workflows.export import abaqus, ansys, lsdyna, table
from bayes_dnlr.workflows.export.cards import ramp, small_strain_limit
from bayes_dnlr.workflows.export.prony import from_parameters
from bayes_dnlr.workflows.export.run import FORMATS, export, index_csv

GOLDEN = Path(__file__).parent / "golden"
TEMPERATURES = (-30.0, 0.0, 20.0, 40.0, 85.0)     # °C, where the round trips compare a_T
R_SI = 8.314462618


# ------------------------------------------------------------------ the solvers' shift functions
# Written from the solvers' documented forms (docs/export.md), independently of the writers: each
# returns a_T, the factor every relaxation time is multiplied by at temperature T (°C).

def abaqus_a_T(trs: dict, constants: tuple[float, float] | None, T: float) -> float:
    """*TRS: reduced time dxi = dt/A (A = a_T); WLF log10 A = -C1 (T - T0)/(C2 + T - T0);
    ARRHENIUS ln A = (E0/R)(1/(T - T_Z) - 1/(T0 - T_Z)), R and T_Z from *PHYSICAL CONSTANTS."""
    if trs["definition"] == "WLF":
        t0, c1, c2 = trs["values"]
        return 10.0 ** (-c1 * (T - t0) / (c2 + T - t0))
    assert trs["definition"] == "ARRHENIUS" and constants is not None
    t0, e0 = trs["values"]
    zero, r = constants
    return math.exp(e0 / r * (1.0 / (T - zero) - 1.0 / (t0 - zero)))


def ansys_a_T(shift: dict, T: float) -> float:
    """TB,SHIFT: reduced time xi = int A dt (a_T = 1/A); WLF log10 A = C1 (T - Tr)/(C2 + T - Tr);
    TN (no fictive temperature) ln A = (H/R)(1/Tr - 1/T), T absolute."""
    if shift["form"] == "WLF":
        tr, c1, c2 = shift["values"]
        return 1.0 / 10.0 ** (c1 * (T - tr) / (c2 + T - tr))
    assert shift["form"] == "TN"
    tr, h_r = shift["values"]
    return 1.0 / math.exp(h_r * (1.0 / tr - 1.0 / (T + 273.15)))


def lsdyna_a_T(card: dict, T: float) -> float:
    """MAT_076: scaled time t' = int Phi dt (a_T = 1/Phi); B = 0: Phi = exp(-A (1/T - 1/TREF)), T
    absolute."""
    assert card["b"] == 0.0
    return 1.0 / math.exp(-card["a"] * (1.0 / (T + 273.15) - 1.0 / card["tref"]))


def physical_constants(text: str) -> tuple[float, float]:
    """ABSOLUTE ZERO and UNIVERSAL GAS CONSTANT of the *PHYSICAL CONSTANTS line a card asks for."""
    m = re.search(r"\*PHYSICAL CONSTANTS, ABSOLUTE ZERO=([-+0-9.eE]+), UNIVERSAL GAS CONSTANT=([-+0-9.eE]+)",
                  text)
    assert m, "the card names the *PHYSICAL CONSTANTS its *TRS needs"
    return float(m.group(1)), float(m.group(2))


def model_a_T(law: str, params: dict, T: float) -> float:
    return float(temperature_shift(T, law, 20.0, **{k: params.get(k) for k in ("Ea", "C1", "C2")}))


# ------------------------------------------------------------------ no shift: what it wrote before

def test_cards_without_a_shift_are_byte_identical_to_before():
    """The golden files were written by the renderers before the shift law entered them."""
    ctx = fixed_context(["E fixed in the run's config (no uncertainty from it)."])
    compared = 0
    for form in FORMATS.values():
        for card in fixed_cards():
            golden = GOLDEN / f"{card.label}.{form.extension}"
            if golden.is_file():
                assert form.render(card, ctx) == golden.read_text(encoding="utf-8"), golden.name
                compared += 1
    assert compared == 9
    assert index_csv(fixed_set(), ctx) == (GOLDEN / "cards.csv").read_text(encoding="utf-8")


def test_a_run_without_a_shift_says_nothing_of_one(tmp_path):
    run = make_finished_run(tmp_path)
    res = export(run, "abaqus", nu=0.45, out=tmp_path / "a")
    assert res.context.shift is None and res.shift is None and all(c.a_test == 1.0 for c in res.cards.cards)
    text = (tmp_path / "a" / "tiny_median.inp").read_text()
    assert "*TRS" not in text and "SHIFT" not in text and "shift:" not in res.table()
    assert "Valid at the test's temperature" in text


# ------------------------------------------------------------------ each law in each format

@pytest.mark.parametrize("law", ["arrhenius", "wlf"])
def test_abaqus_trs_round_trips(law):
    card, ctx = shifted(law)
    text = abaqus.render(card, ctx)
    parsed = abaqus.parse(text)
    lines = text.splitlines()
    # *TRS is an option of the material: after its *VISCOELASTIC data, the last block of the card
    assert lines.index(f"*TRS, DEFINITION={law.upper()}") == len(lines) - 2
    assert len(parsed["rows"]) == 50
    constants = None
    if law == "arrhenius":
        assert parsed["trs"]["values"] == [20.0, SHIFT_VALUES["Ea"] * 1e6]          # E0 in mJ/mol
        constants = physical_constants(text)
        assert constants == (-273.15, pytest.approx(R_SI * 1000.0, rel=1e-10))        # R in mJ/(mol K)
    else:
        assert parsed["trs"]["values"] == [20.0, SHIFT_VALUES["C1"], SHIFT_VALUES["C2"]]
    for T in TEMPERATURES:
        assert abaqus_a_T(parsed["trs"], constants, T) == pytest.approx(model_a_T(law, card.params, T),
                                                                       rel=1e-12)
    assert "NO STRESS SHIFT" not in text and "*TRS shifts" not in text


@pytest.mark.parametrize("law", ["arrhenius", "wlf"])
def test_ansys_tb_shift_round_trips(law):
    card, ctx = shifted(law)
    text = ansys.render(card, ctx)
    parsed = ansys.parse(text)
    assert parsed["n_SHEAR"] == parsed["n_BULK"] == 50 and len(parsed["SHEAR"]) == 50
    shift = parsed["shift"]
    assert text.splitlines()[-2].startswith("TB,SHIFT,1,1,")
    if law == "arrhenius":
        assert shift["form"] == "TN" and shift["n"] == 2
        assert shift["values"] == pytest.approx([293.15, 1000 * SHIFT_VALUES["Ea"] / R_SI], rel=1e-12)
    else:
        assert shift["form"] == "WLF" and shift["n"] == 3
        assert shift["values"] == [20.0, SHIFT_VALUES["C1"], SHIFT_VALUES["C2"]]
    for T in TEMPERATURES:
        assert ansys_a_T(shift, T) == pytest.approx(model_a_T(law, card.params, T), rel=1e-12)
    assert "not checked against the Ansys manual" in text


def test_lsdyna_carries_arrhenius_in_card_1_and_says_it_does_not_carry_wlf():
    card, ctx = shifted("arrhenius")
    card = replace(card, prony=fixed_cards()[3].prony)        # 4 terms: MAT_076 holds 18 rows at most
    text = lsdyna.render(card, ctx)
    parsed = lsdyna.parse(text)
    assert parsed["tref"] == 293.15 and parsed["b"] == 0.0
    assert parsed["a"] == pytest.approx(1000 * SHIFT_VALUES["Ea"] / R_SI, rel=1e-7)    # 10-character field
    for T in TEMPERATURES:
        assert lsdyna_a_T(parsed, T) == pytest.approx(model_a_T("arrhenius", card.params, T), rel=1e-6)
    assert len(parsed["rows"]) == 5
    # WLF: nothing in TREF, A, B; the card says so, with the numbers a user can check and enter
    card_w, ctx_w = shifted("wlf")
    card_w = replace(card, params=card_w.params)
    text = lsdyna.render(card_w, ctx_w)
    parsed = lsdyna.parse(text)
    assert parsed["tref"] is parsed["a"] is parsed["b"] is None
    assert "NO TEMPERATURE SHIFT written" in text and "T_ref = 20 degC only" in text
    flat = " ".join(line[2:].strip() for line in text.splitlines() if line.startswith("$"))
    m = re.search(r"TREF = ([0-9.]+) K, A = -ln\(10\) C1 = ([-0-9.e]+), B = C2 = ([0-9.e]+?)\.?(?: |$)", flat)
    tref, a, b = (float(v) for v in m.groups())
    for T in TEMPERATURES:       # the numbers it gives, in the form it names, are the model's law
        phi = math.exp(-a * (T + 273.15 - tref) / (b + T + 273.15 - tref))
        assert 1.0 / phi == pytest.approx(model_a_T("wlf", card_w.params, T), rel=1e-12)
    assert "NO temperature shift written" in lsdyna.shift_support(ctx_w.shift, card_w.params).summary


def test_the_stress_shift_is_said_in_every_format_and_never_written():
    for law in ("arrhenius", "none"):
        card, ctx = shifted(law, "eyring")
        for name, form in FORMATS.items():
            if name == "ls-dyna":
                card = replace(card, prony=fixed_cards()[3].prony)
            text = form.render(card, ctx)
            support = form.shift(ctx.shift, card.params)
            if name in ("csv", "json"):          # the whole law as data: sigma_s with its interval
                assert "sigma_s" in text and "written whole" in support.summary
                continue
            assert "NO STRESS SHIFT in this card" in text, name
            assert "sigma -> 0 (linear) limit" in " ".join(text.split())
            assert "NO stress shift" in support.summary and "σ → 0" in support.summary
            if law == "none":       # a stress shift alone: no temperature law written, the old validity
                parsed = {"abaqus": abaqus, "ansys": ansys, "ls-dyna": lsdyna}[name].parse(text)
                assert [parsed.get(k) for k in ("trs", "shift", "tref")] == [None, None, None]
                assert "Valid at the test's temperature" in text
    # a temperature law alone says nothing of a stress shift
    card, ctx = shifted("arrhenius")
    assert all("STRESS SHIFT" not in f.render(card, ctx) for n, f in FORMATS.items() if n != "ls-dyna")


def test_comment_lines_hold_no_newline():
    """Every line of a solver card is a comment, a keyword or a data line: a newline inside a
    comment would make the rest of it input."""
    card, ctx = shifted("arrhenius", "eyring")
    text = abaqus.render(card, ctx)
    for line in text.splitlines():
        assert line.startswith(("**", "*")) or re.fullmatch(r"[-+0-9.eE, ]+", line), line
    text = ansys.render(card, ctx)
    for line in text.splitlines():
        assert line.startswith(("!", "MP", "TB")), line


# ------------------------------------------------------------------ a shifted run, end to end

@pytest.fixture(scope="module")
def shifted_run(tmp_path_factory) -> Path:
    """Arrhenius (Ea fixed at 100 kJ/mol, T_ref 20 °C) and Eyring (sigma_s free), the test at 40 °C."""
    return make_shifted_run(tmp_path_factory.mktemp("shifted"), "arrhenius", "eyring")


def test_shifted_run_abaqus_cards(shifted_run, tmp_path):
    res = export(shifted_run, "abaqus", nu=0.4, out=tmp_path / "a")
    draws = load_run_draws(shifted_run).values
    lo, med, hi = np.quantile(draws["sigma_s"], (0.05, 0.5, 0.95))
    assert res.context.shift.test_temperature == 40.0
    for card in res.cards.cards:
        text = (tmp_path / "a" / f"arrhenius_eyring_{card.label}.inp").read_text()
        parsed = abaqus.parse(text)
        assert parsed["trs"] == {"definition": "ARRHENIUS", "values": [20.0, 1e8]}     # Ea = 100 kJ/mol
        constants = physical_constants(text)
        for T in TEMPERATURES:
            assert abaqus_a_T(parsed["trs"], constants, T) == pytest.approx(
                model_a_T("arrhenius", {"Ea": 100.0}, T), rel=1e-12)
        # the series is the reference state's: its longest time is the draw's tau_max (at 20 °C) ...
        assert parsed["rows"][-1][2] == pytest.approx(card.params["tau_max"], rel=1e-9)
        assert card.a_test == pytest.approx(model_a_T("arrhenius", {"Ea": 100.0}, 40.0), rel=1e-12)
        # ... and, shifted by the solver's a_T to the test's 40 °C, the model's small-strain response there
        params = {k: card.params[k] for k in ("E", "G", "tau_max", "Ea")}
        t, e = ramp(res.cards.time_range.strain_rate, 0.002)
        model = simulate(t, e, params, shift=Shift("arrhenius", 20.0), temperature=40.0)
        prony = card.prony.scaled(abaqus_a_T(parsed["trs"], constants, 40.0))
        assert np.max(np.abs(prony.response(t, e)[1:] - model[1:]) / model[1:]) < 1e-3
        # the stress shift: said, with the draw's sigma_s and the posterior's interval
        flat = " ".join(line[2:].strip() for line in text.splitlines() if line.startswith("**"))
        assert "NO STRESS SHIFT in this card" in flat
        assert (f"sigma_s = {card.params['sigma_s']:.6g} MPa in this card's draw (posterior median "
                f"{med:.6g} MPa, 90 % interval {lo:.6g} to {hi:.6g} MPa)") in flat
        assert "Ea = 100 kJ/mol (fixed in the run's config)" in flat
    # the limit is measured against the model with its stress shift: far below the linear one's
    median = res.cards.cards[1]
    linear = small_strain_limit(median, res.cards.time_range.strain_rate, 50, 6.0,
                                shift=Shift("arrhenius", 20.0), temperature=40.0)
    assert res.context.small_strain_limit < 0.5 * linear
    # the summary and the index say what the format carries and what it cannot
    table_text = res.table()
    assert "shift: *TRS, DEFINITION=ARRHENIUS" in table_text and "NO stress shift" in table_text
    index = (tmp_path / "a" / "cards.csv").read_text().splitlines()
    assert index[2].startswith("# shift: temperature arrhenius, stress eyring")
    assert "NO stress shift" in index[2]
    assert index[3].endswith(",Ea_kJ_mol,sigma_s_MPa")
    for row, card in zip(index[4:], res.cards.cards, strict=True):
        cells = row.split(",")
        assert float(cells[-2]) == 100.0
        assert float(cells[-1]) == pytest.approx(card.params["sigma_s"], rel=1e-9)


def test_shifted_run_ansys_lsdyna_and_tables(shifted_run, tmp_path):
    res = export(shifted_run, "ansys", nu=0.4, out=tmp_path / "n")
    parsed = ansys.parse((tmp_path / "n" / "arrhenius_eyring_median.mac").read_text())
    for T in TEMPERATURES:
        assert ansys_a_T(parsed["shift"], T) == pytest.approx(model_a_T("arrhenius", {"Ea": 100.0}, T),
                                                               rel=1e-12)
    # LS-DYNA with 10 terms: refitted over the test's times at T_ref (over a_T), so that at the test's
    # temperature the short series follows the full one over the test's range
    res = export(shifted_run, "ls-dyna", nu=0.4, density=950, terms=10, out=tmp_path / "k")
    text = (tmp_path / "k" / "arrhenius_eyring_median.k").read_text()
    card = lsdyna.parse(text)
    for T in TEMPERATURES:
        assert lsdyna_a_T(card, T) == pytest.approx(model_a_T("arrhenius", {"Ea": 100.0}, T), rel=1e-6)
    median = res.cards.cards[1]
    rng = res.cards.time_range
    assert median.refit.t_range == pytest.approx((rng.t_lo / median.a_test, rng.t_hi / median.a_test))
    p = median.params
    full = from_parameters(p["E"], p["G"], p["tau_max"]).scaled(median.a_test)
    t = np.concatenate([[0.0], np.geomspace(rng.t_lo, rng.t_hi, 300)])
    short = median.at_test
    assert np.max(np.abs(short.modulus(t) - full.modulus(t)) / full.modulus(t)) < 0.02
    assert res.cards.checks["refit_max_error"] < 0.02 and res.cards.checks["refit_ramp_error"] < 0.02
    # JSON: the law as data, the posterior's interval of sigma_s
    export(shifted_run, "json", out=tmp_path / "j")
    c = json.loads((tmp_path / "j" / "arrhenius_eyring_median.json").read_text())
    draws = load_run_draws(shifted_run).values["sigma_s"]
    s = c["shift"]
    assert s["temperature_law"] == "arrhenius" and s["stress_law"] == "eyring"
    assert s["series_at"] == {"temperature_C": 20.0, "stress": "sigma -> 0"}
    assert s["parameters"]["Ea"] == {"value": 100.0, "unit": "kJ/mol", "fixed": True}
    assert s["parameters"]["sigma_s"]["q05"] == pytest.approx(np.quantile(draws, 0.05))
    assert s["parameters"]["sigma_s"]["q95"] == pytest.approx(np.quantile(draws, 0.95))
    assert s["a_T_at_test"] == pytest.approx(model_a_T("arrhenius", {"Ea": 100.0}, 40.0))
    export(shifted_run, "csv", out=tmp_path / "c")
    head = (tmp_path / "c" / "arrhenius_eyring_median.csv").read_text()
    assert "# Ea = 100 kJ/mol" in head and "# shift = temperature arrhenius, stress eyring" in head
    assert table.shift_support is FORMATS["csv"].shift
