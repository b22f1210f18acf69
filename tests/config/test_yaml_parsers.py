"""The YAML loader reads with libyaml's parser where PyYAML has it, and with PyYAML's own parser
otherwise (config/yamlio.py): both give the same values, the same lines in their messages and the
same refusals for the limits, so that a machine without libyaml reads every config alike."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from bayes_dnlr.config import yamlio
from bayes_dnlr.config.yamlio import MAX_DEPTH, YamlError, parse_yaml

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted(ROOT.glob("runs/*/config.yaml"))

DOCUMENTS = {
    "numbers": "a: 1e3\nb: 3e-1\nc: 1_000\nd: 0x10\ne: yes\nf: .5\ng: -2.5E+2\nh: ~\n",
    "anchors": "base: &b {low: 1, high: 2}\nE: *b\nG: {<<: *b, high: 3}\n",
    "duplicate": "name: t\ndata:\n  area0: 24\n  file: x.csv\n  area0: 25\n",
    "duplicate-in-list": "tests:\n  - name: a\n  - name: b\n    name: c\n",
    "deep": "deep: " + "[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1) + "\n",
    "very-deep": "deep: " + "[" * 5000 + "]" * 5000 + "\n",
    "deep-block": "".join(f"{'  ' * i}k{i}:\n" for i in range(MAX_DEPTH + 5))
                  + "  " * (MAX_DEPTH + 5) + "v\n",
    "recursive": "a: &x [1, *x]\n",
    "bomb": "x0: &a0 [l, l, l, l, l, l, l, l, l]\n" + "".join(
        f"x{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]\n" for i in range(1, 9)),
    "python-tag": "a: !!python/object:os.system 1\n",
    "unclosed": "a: [1, 2\n",
    "empty": "",
}


@pytest.fixture(params=["libyaml", "python"])
def loader(request, monkeypatch) -> str:
    if request.param == "libyaml" and yamlio.CParser is None:
        pytest.skip("PyYAML is built without libyaml here")
    if request.param == "python":
        monkeypatch.setattr(yamlio, "Loader", yamlio.PythonLoader)
    return request.param


def _read(text: str) -> tuple[str, object]:
    """('ok', the values) or ('error', the message without the parser's own words). The column is
    the parser's too: libyaml reads ahead of the composer, and meets its own nesting limit (1000
    levels) further along the line than the composer's (MAX_DEPTH)."""
    try:
        return "ok", parse_yaml(text, "c.yaml")
    except YamlError as err:
        message = re.sub(r", column \d+", "", str(err))
        return "error", re.sub(r"not valid YAML: .*", "not valid YAML", message)


def _both(text: str, monkeypatch) -> tuple:
    fast = _read(text) if yamlio.CParser is not None else None
    monkeypatch.setattr(yamlio, "Loader", yamlio.PythonLoader)
    slow = _read(text)
    monkeypatch.undo()
    return fast, slow


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.parent.name)
def test_every_shipped_config_reads_the_same_with_both_parsers(path: Path, monkeypatch) -> None:
    fast, slow = _both(path.read_text(), monkeypatch)
    assert slow[0] == "ok" and fast in (None, slow)


@pytest.mark.parametrize("name", list(DOCUMENTS))
def test_every_document_reads_or_is_refused_the_same(name: str, monkeypatch) -> None:
    fast, slow = _both(DOCUMENTS[name], monkeypatch)
    assert fast in (None, slow), (fast, slow)


def test_the_duplicated_key_names_both_lines(loader) -> None:
    twice = r"c\.yaml: line 5: key 'data\.area0' is given twice \(first at line 3\)"
    with pytest.raises(YamlError, match=twice):
        parse_yaml(DOCUMENTS["duplicate"], "c.yaml")


@pytest.mark.parametrize("name", ["deep", "very-deep", "deep-block"])
def test_nesting_is_refused_as_our_limit(loader, name: str) -> None:
    too_deep = rf"c\.yaml: line \d+, column \d+: not read: .*nested deeper than {MAX_DEPTH}"
    with pytest.raises(YamlError, match=too_deep):
        parse_yaml(DOCUMENTS[name], "c.yaml")


# ---------------------------------------------------------------- writing

AWKWARD = {"name": "épreuve à 23 °C", "note": "two\nlines", "long": "word " * 40,
           "quote": "it's: a \"test\"", "empty": "", "none": None, "flags": [True, False],
           "numbers": [1, -2.5, 1e-12, 3e300, float("inf"), float("-inf")],
           "nested": {"a": {"b": [{"c": 1}, {"d": [1, 2]}]}}, "yes": "yes",
           "number-like": ["1e3", "0x10", "~", "null", "2026-11-28"]}


@pytest.mark.skipif(yamlio.CSafeDumper is None, reason="PyYAML is built without libyaml here")
def test_libyaml_writes_the_text_pyyamls_emitter_writes(monkeypatch) -> None:
    """dump_yaml (libyaml's emitter) gives PyYAML's own text on every shipped config, resolved,
    and on awkward values; both parsers read it back to the same values (a string that reads as a
    number is quoted)."""
    from bayes_dnlr.config import load_config

    documents = [load_config(path).as_dict() for path in SHIPPED] + [AWKWARD]
    assert len(documents) > 1
    for data in documents:
        text = yamlio.dump_yaml(data)
        with monkeypatch.context() as m:
            m.setattr(yamlio, "Dumper", yamlio.PythonDumper)
            assert yamlio.dump_yaml(data) == text
            m.setattr(yamlio, "Loader", yamlio.PythonLoader)
            assert parse_yaml(text, "c.yaml") == data
        assert parse_yaml(text, "c.yaml") == data
    assert "- '1e3'" in yamlio.dump_yaml(AWKWARD)
