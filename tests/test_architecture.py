"""The import rules of docs/architecture.md, read from the package's own source.

Every module of bayes_dnlr/ is parsed (imports inside functions and under TYPE_CHECKING included)
into a graph of module -> imported module, the way an import resolves: ``from a.b import c`` is an
import of ``a.b.c`` when that is a module, else of ``a.b``. On that graph:

- imports go one way, down the layers (a module may import its own layer and any layer below);
- there is no import cycle between modules (a package's ``__init__`` importing its own
  submodules is not one);
- no private name (``_x``) is imported from another module.

The checks are plain functions of a source folder, so that the last tests can show them failing on
a small package with a wrong-way import, a cycle and a private import.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import pytest

import bayes_dnlr

PACKAGE = Path(bayes_dnlr.__file__).parent

# Lowest first; a module may import from its own rank and below (docs/architecture.md, "Import
# rules"). config and data are one step of the pipeline, but data reads configs and config never
# reads data: two ranks.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("leaves", ("errors", "numbers", "vocabulary", "units", "digests", "diskio", "fileset",
                "interrupt", "standards", "crosscheck", "machine_load", "numba_cache", "readback",
                "csvcells")),
    ("config", ("config",)),
    ("data", ("data",)),
    ("model", ("model",)),
    ("inference", ("inference",)),
    ("runs", ("runs",)),
    ("report", ("report",)),
    ("workflows", ("workflows",)),
    ("cli", ("cli", "arguments", "__main__")),
)


@dataclass(frozen=True)
class Import:
    source: str      # importing module, dotted
    target: str      # imported module, dotted
    name: str        # the name as written after ``import``
    line: int
    of_module: bool = False    # ``from a import b`` where b is a module, not a name inside one


def modules(root: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every .py below ``root`` (a package's __init__ is the package)."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _owner(name: str, mods: dict[str, Path]) -> str | None:
    """The longest prefix of ``name`` that is a module of the package (None for other packages)."""
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def imports(mods: dict[str, Path]) -> list[Import]:
    """Every import between two modules of the package."""
    out = []
    for mod, path in mods.items():
        is_package = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    target = _owner(alias.name, mods)
                    if target and target != mod:
                        out.append(Import(mod, target, alias.name, node.lineno))
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = mod.split(".") if is_package else mod.split(".")[:-1]
                    parts = parts[: len(parts) - (node.level - 1)]
                    base = ".".join(parts + ([node.module] if node.module else []))
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    target = _owner(full if full in mods else base, mods)
                    if target and target != mod:
                        out.append(Import(mod, target, alias.name, node.lineno, full in mods))
    return out


def rank_of(mod: str, layers=LAYERS) -> int | None:
    """The rank of a module's layer from its first name below the package. The package's own
    ``__init__`` ranks with the leaves: it loads the rest lazily, by name, so that importing
    bayes_dnlr costs nothing, and a static import there would be a wrong-way import."""
    parts = mod.split(".")
    if len(parts) == 1:
        return 0
    for rank, (_, members) in enumerate(layers):
        if parts[1] in members:
            return rank
    return None


def wrong_way(found: list[Import], layers=LAYERS) -> list[str]:
    """Imports of a module in a higher layer than the importer's."""
    out = []
    for imp in found:
        src, dst = rank_of(imp.source, layers), rank_of(imp.target, layers)
        if src is not None and dst is not None and dst > src:
            out.append(f"{imp.source} (line {imp.line}) imports {imp.target}: "
                       f"{layers[src][0]} may not import {layers[dst][0]}")
    return sorted(out)


def cycles(found: list[Import]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), leaving out a package that
    imports only its own submodules and they only it."""
    graph: dict[str, set[str]] = defaultdict(set)
    for imp in found:
        graph[imp.source].add(imp.target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    comps: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return [c for c in comps if not all(x.startswith(c[0] + ".") for x in c[1:])]


def private_imports(found: list[Import]) -> list[str]:
    """Private names (``_x``, not dunders and not modules) imported from another module."""
    return sorted(f"{imp.source} (line {imp.line}) imports {imp.target}.{imp.name}"
                  for imp in found
                  if imp.name.startswith("_") and not imp.name.startswith("__") and not imp.of_module)


# ----------------------------------------------------------------------------------- the package

@pytest.fixture(scope="module")
def package() -> tuple[dict[str, Path], list[Import]]:
    mods = modules(PACKAGE)
    return mods, imports(mods)


def test_every_module_is_in_a_layer(package) -> None:
    mods, _ = package
    lost = sorted(m for m in mods if rank_of(m) is None)
    assert not lost, (f"modules in no layer of docs/architecture.md: {lost}; add each to its "
                      f"'Import rules' and to LAYERS here")
    assert len(mods) > 100       # the walk did find the package


def test_imports_go_down_the_layers(package) -> None:
    _, found = package
    assert len(found) > 300      # the walk did find the imports
    bad = wrong_way(found)
    assert not bad, "imports against docs/architecture.md:\n" + "\n".join(bad)


def test_no_import_cycles(package) -> None:
    _, found = package
    comps = cycles(found)
    assert not comps, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in comps)


def test_no_private_name_imported_across_modules(package) -> None:
    mods, found = package
    bad = private_imports(found)
    assert not bad, "private names imported from another module:\n" + "\n".join(bad)


# ---------------------------------------------------------------- the checks fail where they should

def _write(root: Path, files: dict[str, str]) -> dict[str, Path]:
    for rel, text in files.items():
        path = root / "pkg" / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return modules(root / "pkg")


SMALL_LAYERS = (("leaves", ("errors",)), ("config", ("config",)), ("data", ("data",)))


def test_a_wrong_way_import_inside_a_function_is_found(tmp_path) -> None:
    mods = _write(tmp_path, {
        "__init__.py": "",
        "errors.py": "",
        "config/__init__.py": "from pkg.config.loader import load\n",
        "config/loader.py": "from pkg import errors\n\ndef load():\n    from pkg.data.reading import read\n",
        "config/schema.py": "",
        "data/__init__.py": "",
        "data/reading.py": "from ..config import schema\n\ndef read():\n    pass\n",
    })
    found = imports(mods)
    assert wrong_way(found, SMALL_LAYERS) == [
        "pkg.config.loader (line 4) imports pkg.data.reading: config may not import data"]
    # data -> config (a relative import, resolved to the module) and config -> errors are allowed
    assert Import("pkg.data.reading", "pkg.config.schema", "schema", 1, of_module=True) in found
    assert cycles(found) == []


def test_a_cycle_and_a_private_import_are_found(tmp_path) -> None:
    mods = _write(tmp_path, {
        "__init__.py": "",
        "data/__init__.py": "",
        "data/testdata.py": "from pkg.data.windows import _cut\n",
        "data/windows.py": "def _cut():\n    from pkg.data import testdata\n",
        "data/_private_module.py": "",
        "data/user.py": "from pkg.data import _private_module\nfrom pkg.data.windows import __doc__\n",
    })
    found = imports(mods)
    assert cycles(found) == [["pkg.data.testdata", "pkg.data.windows"]]
    assert private_imports(found) == ["pkg.data.testdata (line 1) imports pkg.data.windows._cut"]
