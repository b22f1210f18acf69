"""Reading a YAML file the user wrote (config.yaml, design.yaml): one-line errors that name the
file, line and column, and no silent surprises.

- The file must be readable UTF-8 text (a byte order mark is allowed); otherwise the error names the
  line of the first bad byte.
- A key given twice in the same mapping is refused, with both lines: plain YAML loaders keep the
  last one silently, so a duplicated ``area0`` would change the result without a word.
- A syntax error is one line: file, line, column and what the parser expected.
- A number in exponent form without a point (``1e12``, ``3e-1``) is a number, as in YAML 1.2:
  YAML 1.1 (PyYAML's default) reads it as a string, and ``sigma0: 3e-1`` would be refused.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from bayes_dnlr.errors import BayesDnlrError


class Loader(yaml.SafeLoader):
    """PyYAML's safe loader, with YAML 1.2's floats in exponent form without a point."""


Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float", re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"))


class YamlError(BayesDnlrError, ValueError):
    """A YAML file that cannot be read as written; the message names the file and the line."""


def read_text(path: Path, what: str = "config file") -> str:
    """The UTF-8 text of ``path``; YamlError (one line) when missing, a folder, unreadable or not UTF-8."""
    path = Path(path)
    if path.is_dir():
        raise YamlError(f"{path}: is a directory, not a {what}")
    if not path.exists():
        raise YamlError(f"{path}: {what} not found")
    try:
        data = path.read_bytes()
    except OSError as err:
        raise YamlError(f"{path}: cannot read the {what} ({err.strerror or err})") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        line = data[:err.start].count(b"\n") + 1
        column = err.start - (data.rfind(b"\n", 0, err.start) + 1) + 1
        raise YamlError(f"{path}: line {line}, column {column}: byte 0x{data[err.start]:02x} is not "
                        f"UTF-8 text; save the {what} as UTF-8") from None


def _mark(err: yaml.YAMLError) -> str:
    mark = getattr(err, "problem_mark", None) or getattr(err, "context_mark", None)
    return f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""


def _describe(err: yaml.YAMLError) -> str:
    problem = getattr(err, "problem", None)
    context = getattr(err, "context", None)
    if problem:
        return f"{problem}" + (f" ({context})" if context else "")
    return " ".join(str(err).split())


def _key_text(node: yaml.Node) -> str:
    return str(node.value) if isinstance(node, yaml.ScalarNode) else f"<{node.tag}>"


def _duplicates(node: yaml.Node, path: str, found: list[str]) -> None:
    """Append one message per key that occurs twice in a mapping of ``node`` (depth first)."""
    if isinstance(node, yaml.MappingNode):
        seen: dict[str, int] = {}
        for key, value in node.value:
            if key.tag == "tag:yaml.org,2002:merge":
                continue
            name = _key_text(key)
            where = f"{path}.{name}" if path else name
            line = key.start_mark.line + 1
            if name in seen:
                found.append(f"line {line}: key '{where}' is given twice (first at line {seen[name]}); "
                             "YAML would silently keep the last one: keep one")
            else:
                seen[name] = line
            _duplicates(value, where, found)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _duplicates(item, f"{path}[{i}]", found)


def parse_yaml(text: str, where: str) -> Any:
    """The YAML document in ``text`` (None when empty); YamlError naming ``where`` and the line for
    a syntax error or a duplicated key."""
    try:
        node = yaml.compose(text, Loader=Loader)
    except yaml.YAMLError as err:
        raise YamlError(f"{where}: {_mark(err)}not valid YAML: {_describe(err)}") from None
    if node is None:
        return None
    found: list[str] = []
    _duplicates(node, "", found)
    if found:
        raise YamlError(f"{where}: {found[0]}")
    try:
        return yaml.load(text, Loader=Loader)  # noqa: S506 - a safe loader
    except yaml.YAMLError as err:   # e.g. a tag the safe loader does not construct
        raise YamlError(f"{where}: {_mark(err)}not valid YAML: {_describe(err)}") from None


def load_yaml(path: str | Path, what: str = "config file") -> Any:
    """Read and parse a YAML file the user wrote (see the module doc)."""
    path = Path(path)
    return parse_yaml(read_text(path, what), str(path))
