"""The words of a YAML file that cannot be read (config/yamlio.py): the file, the line and column
where the parser stopped, what it expected; the text written back keeps the user's key order."""

from __future__ import annotations

from pathlib import Path

import pytest

from bayes_dnlr.config import ConfigError, load_config
from bayes_dnlr.config.yamlio import YamlError, dump_yaml, parse_yaml, read_text


@pytest.mark.parametrize(("text", "message"), [
    # the line and column where the parser found the problem, not where the list began
    ("a: [1, 2\nb: 3\n", "c.yaml: line 2, column 2: not valid YAML: did not find expected ',' or ']' "
                         "(while parsing a flow sequence)"),
    ("a: 1\n  b: 2\n", "c.yaml: line 2, column 4: not valid YAML: mapping values are not allowed in "
                       "this context"),
    ("[" * 40 + "]" * 40, "c.yaml: line 1, column 33: not read: the document is nested deeper than 32 "
                          "levels (a config nests 6)"),
    ("a: &x [*x]\n", "c.yaml: line 1, column 4: not read: an alias refers to the list or mapping that "
                     "contains it"),
    # an error without a place in the text: the reader's own words, on one line
    ("a: 1\x00\n", "c.yaml: not valid YAML: unacceptable character #x0000: control characters are not "
                   "allowed in \"<unicode string>\", position 4"),
])
def test_a_document_that_cannot_be_read_is_one_line_with_its_place(text: str, message: str) -> None:
    with pytest.raises(YamlError) as err:
        parse_yaml(text, "c.yaml")
    assert str(err.value) == message


def test_a_config_file_names_itself_in_the_error(tmp_path: Path) -> None:
    bad = tmp_path / "config.yaml"
    bad.write_text("a: [1\n")
    with pytest.raises(ConfigError) as err:
        load_config(bad)
    assert str(err.value) == (f"{bad}: line 2, column 1: not valid YAML: did not find expected ',' or "
                              "']' (while parsing a flow sequence)")
    with pytest.raises(YamlError) as err:
        read_text(tmp_path)
    assert str(err.value) == f"{tmp_path}: is a directory, not a config file"


def test_the_written_text_keeps_the_key_order() -> None:
    data = {"name": "x", "data": {"file": "d.csv", "columns": {"time": "t", "stress": "s"}}, "a": 1}
    text = dump_yaml(data)
    assert text == "name: x\ndata:\n  file: d.csv\n  columns:\n    time: t\n    stress: s\na: 1\n"
    assert list(parse_yaml(text, "x")) == ["name", "data", "a"]
