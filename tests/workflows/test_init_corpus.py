"""init -> fit on real-layout exports, with no edit but area0 where a force needs it: the right
columns, specimens and hold, the window up to the load peak, and the same E as a config written by
hand to 1e-9. The corpus is made by the package (tests/support/export_corpus.py); the two real curves are
read when present (tests/support/real_data.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from support.export_corpus import CASES, Case
from support.real_data import ETFE, REAL_MARKS, RHDPE

from bayes_dnlr.config import load_config, parse_config
from bayes_dnlr.data import load_test
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.workflows.init import init_config


def _set(raw: dict, key: str, value: Any) -> None:
    *path, last = key.split(".")
    node = raw
    for k in path:
        node = node.setdefault(k, {})
    node[last] = value


def _init_then_fit(case: Case, tmp_path: Path):
    out = tmp_path / "init" / "config.yaml"
    result = init_config(case.path, out)
    assert {e.key for e in result.edits if e.action == "set"} == set(case.set), result.text()
    assert not any("cannot be read" in p for p in result.problems), result.problems
    assert ("EDIT:" in out.read_text()) == bool(case.set)     # marked only where a value must be set
    raw = yaml.safe_load(out.read_text())
    for key, value in case.expect.items():
        assert raw["data"].get(key) == value, (key, raw["data"])
    assert ("relaxation_start" in raw["data"]) == ("relaxation_start" in case.expect)
    for key, value in case.set.items():                 # the only edit: what init asks to set
        _set(raw, key, value)
    out.write_text(yaml.safe_dump(raw, sort_keys=False, allow_unicode=True))
    cfg = load_config(out)
    test = load_test(cfg)
    hints = ("warning: a relaxation hold", "warning: data.columns.stress", "warning: data.window ends",
             "warning: data.area0")
    assert not [n for n in test.notes if n.startswith(hints)]      # nothing fit would flag
    if case.peak_time is not None:                     # the window ends on the load peak's sample
        assert test.time[test.window][-1] == case.peak_time
    hand = parse_config({"name": "hand", "data": {"file": str(case.path), **case.hand},
                         "noise": {"sigma0": "residuals"}}, source=tmp_path / "hand" / "config.yaml")
    return fit(cfg, write=False), fit(hand, write=False), test


@pytest.mark.parametrize("name", list(CASES))
def test_init_then_fit_gives_the_hand_written_configs_E(tmp_path, name):
    case = CASES[name](tmp_path)
    mine, hand, test = _init_then_fit(case, tmp_path)
    assert mine.estimate["E"] == pytest.approx(hand.estimate["E"], rel=1e-9)
    assert mine.converged
    # the truth, near: within 5 % or, on a short window (a cyclic test's first loading), 3 of its sd
    assert abs(mine.estimate["E"] - 2854.0) < max(0.05 * 2854.0, 3 * mine.sd["E"]), (mine.estimate, mine.sd)
    if "relaxation_start" in case.expect:
        assert {"sigma_inf", "tau_max_R"} <= set(mine.estimate)


def _rhdpe_case() -> Case:
    a = np.loadtxt(RHDPE, delimiter=",", usecols=(1, 3))
    peak = float(a[int(np.argmax(a[:, 1])), 0])           # the force's peak (yield)
    data = {"columns": {"time": 2, "force": 4, "strain": 6}, "strain_unit": "percent",
            "strain_measure": "nominal", "area0": 37.1712, "initial_state": "ramp-from-zero"}
    # the hand config: the data README's layout, S0 as the export's stress column used it, and the
    # first rows its source cropped put back (its strain counts from the unloaded length)
    return Case("rhdpe", RHDPE, data, {**data, "window": {"time_max": peak}}, peak_time=peak)


def _etfe_case() -> Case:
    expect = {"specimen": 1, "columns": {"time": 1, "strain": 8, "stress": 10}, "observable": "stress",
              "strain_measure": "hencky", "window": {}}
    hand = {"specimen": 1, "columns": {"time": 1, "eps11": 8, "stress": 10}, "observable": "stress"}
    return Case("etfe", ETFE, expect, hand)                # docs/data-input.md's hand-written config


@pytest.mark.parametrize("make", [pytest.param(_rhdpe_case, marks=REAL_MARKS, id="rhdpe"),
                                  pytest.param(_etfe_case, marks=REAL_MARKS, id="etfe")])
def test_init_then_fit_on_the_real_curves(tmp_path, make):
    case = make()
    mine, hand, _ = _init_then_fit(case, tmp_path)
    assert mine.estimate["E"] == pytest.approx(hand.estimate["E"], rel=1e-9)
