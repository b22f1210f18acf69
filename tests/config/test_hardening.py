"""The one YAML loader of every command (configs, design files, manifest cells) against hostile
documents: a boolean where a number is expected, an alias bomb, deep nesting, a huge file. Each is
refused with one line naming the file and what was wrong, in bounded time; the CLI exits 2.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml

from bayes_dnlr import cli
from bayes_dnlr.config import ConfigError, load_config, parse_config, yamlio
from bayes_dnlr.config.yamlio import MAX_DEPTH, MAX_NODES, MAX_YAML_BYTES, YamlError, parse_yaml

DATA = {"file": "x.csv", "columns": {"time": "t", "force": "F", "eps11": "e"}, "area0": 24.0}


def _raw(**data) -> dict:
    return {"name": "t", "data": {**DATA, **data}}


def alias_bomb(levels: int) -> str:
    """``levels`` top-level keys, each a list of nine aliases of the one before (9**levels leaves)."""
    names = [f"a{i}" for i in range(levels)]
    text = f"x0: &{names[0]} [l, l, l, l, l, l, l, l, l]\n"
    for i in range(1, levels):
        text += f"x{i}: &{names[i]} [" + ", ".join([f"*{names[i - 1]}"] * 9) + "]\n"
    return text


# ---------------------------------------------------------------- booleans are not numbers

@pytest.mark.parametrize("key, value", [
    ("area0", True), ("area0", False), ("strain_rate", True), ("gauge_length", True),
])
def test_boolean_refused_where_a_number_is_expected(key: str, value: bool) -> None:
    with pytest.raises(ConfigError, match=rf"data\.{key}: expected a number, got {str(value).lower()}"):
        parse_config(_raw(**{key: value}))


@pytest.mark.parametrize("section, key, value, path", [
    ("model", "modes", True, "model.modes"),
    ("sampler", "walkers", True, "sampler.walkers"),
    ("sampler", "seed", False, "sampler.seed"),
    ("sampler", "target_ess", True, "sampler.target_ess"),
    ("fit", "multistart", True, "fit.multistart"),
    ("parameters", "E", {"prior": "uniform", "low": True, "high": 20000}, "parameters.E.low"),
    ("parameters", "G", {"value": True}, "parameters.G.value"),
])
def test_boolean_refused_in_every_section(section: str, key: str, value, path: str) -> None:
    raw = {**_raw(), section: {key: value}}
    with pytest.raises(ConfigError, match=rf"{path}: expected a (whole )?number, got (true|false)"):
        parse_config(raw)


def test_column_number_is_not_a_boolean() -> None:
    with pytest.raises(ConfigError, match=r"data\.columns\.time"):
        parse_config(_raw(columns={"time": True, "force": "F", "eps11": "e"}))


def test_numbers_in_every_form_still_read() -> None:
    """The strict numbers keep what YAML users write: an int for a float, 1e5 for a whole number."""
    text = ("name: t\ndata: {file: x.csv, columns: {time: t, force: F, eps11: e}, area0: 24}\n"
            "sampler: {max_steps: 1e5, walkers: 32.0, seed: 3}\nmodel: {decades: 6}\n")
    cfg = parse_config(parse_yaml(text, "c.yaml"))
    assert cfg.data.area0 == 24.0 and isinstance(cfg.data.area0, float)
    assert cfg.sampler.max_steps == 100000 and isinstance(cfg.sampler.max_steps, int)
    assert cfg.sampler.walkers == 32 and isinstance(cfg.sampler.walkers, int)
    with pytest.raises(ConfigError, match=r"sampler\.walkers: expected a whole number, got 32\.5"):
        parse_config({**_raw(), "sampler": {"walkers": 32.5}})
    with pytest.raises(ConfigError, match=r"data\.area0: expected a number, got '24'"):
        parse_config(_raw(area0="24"))


def test_area0_true_stops_fit_on_the_command_line(tmp_path: Path, capsys) -> None:
    """``area0: true`` used to be read as 1 mm²: `fit` ran and put E on the prior's bound."""
    (tmp_path / "x.csv").write_text("t,F,e\n0,0,0\n1,10,0.01\n2,20,0.02\n")
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(_raw(area0=True)))
    code = cli.main(["fit", "--quiet", str(tmp_path / "config.yaml")])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("error: ") and "data.area0" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "t").exists()


# ---------------------------------------------------------------- aliases

def test_alias_bomb_refused_quickly() -> None:
    """Nine levels of nine-fold aliases (3.9e8 leaves): refused within a fraction of a second."""
    t0 = time.process_time()
    with pytest.raises(YamlError, match=r"bomb\.yaml: .*alias"):
        parse_yaml(alias_bomb(9), "bomb.yaml")
    assert time.process_time() - t0 < 2.0


@pytest.mark.parametrize("levels", [6, 9, 12, 40])
def test_alias_bomb_cost_does_not_grow(levels: int) -> None:
    t0 = time.process_time()
    with pytest.raises(YamlError, match=f"more than {MAX_NODES} values"):
        parse_yaml(alias_bomb(levels), "bomb.yaml")
    assert time.process_time() - t0 < 2.0


def test_aliases_within_the_budget_read() -> None:
    """Five levels expand to 9**5 = 59049 values, within MAX_NODES: read, as YAML says."""
    doc = parse_yaml(alias_bomb(5), "ok.yaml")
    assert len(doc["x4"]) == 9 and doc["x4"][0][0][0][0] == ["l"] * 9


def test_aliases_used_once_are_fine() -> None:
    text = ("name: t\nprior: &p {prior: uniform, low: 100, high: 20000}\n")
    assert parse_yaml(text, "c.yaml")["prior"] == {"prior": "uniform", "low": 100, "high": 20000}
    text = "a: &x {k: 1}\nb: *x\nc: [*x, *x]\n"
    assert parse_yaml(text, "c.yaml")["c"] == [{"k": 1}, {"k": 1}]


def test_recursive_alias_refused() -> None:
    with pytest.raises(YamlError, match=r"c\.yaml: .*"):
        parse_yaml("a: &x [1, *x]\n", "c.yaml")


def test_alias_bomb_through_the_command_line(tmp_path: Path, capsys) -> None:
    (tmp_path / "config.yaml").write_text(alias_bomb(9))
    t0 = time.process_time()
    code = cli.main(["fit", str(tmp_path / "config.yaml")])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("error: ") and len(err.splitlines()) == 1
    assert time.process_time() - t0 < 5.0


# ---------------------------------------------------------------- depth and size

@pytest.mark.parametrize("n", [MAX_DEPTH + 1, 5000, 100_000])
def test_deep_flow_nesting_is_one_line(n: int) -> None:
    with pytest.raises(YamlError, match=rf"deep\.yaml: line 1, column \d+: .*nested deeper than {MAX_DEPTH}"):
        parse_yaml("deep: " + "[" * n + "]" * n + "\n", "deep.yaml")


def test_deep_block_nesting_is_one_line() -> None:
    text = "".join(f"{'  ' * i}k{i}:\n" for i in range(MAX_DEPTH + 5)) + "  " * (MAX_DEPTH + 5) + "v\n"
    with pytest.raises(YamlError, match=rf"nested deeper than {MAX_DEPTH}"):
        parse_yaml(text, "deep.yaml")


def test_nesting_at_the_limit_reads() -> None:
    n = MAX_DEPTH - 1
    assert parse_yaml("deep: " + "[" * n + "]" * n + "\n", "ok.yaml") is not None


def test_deep_nesting_through_the_command_line(tmp_path: Path, capsys) -> None:
    (tmp_path / "config.yaml").write_text("deep: " + "[" * 5000 + "]" * 5000 + "\n")
    code = cli.main(["fit", str(tmp_path / "config.yaml")])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and err.startswith("error: ")
    assert "nested deeper" in err


def test_file_too_large(tmp_path: Path) -> None:
    path = tmp_path / "config.yaml"
    path.write_text("# " + "x" * MAX_YAML_BYTES + "\nname: t\n")
    with pytest.raises(ConfigError, match=r"config\.yaml: .*larger than"):
        load_config(path)


def test_too_many_nodes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = "big: [" + ", ".join("1" for _ in range(MAX_NODES + 10)) + "]\n"
    assert len(text.encode()) < MAX_YAML_BYTES          # the limit on values is met first
    # the loader counts against the module's limit whatever it is: refused at a limit of 1000, as at
    # 100 000 (which PyYAML's pure-Python scanner takes 6 s to reach)
    monkeypatch.setattr(yamlio, "MAX_NODES", 1000)
    text = "big: [" + ", ".join("1" for _ in range(1000 + 10)) + "]\n"
    with pytest.raises(YamlError, match=r"more than 1000 values"):
        parse_yaml(text, "big.yaml")
    parse_yaml("big: [" + ", ".join("1" for _ in range(990)) + "]\n", "big.yaml")   # within it: read


# ---------------------------------------------------------------- the other readers share it

def test_design_file_uses_the_same_loader(tmp_path: Path) -> None:
    from bayes_dnlr.workflows.design.config import load_design

    path = tmp_path / "design.yaml"
    path.write_text(alias_bomb(9))
    t0 = time.process_time()
    with pytest.raises(ConfigError, match="alias"):
        load_design(path)
    assert time.process_time() - t0 < 2.0
    path.write_text("deep: " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(ConfigError, match="nested deeper"):
        load_design(path)


def test_manifest_cell_uses_the_same_loader() -> None:
    from bayes_dnlr.workflows.batch.manifest import parse_cell

    deep = "[" * 5000 + "]" * 5000
    assert parse_cell(deep) == deep                     # not YAML we read: the text itself
    bomb = "[" + ", ".join(f"&a{i} [" + ", ".join([f"*a{i - 1}" if i else "l"] * 9) + "]"
                           for i in range(9)) + "]"
    t0 = time.process_time()
    assert parse_cell(bomb) == bomb
    assert time.process_time() - t0 < 2.0
    assert parse_cell("{prior: half-normal, scale: 5}") == {"prior": "half-normal", "scale": 5}
    assert parse_cell("true") is True and parse_cell("null") is None and parse_cell("24.1") == 24.1
