"""Config validation: every error names the file and the key."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from bayes_dnlr.config import ConfigError, load_config, parse_config

BASE = {
    "name": "t",
    "data": {"file": "t.csv", "columns": {"time": "t_s", "force": "F_N", "eps11": "eps11"},
             "area0": 24.0},
}


def write(tmp_path: Path, raw: dict) -> Path:
    p = tmp_path / "config.yaml"
    p.write_text(yaml.safe_dump(raw))
    return p


def with_(path: str, value):
    raw = yaml.safe_load(yaml.safe_dump(BASE))
    node = raw
    keys = path.split(".")
    for k in keys[:-1]:
        node = node.setdefault(k, {})
    node[keys[-1]] = value
    return raw


def test_defaults_are_filled(tmp_path):
    cfg = load_config(write(tmp_path, BASE))
    assert cfg.free_parameters == ["E", "G", "tau_max"]
    assert cfg.parameters["tau_max"].prior == "log-uniform"
    assert cfg.model.modes == 50 and cfg.model.decades == 6
    assert cfg.data.strain_input == "smoothed" and cfg.data.observable == "sigma_star"
    assert cfg.noise.sigma0 == "residuals"
    assert cfg.sampler.walkers == 32
    assert cfg.data_path == tmp_path.resolve() / "t.csv"
    assert cfg.material is None


def test_material_is_a_label_outside_the_chains_identity(tmp_path):
    """``material:`` names the specimen's material for batch, population and compare; it is no
    part of what a chain depends on, so labelling finished runs keeps their results current."""
    from bayes_dnlr.runs.identity import chain_parts

    plain = load_config(write(tmp_path, BASE))
    labelled = load_config(write(tmp_path, {**BASE, "material": "resin 19"}))
    assert labelled.material == "resin 19" and "material: resin 19" in labelled.to_yaml()
    assert load_config(write(tmp_path, {**BASE, "material": 19})).material == "19"
    assert chain_parts(labelled, "sha") == chain_parts(plain, "sha")


@pytest.mark.parametrize(("raw", "key", "words"), [
    (with_("data.colums", {}), "data.colums", "unknown key"),
    (with_("sampler.walker", 10), "sampler.walker", "unknown key"),
    (with_("parameters.E", {"prior": "uniform", "low": 5000, "high": 100}), "parameters.E",
     "low (5000.0) must be smaller than high (100.0)"),
    (with_("parameters.G", {"value": 2.0, "prior": "uniform", "low": 0, "high": 5}), "parameters.G",
     "a fixed parameter (value: 2.0) takes no prior"),
    (with_("parameters.tau_max", {"prior": "log-uniform", "low": 0, "high": 5}),
     "parameters.tau_max", "needs low > 0"),
    (with_("parameters.E", {"prior": "normal", "mean": 2000}), "parameters.E", "needs sd"),
    (with_("parameters.sigma_inf", {"prior": "uniform", "low": 0, "high": 5}), "(top level)",
     "need a relaxation hold: set data.relaxation_start"),
    (with_("parameters.Young", {"prior": "uniform", "low": 0, "high": 5}), "parameters",
     "unknown parameter(s) ['Young']"),
    (with_("data.area0", -3.0), "data.area0", "positive cross-section"),
    (with_("data.observable", "sigma"), "data", "needs the transverse strain column eps22"),
    (with_("data.columns", {"time": "t", "eps11": "e"}), "data.columns", "needs 'force'"),
    (with_("data.window", {"strain_min": 0.5, "strain_max": 0.1}), "data.window",
     "strain_min (0.5) must be smaller than strain_max (0.1)"),
    (with_("sampler.walkers", 1), "sampler.walkers", "greater than or equal to 2"),
    (with_("model.modes", 0), "model.modes", "greater than or equal to 1"),
    (with_("noise.sigma0", -1.0), "noise.sigma0", "must be a finite number > 0, got -1.0"),
    (with_("noise.sigma0", "resid"), "noise.sigma0", "unknown form"),
    (with_("name", "bad name/"), "name", "pattern"),
    (with_("material", " HDPE"), "material", "expected a short label (1 to 60 printable characters"),
    (with_("material", "x" * 61), "material", "expected a short label"),
    (with_("material", True), "material", "expected a short label, got true"),
])
def test_errors_name_file_and_key(tmp_path, raw, key, words):
    path = write(tmp_path, raw)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    msg = str(err.value)
    assert str(path.resolve()) in msg
    assert f": {key}: " in msg, msg
    assert words in msg


def test_all_fixed_is_refused():
    raw = with_("parameters", {k: {"value": 1.0} for k in ("E", "G", "tau_max")})
    with pytest.raises(ConfigError, match="nothing to identify"):
        parse_config(raw)


def test_missing_file_and_bad_yaml(tmp_path):
    with pytest.raises(ConfigError, match="config file not found"):
        load_config(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(bad)


def test_run_dir_rules(tmp_path):
    own = tmp_path / "t"
    own.mkdir()
    (own / "config.yaml").write_text(yaml.safe_dump(BASE))
    assert load_config(own / "config.yaml").run_dir == own.resolve()        # folder named after run
    assert load_config(write(tmp_path, BASE)).run_dir == tmp_path.resolve() / "t"
    cfg = parse_config(with_("output", {"dir": "out/x"}), source=tmp_path / "c.yaml")
    assert cfg.run_dir == tmp_path / "out/x"


def test_relaxation_adds_its_parameters():
    cfg = parse_config(with_("data.relaxation_start", "auto"))
    assert cfg.free_parameters == ["E", "G", "tau_max", "sigma_inf", "tau_max_R"]
    assert cfg.has_relaxation


def test_a_design_file_given_as_a_run_config_is_named_as_one(tmp_path: Path, capsys) -> None:
    """pydantic would list a design's keys one by one (parameters.E, conditions, constraints...)."""
    from bayes_dnlr.cli import main

    repo = Path(__file__).resolve().parents[2]
    design = repo / "runs" / "design" / "a-par.yaml"
    with pytest.raises(ConfigError, match=r"a design file \(it has conditions:, no data:\), not a run "
                                          r"config: `python -m bayes_dnlr design` reads it"):
        load_config(design)
    for command in ("fit", "sample"):
        assert main([command, str(design)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: {design}: a design file") and "ParameterSpec" not in err
