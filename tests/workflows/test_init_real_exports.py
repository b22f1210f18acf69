"""init -> fit, unedited, on two more real exports of the ETFE film (read when present,
tests/support/real_data.py): a ramp then a hold whose header sits one column off its data from the
sixth column of each group, and loading-unloading cycles with an engineering stress only and a
repeated time stamp. The config init writes reads the columns the relations confirm, finds the hold,
handles the repeated stamp, and gives the E of a config written by hand from the data's own
description."""

from __future__ import annotations

import pytest
import yaml
from support.real_data import CYCLES, RELAX, reads_export

from bayes_dnlr.config import load_config, parse_config
from bayes_dnlr.data import load_test
from bayes_dnlr.runs.fit import fit
from bayes_dnlr.workflows.init import init_config

# the hand configs: the layouts as the source repository's scripts read them (time, the area's
# nominal strain, the true stress = engineering × (1 + e); time, the point's nominal strain, the
# engineering stress), the hold from the data, the repeated stamp dropped
HAND_RELAX = {"specimen": 1, "specimen_columns": 9, "columns": {"time": 1, "strain": 2, "stress": 8},
              "strain_unit": "fraction", "strain_measure": "nominal", "observable": "stress",
              "relaxation_start": "auto", "window": {}}
HAND_CYCLES = {"specimen": 1, "specimen_columns": 8, "columns": {"time": 1, "strain": 2, "stress": 4},
               "strain_unit": "fraction", "strain_measure": "nominal", "observable": "stress",
               "stress_measure": "engineering", "repeated_time": "drop", "window": {"time_max": 16.8}}


def _init_fit_hand(path, hand, tmp_path):
    out = tmp_path / "init" / "config.yaml"
    result = init_config(path, out)
    assert not [e for e in result.edits if e.action == "set"], result.text()
    assert not result.problems, result.problems
    cfg = load_config(out)
    hand_cfg = parse_config({"name": "hand", "data": {"file": str(path), **hand},
                             "noise": {"sigma0": "residuals"}}, source=tmp_path / "hand" / "config.yaml")
    return result, yaml.safe_load(out.read_text())["data"], cfg, hand_cfg


@reads_export(RELAX)
def test_the_relaxation_export_is_read_by_its_relations_and_its_hold_found(tmp_path):
    result, data, cfg, hand = _init_fit_hand(RELAX, HAND_RELAX, tmp_path)
    assert data["columns"] == {"time": 1, "stress": 8, "strain": 2}
    assert data["relaxation_start"] == "auto" and data["window"] == {}
    assert (data["observable"], data["strain_measure"], data["strain_unit"]) == ("stress", "nominal",
                                                                                 "fraction")
    text = result.text()
    assert "column 7 is named 'StressTrue01AVG' (a true stress), but column 8 = column 3 × (1 + " \
           "column 2)" in text, text
    assert "column 6 is named 'exxHencky01SOI' (a Hencky strain), but column 6 = column 1" in text
    test = load_test(cfg)
    assert test.relaxation_start is not None and not any(n.startswith("warning") for n in test.notes)
    mine, theirs = fit(cfg, write=False), fit(hand, write=False)
    assert mine.estimate["E"] == pytest.approx(theirs.estimate["E"], rel=1e-9)


@reads_export(CYCLES)
def test_the_cyclic_export_is_read_with_its_repeated_stamp_and_engineering_stress(tmp_path):
    result, data, cfg, hand = _init_fit_hand(CYCLES, HAND_CYCLES, tmp_path)
    assert data["columns"] == {"time": 1, "stress": 4, "strain": 2}
    assert (data["repeated_time"], data["stress_measure"]) == ("drop", "engineering")
    assert data["window"] == {"time_max": 16.8}           # the first loading (docs/data-input.md)
    assert "loading-unloading cycles" in result.text()
    test = load_test(cfg)
    assert any(n.startswith("repeated time stamps: 1 row(s)") for n in test.notes), test.notes
    assert not any(n.startswith("warning") for n in test.notes), test.notes     # no spike, no hint
    mine, theirs = fit(cfg, write=False), fit(hand, write=False)
    assert mine.estimate["E"] == pytest.approx(theirs.estimate["E"], rel=1e-9)
