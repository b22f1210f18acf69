"""fit notices what init would have: a hold without relaxation_start, an engineering stress taken as
the true stress, a window just past the load peak, a force read with a placeholder or contradicted
area0; one warning line each, with the fix (data/hints.py). The exports are the corpus the package
makes (tests/support/export_corpus.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from support.export_corpus import S0, both_stresses, force_extension_strain, ramp_hold_plain, shifted_relax
from support.real_data import ETFE, REAL_MARKS, RHDPE

from bayes_dnlr.cli import main
from bayes_dnlr.config import parse_config
from bayes_dnlr.data import load_test


def _warnings(tmp_path: Path, data: dict[str, Any]) -> list[str]:
    cfg = parse_config({"name": "h", "data": data}, source=tmp_path / "config.yaml")
    return [n for n in load_test(cfg).notes if n.startswith("warning:")]


def test_a_hold_without_relaxation_start(tmp_path):
    case = ramp_hold_plain(tmp_path)
    data = {**case.hand, "file": str(case.path)}
    del data["relaxation_start"]
    warn = [w for w in _warnings(tmp_path, data) if "relaxation hold" in w]
    assert len(warn) == 1 and "set data.relaxation_start: auto" in warn[0]
    assert "the strain stays at 0.2624" in warn[0]                 # ln(1 + 0.3)
    assert not [w for w in _warnings(tmp_path, {**case.hand, "file": str(case.path)}) if "hold" in w]
    # a window that ends before the hold does not see it
    early = {**data, "window": {"time_max": 30.0}}
    assert not [w for w in _warnings(tmp_path, early) if "relaxation hold" in w]


def test_fit_prints_the_hold_warning(tmp_path, capsys):
    case = ramp_hold_plain(tmp_path)
    data = {**case.hand, "file": str(case.path)}
    del data["relaxation_start"]
    import yaml

    cfg = tmp_path / "run" / "config.yaml"
    cfg.parent.mkdir()
    cfg.write_text(yaml.safe_dump({"name": "run", "data": data, "fit": {"multistart": 1}}))
    assert main(["fit", str(cfg)]) == 0
    out = capsys.readouterr().out
    assert "data: warning: a relaxation hold" in out


@pytest.mark.parametrize("make", [both_stresses, shifted_relax])
def test_an_engineering_stress_taken_as_the_true_stress(tmp_path, make):
    case = make(tmp_path)
    right = case.hand["columns"]["stress"]
    data = {**case.hand, "file": str(case.path), "columns": {**case.hand["columns"], "stress": right - 1}}
    warn = [w for w in _warnings(tmp_path, data) if "engineering stress" in w]
    assert len(warn) == 1
    assert warn[0].endswith(f"set data.columns.stress: {right}")
    assert not [w for w in _warnings(tmp_path, {**case.hand, "file": str(case.path)})
                if "engineering stress" in w]


def test_a_window_just_past_the_load_peak(tmp_path):
    case = force_extension_strain(tmp_path)
    base = {**case.hand, "file": str(case.path)}
    test = load_test(parse_config({"name": "h", "data": base}, source=tmp_path / "c.yaml"))
    peak = float(test.strain_input[test.window][-1])            # the hand window ends at the peak
    past = {**base, "window": {"strain_max": round(peak + 0.004, 4)}}
    warn = [w for w in _warnings(tmp_path, past) if "past the load peak" in w]
    assert len(warn) == 1 and "end the window at the peak, data.window: {strain_max: " in warn[0]
    fix = float(warn[0].split("{strain_max: ")[1].split("}")[0])
    fixed = load_test(parse_config({"name": "h", "data": {**base, "window": {"strain_max": fix}}},
                                   source=tmp_path / "c.yaml"))
    assert fixed.time[fixed.window][-1] == case.peak_time          # the fix ends on the peak's sample
    for chosen in ({}, {"strain_max": 0.3}, {"strain_max": fix}):  # the whole test, well past, at it
        assert not [w for w in _warnings(tmp_path, {**base, "window": chosen}) if "past the load" in w]


def test_a_force_read_with_a_placeholder_or_contradicted_area(tmp_path):
    case = force_extension_strain(tmp_path)                       # holds F and F/S0 (S0 = 40)
    base = {**case.hand, "file": str(case.path)}
    warn = [w for w in _warnings(tmp_path, {**base, "area0": 1.0}) if "area0" in w]
    assert len(warn) == 1 and f"set data.area0: {S0:g}" in warn[0] and "S0 = 40 mm²" in warn[0]
    assert not [w for w in _warnings(tmp_path, base) if "data.area0" in w]
    plain = ramp_hold_plain(tmp_path)                             # a force and no stress column
    data = {**plain.hand, "file": str(plain.path), "area0": 1.0}
    warn = [w for w in _warnings(tmp_path, data) if "area0" in w]
    assert len(warn) == 1 and "placeholder" in warn[0] and "the force in N" in warn[0]


def test_the_first_sample_warning_of_init_is_in_newtons(tmp_path):
    """A cropped force record read by init with the placeholder area0 = 1: the warning says the
    force in N, never a stress in MPa that only the placeholder made."""
    from bayes_dnlr.workflows.init import init_config

    case = ramp_hold_plain(tmp_path)
    lines = case.path.read_text().splitlines()
    cropped = tmp_path / "cropped.csv"                      # a ramp and a hold, its first 10 rows cut
    cropped.write_text("\n".join(lines[10:]) + "\n")
    result = init_config(cropped, tmp_path / "run" / "config.yaml")
    first = [p for p in result.problems if p.startswith("the first sample")]
    assert len(first) == 1 and " N (" in first[0] and "MPa" not in first[0].split("noise")[0]
    assert "read with data.area0 = 1 in place of your value" in first[0]


@pytest.mark.parametrize("case", [pytest.param("etfe", marks=REAL_MARKS),
                                  pytest.param("rhdpe", marks=REAL_MARKS)])
def test_the_real_curves_as_the_issue_met_them(tmp_path, case):
    """ETFE read with its engineering stress (column 4), rHDPE with the window init once took from
    its extension column (strain_max 0.084 on the strain of column 6) and with area0 = 1."""
    if case == "etfe":
        data = {"file": str(ETFE), "specimen": 1, "columns": {"time": 1, "strain": 2, "stress": 4},
                "observable": "stress", "strain_measure": "nominal"}
        assert any("set data.columns.stress: 10" in w for w in _warnings(tmp_path, data))
        return
    data = {"file": str(RHDPE), "columns": {"time": 2, "force": 4, "strain": 6}, "strain_unit": "percent",
            "strain_measure": "nominal", "area0": 37.2, "window": {"strain_max": 0.084}}
    warn = _warnings(tmp_path, data)
    assert any("past the load peak (yield) at t = 30.948 s" in w for w in warn)
    assert any("set data.area0: 37.1712" in w for w in _warnings(tmp_path, {**data, "area0": 1.0}))
    ok = {**data, "window": {"strain_max": 0.07}}
    assert not [w for w in _warnings(tmp_path, ok) if "data.area0 is" in w or "past the load" in w]
