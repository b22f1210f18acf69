"""A misspelt config key gets the key it was probably meant to be, read from the models along its
path (config/suggest.py); an unrelated one gets none, and the message stays one line."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from bayes_dnlr.cli import main
from bayes_dnlr.config import Config, ConfigError, parse_config
from bayes_dnlr.config.suggest import close_key
from bayes_dnlr.workflows.design.config import DesignConfig


@pytest.mark.parametrize(("model", "loc", "meant"), [
    (Config, ["data", "observabel"], "observable"),
    (Config, ["data", "window", "strain_mx"], "strain_max"),       # an optional model
    (Config, ["data", "columns", "tiem"], "time"),
    (Config, ["noise", "sigma"], "sigma0"),
    (Config, ["noise", "discrepancy", "kernal"], "kernel"),          # a member of a union
    (Config, ["parameters", "E", "lo"], "low"),                      # a mapping of models
    (Config, ["sampler", "walker"], "walkers"),
    (Config, ["modle"], "model"),
    (Config, ["sampler", "zzz"], None),
    (Config, ["xyz_completely_other"], None),
    (Config, ["data", "no_such_section", "file"], None),            # a path that cannot be followed
    (DesignConfig, ["conditions", "sampling"], "sample_rate"),
    (DesignConfig, ["conditions", "windows", "II", "strain_mx"], "strain_max"),
    (DesignConfig, ["frees"], "free"),
])
def test_the_closest_allowed_key_is_offered(model, loc, meant):
    assert close_key(model, loc) == meant


def test_the_message_offers_it_and_stays_one_line(tmp_path: Path, capsys) -> None:
    raw = {"name": "t", "data": {"file": "t.csv", "columns": {"time": 1, "stress": 2, "strain": 3},
                                 "observable": "stress", "window": {"strain_mx": 0.1}},
           "sampler": {"walker": 16, "zzz": 1}}
    with pytest.raises(ConfigError) as err:
        parse_config(raw, source=tmp_path / "config.yaml")
    text = str(err.value)
    assert "\n" not in text
    assert "data.window.strain_mx: unknown key (did you mean strain_max? see docs/config.md)" in text
    assert "sampler.walker: unknown key (did you mean walkers? see docs/config.md)" in text
    assert "sampler.zzz: unknown key (check the spelling; see docs/config.md)" in text
    design = tmp_path / "design.yaml"
    design.write_text(yaml.safe_dump({"name": "d", "parameters": {"E": 2854.0, "G": 2.32, "tau_max": 5.79},
                                      "conditions": {"strain_rate": 1e-3, "strain_max": 0.5,
                                                     "sampling": 5.0}}))
    assert main(["design", str(design)]) == 2
    assert ("conditions.sampling: unknown key (did you mean sample_rate? see docs/design.md)"
            in capsys.readouterr().err)
