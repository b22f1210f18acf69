"""Reading a YAML file the user wrote (config.yaml, design.yaml): one-line errors that name the
file, line and column, and no silent surprises.

- The file must be readable UTF-8 text (a byte order mark is allowed); otherwise the error names the
  line of the first bad byte.
- A key given twice in the same mapping is refused, with both lines: plain YAML loaders keep the
  last one silently, so a duplicated ``area0`` would change the result without a word.
- A syntax error is one line: file, line, column and what the parser expected.
- A number in exponent form without a point (``1e12``, ``3e-1``) is a number, as in YAML 1.2:
  YAML 1.1 (PyYAML's default) reads it as a string, and ``sigma0: 3e-1`` would be refused.
- Bounded work whatever the document: at most MAX_YAML_BYTES of text, MAX_DEPTH levels of nesting
  and MAX_NODES values once every alias is expanded (an alias bomb, nine levels of nine-fold
  aliases, would expand to 9**9 values; a recursive alias to infinitely many). Each limit is a
  one-line error found before the document is walked or built, in time linear in its size.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from yaml.composer import Composer
from yaml.constructor import SafeConstructor
from yaml.resolver import Resolver

try:
    from yaml.cyaml import CParser, CSafeDumper
except ImportError:                     # PyYAML built without libyaml
    CParser = CSafeDumper = None

from bayes_dnlr.errors import BayesDnlrError

MAX_YAML_BYTES = 1 << 20     # a config with a thousand tests is about 300 kB
MAX_DEPTH = 32               # a config nests 6 levels (tests[i].noise.discrepancy.amplitude.low)
MAX_NODES = 100_000          # values of the document with its aliases expanded
TOO_DEEP = f"the document is nested deeper than {MAX_DEPTH} levels (a config nests 6)"


class _Bounded:
    """Stops composing past MAX_DEPTH levels or MAX_NODES values (PyYAML's composer recurses once
    per level: 5000 nested brackets were a RecursionError)."""

    _depth = 0
    _nodes = 0

    def compose_node(self, parent, index):
        self._depth += 1
        self._nodes += 1
        try:
            if self._depth > MAX_DEPTH:
                raise _Limit(TOO_DEEP, self.peek_event().start_mark)
            if self._nodes > MAX_NODES:
                raise _Limit(f"the document holds more than {MAX_NODES} values", self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


class PythonLoader(_Bounded, yaml.SafeLoader):
    """PyYAML's safe loader, bounded: the whole parse in Python."""


if CParser is not None:
    class Loader(_Bounded, Composer, CParser, SafeConstructor, Resolver):
        """PyYAML's safe loader, bounded, with libyaml's scanner and parser: the text is read in C
        (a config in 1-4 ms instead of 10-25 ms, and every command reads its config several times);
        the document is composed, checked and built in Python as with PythonLoader. The messages of
        a syntax error are libyaml's."""

        def __init__(self, stream: str) -> None:
            CParser.__init__(self, stream)
            Composer.__init__(self)
            SafeConstructor.__init__(self)
            Resolver.__init__(self)
else:
    Loader = PythonLoader               # the same, all in Python


class PythonDumper(yaml.SafeDumper):
    """PyYAML's safe dumper, all in Python."""


if CSafeDumper is not None:
    class Dumper(CSafeDumper):
        """PyYAML's safe dumper with libyaml's emitter (the same text, 4x faster)."""
else:
    Dumper = PythonDumper

# YAML 1.2's floats in exponent form without a point, read as numbers; written, a string of that
# form is quoted, so that it reads back as the string it was
for _cls in {Loader, PythonLoader, Dumper, PythonDumper}:
    _cls.add_implicit_resolver(
        "tag:yaml.org,2002:float", re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
        list("-+0123456789"))


class YamlError(BayesDnlrError, ValueError):
    """A YAML file that cannot be read as written; the message names the file and the line."""


class _Limit(Exception):
    """A document beyond the loader's limits (MAX_DEPTH, MAX_NODES), with where it was found."""

    def __init__(self, what: str, mark: yaml.Mark | None = None) -> None:
        super().__init__(what)
        self.what, self.mark = what, mark

    def where(self) -> str:
        return f"line {self.mark.line + 1}, column {self.mark.column + 1}: " if self.mark else ""


def read_text(path: Path, what: str = "config file") -> str:
    """The UTF-8 text of ``path``; YamlError (one line) when missing, a folder, unreadable or not UTF-8."""
    path = Path(path)
    if path.is_dir():
        raise YamlError(f"{path}: is a directory, not a {what}")
    if not path.exists():
        raise YamlError(f"{path}: {what} not found")
    try:
        if path.stat().st_size > MAX_YAML_BYTES:      # before reading a file that is far too large
            raise YamlError(f"{path}: {path.stat().st_size} bytes, larger than the {MAX_YAML_BYTES} "
                            f"bytes a {what} may have; is it the right file?")
        data = path.read_bytes()
    except OSError as err:
        raise YamlError(f"{path}: cannot read the {what} ({err.strerror or err})") from None
    if len(data) > MAX_YAML_BYTES:
        raise YamlError(f"{path}: {len(data)} bytes, larger than the {MAX_YAML_BYTES} bytes a {what} "
                        "may have; is it the right file?")
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


def _expanded(root: yaml.Node) -> None:
    """Refuse a document whose aliases expand it beyond MAX_NODES values or MAX_DEPTH levels, or
    that refers to itself (``a: &x [*x]``). Each node is measured once (an iterative walk with the
    sizes of shared nodes remembered), so an alias bomb costs what its text costs."""
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    open_: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        children = ([n for pair in node.value for n in pair] if isinstance(node, yaml.MappingNode)
                    else list(node.value) if isinstance(node, yaml.SequenceNode) else [])
        if done:
            open_.discard(key)
            size[key] = 1 + sum(size[id(c)] for c in children)
            depth[key] = 1 + max((depth[id(c)] for c in children), default=0)
            if size[key] > MAX_NODES:
                raise _Limit(f"the aliases expand the document to more than {MAX_NODES} values (aliases "
                             "repeated inside aliased lists); write the values out",
                             node.start_mark)
            if depth[key] > MAX_DEPTH:
                raise _Limit(f"the aliases nest the document deeper than {MAX_DEPTH} levels", node.start_mark)
            continue
        if key in size:
            continue
        if key in open_:
            raise _Limit("an alias refers to the list or mapping that contains it", node.start_mark)
        open_.add(key)
        stack.append((node, True))
        stack.extend((c, False) for c in children if id(c) not in size)


def parse_yaml(text: str, where: str) -> Any:
    """The YAML document in ``text`` (None when empty); YamlError naming ``where`` and the line for
    a syntax error, a duplicated key or a document beyond the limits (see the module doc)."""
    if len(text) > MAX_YAML_BYTES:
        raise YamlError(f"{where}: {len(text)} characters, larger than the {MAX_YAML_BYTES} a YAML "
                        "document may have")
    try:
        loader = Loader(text)               # refuses control characters (a NUL byte) at once
    except yaml.YAMLError as err:
        raise YamlError(f"{where}: {_mark(err)}not valid YAML: {_describe(err)}") from None
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _expanded(node)
        found: list[str] = []
        _duplicates(node, "", found)
        if found:
            raise YamlError(f"{where}: {found[0]}")
        return loader.construct_document(node)
    except yaml.YAMLError as err:   # syntax, or a tag the safe loader does not construct
        if "maximum nesting depth" in str(getattr(err, "problem", "")):
            # libyaml's own limit (1000 levels), met while it reads ahead of the composer
            raise YamlError(f"{where}: {_mark(err)}not read: {TOO_DEEP}") from None
        raise YamlError(f"{where}: {_mark(err)}not valid YAML: {_describe(err)}") from None
    except _Limit as err:
        raise YamlError(f"{where}: {err.where()}not read: {err.what}") from None
    finally:
        loader.dispose()


def dump_yaml(data: Any) -> str:
    """``data`` as block YAML, keys in their own order, that ``parse_yaml`` reads back as ``data``:
    emitted by libyaml where PyYAML has it (the same text as PyYAML's own emitter, 4x faster: 1.3 ms
    for a resolved config), else by PyYAML."""
    return yaml.dump(data, Dumper=Dumper, sort_keys=False)


def load_yaml(path: str | Path, what: str = "config file") -> Any:
    """Read and parse a YAML file the user wrote (see the module doc)."""
    path = Path(path)
    return parse_yaml(read_text(path, what), str(path))
