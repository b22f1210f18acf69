"""ISO 527-1 and ASTM D638 moduli on curves with a known answer (paper section 2.4, Table 1)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from support import REPO

from bayes_dnlr import data as bd_data
from bayes_dnlr.model import simulate
from bayes_dnlr.standards import (
    astm_d638_modulus,
    iso527_1_modulus,
    standard_moduli,
    standard_results,
)

E_LIN = 1500.0


def toe_curve(e: np.ndarray, modulus: float, toe_end: float) -> np.ndarray:
    """Quadratic toe up to ``toe_end`` (slope rising from 0 to ``modulus``), then linear with
    slope ``modulus`` up to e = 1 %, then a saturating 'yield' (slope continuous, decreasing).
    The straight part extended to zero stress crosses the strain axis at toe_end / 2."""
    s = np.where(e < toe_end, modulus * e**2 / (2 * toe_end), modulus * (e - toe_end / 2))
    s1 = modulus * (0.01 - toe_end / 2)
    late = e > 0.01
    s[late] = s1 + modulus * 0.005 * (1 - np.exp(-(e[late] - 0.01) / 0.005))
    return s


def test_linear_curve_gives_its_slope_by_every_method():
    e = np.linspace(0.0, 0.01, 1001)
    s = E_LIN * e + 0.2  # a small offset (prestress) does not change a slope
    for method in ("regression", "chord", "auto"):
        r = iso527_1_modulus(e, s, method=method)
        assert r.modulus == pytest.approx(E_LIN, rel=1e-9), method
    r = iso527_1_modulus(e, s)
    assert r.method == "least-squares slope"
    assert r.n_points == 201  # samples at 0.05 %, 0.06 %, ... 0.25 %
    a = astm_d638_modulus(e, s)
    assert a.modulus == pytest.approx(E_LIN, rel=1e-9)
    assert a.corrected_zero == pytest.approx(-0.2 / E_LIN, abs=1e-12)


def test_toe_region_astm_compensates_iso_does_not():
    e = np.linspace(0.0, 0.03, 3001)
    E = 2000.0
    s = toe_curve(e, E, toe_end=0.002)
    a = astm_d638_modulus(e, s)
    assert a.modulus == pytest.approx(E, rel=1e-9)
    assert a.corrected_zero == pytest.approx(0.001, abs=1e-9)   # toe_end / 2 (Annex A1, point B)
    assert a.strain_range[0] >= 0.002 - 1e-12                  # the window lies past the toe
    iso = iso527_1_modulus(e, s)
    # ISO 527-1 takes strains as recorded: the toe (which the standard avoids by a prestress) lowers
    # the modulus. Hand value: least squares of the curve on [0.0005, 0.0025] (toe up to 0.002).
    ee = e[(e >= 0.0005) & (e <= 0.0025)]
    expected = np.polyfit(ee, toe_curve(ee, E, 0.002), 1)[0]
    assert iso.modulus == pytest.approx(expected, rel=1e-9)
    assert iso.modulus < 0.8 * E


def test_short_toe_below_iso_range_leaves_iso_exact():
    e = np.linspace(0.0, 0.03, 3001)
    s = toe_curve(e, 2000.0, toe_end=0.0004)   # toe over before 0.05 %
    assert iso527_1_modulus(e, s).modulus == pytest.approx(2000.0, rel=1e-9)


def test_noisy_linear_curve_within_its_standard_error():
    rng = np.random.default_rng(3)
    e = np.linspace(0.0, 0.01, 1001)
    s = E_LIN * e + rng.normal(0.0, 0.05, e.size)
    r = iso527_1_modulus(e, s)
    inside = e[(e >= 0.0005) & (e <= 0.0025)]
    se = 0.05 / np.sqrt(np.sum((inside - inside.mean()) ** 2))
    assert abs(r.modulus - E_LIN) < 4 * se


def test_sparse_data_falls_back_to_the_chord():
    e = np.array([0.0, 0.001, 0.002, 0.003, 0.004])
    s = E_LIN * e
    r = iso527_1_modulus(e, s)
    assert r.method == "chord" and r.n_points == 2
    assert r.modulus == pytest.approx(E_LIN)


def test_chord_on_a_curved_irregularly_sampled_curve_interpolates_at_both_strains():
    """Three samples between 0.05 % and 0.25 % (fewer than a least-squares slope needs): the chord
    between the stresses interpolated linearly at exactly 0.05 % and 0.25 % on the first passage of
    the loading, which on this concave curve is within 1 % of its exact chord; the samples next to
    those strains would give 13 % more, and the unloading after the first passage is never read."""
    def curve(e):
        return 30.0 * (1.0 - np.exp(-e / 0.004))

    load = np.array([0.0, 0.00021, 0.00037, 0.00064, 0.00141, 0.00233, 0.00312, 0.0052, 0.009])
    unload = np.array([0.004, 0.0024, 0.0011, 0.0004])            # back through the range, lower
    e = np.concatenate([load, unload])
    s = np.concatenate([curve(load), curve(unload) - 5.0])
    r = iso527_1_modulus(e, s)
    assert r.method == "chord" and r.n_points == 2 and r.strain_range == (0.0005, 0.0025)
    assert "only 3 sample(s)" in r.reason
    s1 = curve(0.00037) + (curve(0.00064) - curve(0.00037)) * (0.0005 - 0.00037) / (0.00064 - 0.00037)
    s2 = curve(0.00233) + (curve(0.00312) - curve(0.00233)) * (0.0025 - 0.00233) / (0.00312 - 0.00233)
    assert r.modulus == pytest.approx((s2 - s1) / 0.002, rel=1e-12)
    exact = (curve(0.0025) - curve(0.0005)) / 0.002                # 5207 MPa
    assert r.modulus == pytest.approx(exact, rel=0.01)
    next_samples = (curve(0.00312) - curve(0.00064)) / 0.002
    assert next_samples > 1.1 * exact
    # a sample exactly at 0.05 % is taken as it is
    at = np.array([0.0, 0.0005, 0.0011, 0.0026, 0.004])
    assert iso527_1_modulus(at, curve(at)).modulus == pytest.approx(
        (curve(0.0011) + (curve(0.0026) - curve(0.0011)) * 14 / 15 - curve(0.0005)) / 0.002, rel=1e-12)


def test_curve_that_does_not_cover_the_range_gives_none_with_a_reason():
    e = np.linspace(0.0, 0.002, 50)
    r = iso527_1_modulus(e, E_LIN * e)
    assert r.modulus is None and "0.25 %" in r.reason
    r = iso527_1_modulus(e + 0.001, E_LIN * e)
    assert r.modulus is None and "starts above" in r.reason
    a = astm_d638_modulus(e, -e)
    assert a.modulus is None and "positive" in a.reason


def _dnlr_test(rate: float, n: int = 20000, tau_max: float = 5.79) -> bd_data.TestData:
    t = np.linspace(0.0, 1.9 / rate, n)
    eps = rate * t
    true = simulate(t, eps, {"E": 2854.0, "G": 2.32, "tau_max": tau_max})
    return bd_data.TestData(path=Path("synthetic.csv"), sha256="0" * 64, time=t, strain=eps, strain_input=eps,
                    stress=true, nominal_strain=np.expm1(eps), nominal_stress=true * np.exp(-eps),
                    window=np.ones(n, bool), relaxation_start=None, strain_rate=rate,
                    observable="sigma_star")


def test_viscoelastic_curve_standards_far_below_E_and_close_to_each_other():
    test = _dnlr_test(5e-3)
    m = standard_moduli(test)
    assert set(m) == {"iso527_1", "astm_d638"}
    # DNLR curve with E = 2854 MPa, tau_max = 5.79 s at 5e-3 1/s: ISO about 0.67 E
    assert 0.55 * 2854 < m["iso527_1"] < 0.75 * 2854
    assert m["astm_d638"] == pytest.approx(m["iso527_1"], rel=0.1)
    # without a force (nominal_stress None) F/S0 is derived as σ*·exp(-ε): same numbers
    no_force = bd_data.TestData(**{**test.__dict__, "nominal_stress": None})
    r = standard_results(no_force)
    assert r["iso527_1"].modulus == pytest.approx(m["iso527_1"], rel=1e-9)
    assert "derived" in r["iso527_1"].reason


def test_standard_modulus_grows_with_strain_rate_like_table_1():
    # The paper's Table 1: the standards depend on the test speed (E, the model's modulus, does not)
    slow = standard_moduli(_dnlr_test(2.5e-3, tau_max=5.79))["iso527_1"]
    fast = standard_moduli(_dnlr_test(1e-2, tau_max=5.79))["iso527_1"]
    assert fast > slow * 1.05


def test_sparse_noisy_record_astm_keeps_five_samples_and_the_start():
    # 2000 samples to strain 1.9: about 0.1 % strain between samples, so a 0.25 % window holds
    # 2-3 samples; every window must still hold 5 and the steepest is the first (concave curve)
    rng = np.random.default_rng(11)
    t = np.linspace(0.0, 380.0, 2000)
    eps = 5e-3 * t
    true = simulate(t, eps, {"E": 2854.0, "G": 2.32, "tau_max": 5.79})
    e = np.expm1(eps + rng.normal(0, 1e-4, t.size))
    s = true * np.exp(-eps) + rng.normal(0, 0.3, t.size)
    a = astm_d638_modulus(e, s)
    assert a.n_points >= 5 and a.strain_range[0] < 0.001
    assert 0.5 * 2854 < a.modulus < 0.8 * 2854


def shipped_ratios() -> dict[str, dict[str, float]]:
    """Each shipped synthetic test's standard moduli over its true E: every config of runs/ with a
    truth (each test of a config with tests:), the population's specimens included; not the tests
    of the material made at several temperatures (runs/three-temperatures), whose E is the glass's
    and whose 40 °C test is rubbery (the README's sentence is about the HDPE-like tests)."""
    from bayes_dnlr.config import load_config

    out = {}
    for path in sorted((REPO / "runs").glob("**/config.yaml")):
        cfg = load_config(path)
        for name in cfg.test_names:
            view = cfg.for_test(name)
            if view.truth is None or view.truth.shift.temperature != "none":
                continue
            m = standard_moduli(bd_data.load_test(view))
            out[f"{path.parent.relative_to(REPO / 'runs')}/{name}"] = {
                k: v / view.truth.params["E"] for k, v in m.items()}
    return out


README_RATIOS = re.compile(r"ISO 527-1 gives ([0-9.]+)-([0-9.]+) × E and ASTM D638 ([0-9.]+)-([0-9.]+) × E")


@pytest.mark.skipif(not (REPO / "runs" / "hdpe-a-5e-3").is_dir(), reason="shipped examples not present")
def test_the_shipped_examples_standard_moduli_are_the_readmes():
    """The README's ranges of ISO 527-1 / E and ASTM D638 / E are those of every shipped synthetic
    test (to two digits), and each ISO value is the interpolated chord's: taking the samples next
    to 0.05 % and 0.25 % instead puts the 5e-3 1/s example at 0.62 × E."""
    ratios = shipped_ratios()
    assert len(ratios) >= 14 and any(k.startswith("population/") for k in ratios)
    iso = [r["iso527_1"] for r in ratios.values()]
    astm = [r["astm_d638"] for r in ratios.values()]
    found = README_RATIOS.search(" ".join((REPO / "README.md").read_text().split()))
    assert found, "the README's sentence on the standards' ratios"
    quoted = [float(x) for x in found.groups()]
    assert quoted == [round(min(iso), 2), round(max(iso), 2), round(min(astm), 2), round(max(astm), 2)], (
        quoted, {k: {s: round(v, 3) for s, v in r.items()} for k, r in ratios.items()})
    # measured: the 5e-3 1/s example's ISO is a chord (2 samples in 0.05-0.25 %) at 0.730 E
    assert ratios["hdpe-a-5e-3/hdpe-a-5e-3"]["iso527_1"] == pytest.approx(0.730, abs=0.002)


def test_the_model_only_origin_sample_is_never_used(tmp_path):
    """A record cropped at 0.5 % strain read with initial_state: ramp-from-zero gets an unloaded
    model-only sample at strain 0 before its first row: ISO 527-1 (0.05-0.25 %) has no measured
    sample there and is not available, and ASTM D638 starts at the first measured sample."""
    from bayes_dnlr.config import parse_config

    t = np.linspace(0.0, 40.0, 801)
    eps = 5e-3 * t
    true = simulate(t, eps, {"E": 2854.0, "G": 2.32, "tau_max": 5.79})
    keep = eps >= 0.005                                     # the toe cropped, as real exports are
    rows = np.column_stack([t[keep], eps[keep], true[keep]])
    np.savetxt(tmp_path / "cropped.csv", rows, delimiter=",", header="t_s,eps11,stress", comments="")
    cfg = parse_config({"name": "c", "data": {
        "file": "cropped.csv", "columns": {"time": "t_s", "eps11": "eps11", "stress": "stress"},
        "observable": "stress", "initial_state": "ramp-from-zero"}}, source=tmp_path / "config.yaml")
    test = bd_data.load_test(cfg)
    assert test.virtual_start == 1 and test.nominal_strain[0] == 0.0
    r = standard_results(test)
    assert r["iso527_1"].modulus is None and "starts above" in r["iso527_1"].reason
    astm = r["astm_d638"]
    assert astm.strain_range[0] >= test.nominal_strain[1] - 1e-15


def test_each_result_describes_itself_in_one_line_for_the_report():
    e = np.linspace(0.0, 0.01, 1001)
    s = E_LIN * e + 0.2
    assert iso527_1_modulus(e, s).describe() == (
        "ISO 527-1: 1500 MPa, least-squares slope over nominal strain 0.050-0.250 % (201 samples)")
    assert astm_d638_modulus(e, s).describe() == (
        "ASTM D638: 1500 MPa, steepest window (toe-compensated) over nominal strain 0.000-0.250 % "
        "(251 samples), corrected zero at -0.0133 %")
    assert iso527_1_modulus(e[:50], s[:50]).describe() == (
        "ISO 527-1: not available (the curve does not reach 0.25 % nominal strain (max 0.049 %))")
    sparse = iso527_1_modulus(np.array([0.0, 0.001, 0.002, 0.003]), np.array([0.0, 1.5, 3.0, 4.5]))
    assert sparse.describe() == (
        "ISO 527-1: 1500 MPa, chord over nominal strain 0.050-0.250 % (2 samples); only 2 sample(s) "
        "between the two strains, fewer than the 5 a least-squares slope needs")


def test_a_derived_nominal_stress_is_said_after_the_methods_own_note():
    """Without a force, F/S0 comes from the true stress (eq. 6): that note follows any note of the
    method (here the chord's), and a standard that is not available keeps its reason alone."""
    t = np.linspace(0.0, 2.0, 5)
    eps = np.array([0.0, 0.001, 0.002, 0.003, 0.004])
    stress = E_LIN * np.expm1(eps) * np.exp(eps)
    test = bd_data.TestData(path=Path("s.csv"), sha256="0" * 64, time=t, strain=eps, strain_input=eps,
                            stress=stress, nominal_strain=np.expm1(eps), nominal_stress=None,
                            window=np.ones(5, bool), relaxation_start=None, strain_rate=1e-3,
                            observable="sigma_star")
    r = standard_results(test)
    iso = r["iso527_1"]
    assert iso.method == "chord" and iso.reason.startswith("only 2 sample(s) between the two strains")
    derived = "nominal stress derived from the true stress as σ·exp(-ε) (isovolumic, eq. 6)"
    assert iso.reason.endswith("; " + derived) and r["astm_d638"].reason == derived
    short = bd_data.TestData(**{**test.__dict__, "time": t[:2], "strain": eps[:2], "strain_input": eps[:2],
                                "stress": stress[:2], "nominal_strain": np.expm1(eps[:2]),
                                "window": np.ones(2, bool)})
    assert standard_results(short)["iso527_1"].reason.startswith("the curve does not reach")


def test_iso_without_enough_samples_says_why_and_refuses_bad_arguments():
    r = iso527_1_modulus(np.array([0.001]), np.array([1.0]))
    assert (r.standard, r.modulus, r.method, r.reason) == (
        "ISO 527-1", None, "auto", "fewer than two samples")
    e = np.array([0.0, 0.0006, 0.003, 0.004])
    r = iso527_1_modulus(e, 1500.0 * e, method="regression")
    assert (r.standard, r.modulus, r.method, r.reason) == (
        "ISO 527-1", None, "regression", "1 sample(s) between the two strains")
    two = np.array([0.0, 0.0006, 0.002, 0.003, 0.004])
    r = iso527_1_modulus(two, 1500.0 * two, method="regression")       # 2 samples: a slope, with a note
    assert r.modulus == pytest.approx(1500.0) and r.n_points == 2
    assert r.reason == "only 2 samples in the range"
    five = np.array([0.0, 0.0005, 0.001, 0.0015, 0.002, 0.0025, 0.004])
    r = iso527_1_modulus(five, 1500.0 * five)                        # 6 samples: a slope, no note
    assert r.method == "least-squares slope" and r.reason is None
    r = iso527_1_modulus(e + 0.001, 1500.0 * e)
    assert (r.standard, r.method) == ("ISO 527-1", "auto")
    assert r.reason == "the curve starts above 0.05 % nominal strain (0.100 %)"
    r = iso527_1_modulus(e[:2], 1500.0 * e[:2])
    assert (r.standard, r.method) == ("ISO 527-1", "auto")
    assert r.reason == "the curve does not reach 0.25 % nominal strain (max 0.060 %)"
    # the range may start at 0; it may not be empty or reversed, and the method is one of three
    line = np.linspace(0.0, 0.01, 101)
    assert iso527_1_modulus(line, 1500.0 * line, strains=(0.0, 0.0025)).modulus == pytest.approx(1500.0)
    with pytest.raises(ValueError, match=r"strains must satisfy 0 <= e1 < e2, got \(0.0025, 0.0025\)"):
        iso527_1_modulus(line, line, strains=(0.0025, 0.0025))
    with pytest.raises(ValueError, match="method must be auto, regression or chord, got 'slope'"):
        iso527_1_modulus(line, line, method="slope")
    # only the first passage: samples after the strain first exceeds twice e2 are never read
    back = np.concatenate([line[:60], line[30::-1]])
    assert iso527_1_modulus(back, np.concatenate([1500.0 * line[:60], np.zeros(31)])).modulus == (
        pytest.approx(1500.0))
