"""``reference_moduli:`` entries: a point or a sweep, every error naming the entry and what was
expected (config/reference_section.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from bayes_dnlr.config import ConfigError, parse_config

BASE = {"name": "t", "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                               "observable": "stress"}}


def cfg(refs, **extra):
    return parse_config({**BASE, "reference_moduli": refs, **extra}, source=Path("/tmp/c/config.yaml"))


def test_a_point_and_a_sweep_with_their_keys():
    c = cfg([{"method": "pulse-echo", "value": 2780, "sd": 40, "frequency": 5e6, "temperature": 23,
              "note": "OPBOX"},
             {"method": "nanoindentation", "value": 2380, "relative_sd": 0.02, "time": 0.02, "use": "data"},
             {"method": "dma", "file": "sweep.csv", "relative_sd": 0.02, "use": "data",
              "columns": {"frequency": "f", "storage": 2}, "units": {"storage": "GPa"}}])
    a, b, s = c.reference_moduli
    assert (a.method, a.value, a.sd, a.frequency, a.use, a.temperature) == ("pulse-echo", 2780, 40, 5e6,
                                                                          "check", 23)
    assert b.value_sd() == pytest.approx(47.6) and b.use == "data" and b.time == 0.02
    assert s.is_sweep and s.columns == {"frequency": "f", "storage": 2}
    assert c.reference_labels == ["pulse-echo", "nanoindentation", "dma"]


def test_labels_number_a_shared_method_and_refuse_a_clash():
    c = cfg([{"method": "other", "value": 1}, {"method": "other", "value": 2},
             {"method": "pulse-echo", "value": 3, "name": "PE-core"}])
    assert c.reference_labels == ["other-1", "other-2", "PE-core"]
    with pytest.raises(ConfigError, match="used twice"):
        cfg([{"method": "other", "value": 1, "name": "x"}, {"method": "other", "value": 2, "name": "x"}])


@pytest.mark.parametrize("entry, words", [
    ({"method": "pulse-echo"}, "give value"),
    ({"method": "pulse-echo", "value": 1, "file": "a.csv"}, "give value"),
    ({"method": "pulse-echo", "value": 1, "frequency": 1, "time": 1}, "time scale once"),
    ({"method": "pulse-echo", "value": 1, "frequency": 1, "use": "data"}, "needs the measurement's sd"),
    ({"method": "pulse-echo", "value": 1, "sd": 1, "use": "data"}, "needs the time scale"),
    ({"method": "pulse-echo", "value": 1, "sd": 1, "relative_sd": 0.1}, "not both"),
    ({"method": "nanoindentation", "file": "a.csv", "sd": 1}, "method must be dma"),
    ({"method": "dma", "file": "a.csv"}, "needs its uncertainty"),
    ({"method": "dma", "file": "a.csv", "sd": 1, "frequency": 1}, "leave frequency and time out"),
    ({"method": "dma", "value": 1, "columns": {"storage": 1}}, "belong to a sweep"),
    ({"method": "dma", "file": "a.csv", "sd": 1, "columns": {"modulus": 1}}, "unknown column role"),
    ({"method": "ultrasound", "value": 1}, "method"),
    ({"method": "pulse-echo", "value": -1}, "greater than 0"),
    ({"method": "pulse-echo", "value": True}, "expected a number"),
    ({"method": "pulse-echo", "value": 1, "temperature": -300}, "temperature"),
    ({"method": "pulse-echo", "value": 1, "use": "prior"}, "use"),
])
def test_a_bad_entry_is_one_line_naming_it(entry, words):
    with pytest.raises(ConfigError) as err:
        cfg([entry])
    text = str(err.value)
    assert "reference_moduli" in text and words in text and "\n" not in text


def test_a_reference_names_an_existing_test():
    with pytest.raises(ConfigError, match="no test named 'zz'"):
        cfg([{"method": "pulse-echo", "value": 1, "test": "zz"}])
