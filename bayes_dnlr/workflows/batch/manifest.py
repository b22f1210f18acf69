"""The tests of a batch: a list (or glob) of configs, or one template config plus a manifest.

Manifest (CSV, one row per test): a header row of **dotted config keys** whose cells override the
template for that row, e.g.

    name,data.file,data.area0,data.window.strain_max,sampler.seed
    spec-01,data/spec-01.csv,24.1,1.9,1
    spec-02,data/spec-02.csv,23.8,,2

- A key is the path of a config key with dots (``parameters.E.low``, ``noise.sigma0``); a cell is
  read as a number when it is one, else as YAML (``null``, ``true``, ``{prior: half-normal, scale: 5}``),
  else as text. An **empty cell keeps the template's value**; write ``null`` to clear a key.
- ``name`` names the run (its folder); without a ``name`` column (or with an empty cell) the run is
  named after the stem of its data file. Names must be unique.
- ``data.file`` (and ``output.dir``) in the manifest are relative to the manifest's folder.
- Each row runs in ``<out>/runs/<name>/`` unless the row sets ``output.dir``.
- A ``config`` column names each row's own config (relative to the manifest's folder) in place of
  the template (``init FILE --all`` writes one per specimen): the row runs where that config runs
  alone, as a list of configs would, and its other cells override that config's keys.
- A line whose first cell starts with ``#`` is a comment.

A config that does not validate becomes a failed test with its error (the batch goes on); a
manifest that cannot be read, has no rows or repeats a name stops the batch before anything runs.
"""

from __future__ import annotations

import copy
import csv
import glob
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bayes_dnlr.config import Config, ConfigError, load_config, parse_config
from bayes_dnlr.config.yamlio import YamlError, load_yaml, parse_yaml
from bayes_dnlr.errors import BayesDnlrError

RUNS_FOLDER = "runs"
CONFIG_COLUMN = "config"          # a row's own config, in place of the template
NAME_OK = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
PATH_KEYS = ("data.file", "output.dir")


class BatchError(BayesDnlrError):
    """The batch as a whole cannot run (unreadable manifest, duplicate names, no inputs)."""


@dataclass(frozen=True)
class Job:
    """One test of a batch: everything a worker needs, as plain data (picklable, no arrays)."""

    name: str
    origin: str                      # "path/config.yaml" or "manifest.csv row 3"
    source: str                      # the config (or template) file: anchors relative paths
    raw: dict[str, Any] | None       # the config mapping with the row's overrides
    run_dir: str | None
    inputs: dict[str, str] = field(default_factory=dict)   # the manifest cells of this row
    error: str | None = None         # the config did not validate: the job is recorded, not run
    restart: bool = False            # batch --restart: a stale fit or chain is discarded, not an error

    def config(self) -> Config:
        """The validated config (raises ConfigError)."""
        if self.raw is None:
            raise ConfigError(self.error or f"{self.origin}: no config")
        return parse_config(copy.deepcopy(self.raw), source=Path(self.source))


def _sanitize(text: str) -> str:
    name = re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-._")
    return name or "test"


def expand_inputs(patterns: list[str]) -> list[Path]:
    """Config paths from paths and glob patterns (``runs/*/config.yaml``), in the given order. A
    config named twice (two spellings, or a file a pattern matches again) is an error: it would run
    once, and the batch would not say which of the two was meant."""
    paths: list[tuple[Path, str]] = []
    for pat in patterns:
        p = Path(pat)
        if p.is_file():
            paths.append((p, pat))
            continue
        if p.is_dir():
            raise BatchError(f"{pat}: a folder; give config files (e.g. {pat}/*/config.yaml)")
        found = sorted(glob.glob(pat, recursive=True))
        if not found:
            raise BatchError(f"{pat}: no such config file (and no file matches it as a pattern)")
        paths += [(Path(f), pat) for f in found if Path(f).is_file()]
    seen: dict[Path, str] = {}
    unique = []
    for p, given in paths:
        r = p.resolve()
        if r in seen:
            first = seen[r]
            also = f"'{first}' and '{given}'" if first != given else f"'{given}' (twice)"
            raise BatchError(f"{p}: listed twice, as {also}; give each config once (the batch runs "
                             "each test once)")
        seen[r] = given
        unique.append(p)
    return unique


def default_out(configs: list[Path], manifest: Path | None) -> Path:
    """Where batch outputs go when --out is not given: ``<manifest folder>/batch-<manifest stem>``,
    or ``<the configs' common folder>/batch`` (``runs/*/config.yaml`` -> ``runs/batch``)."""
    if manifest is not None:
        return manifest.resolve().parent / f"batch-{manifest.stem}"
    return Path(os.path.commonpath([str(p.resolve().parent) for p in configs])) / "batch"


def jobs_from_configs(paths: list[Path]) -> list[Job]:
    """One job per config file; a config that does not validate is a job with its error."""
    jobs = []
    for p in paths:
        origin = str(p)
        try:
            cfg = load_config(p)
            raw = load_yaml(p)          # as load_config read it (YAML 1.2 floats)
            jobs.append(Job(cfg.name, origin, str(p.resolve()), raw, str(cfg.run_dir)))
        except ConfigError as err:
            name = _name_of_broken(p)
            jobs.append(Job(name, origin, str(p.resolve()), None, None, error=str(err)))
    _check_unique(jobs, "config")
    return jobs


def _name_of_broken(p: Path) -> str:
    try:
        raw = load_yaml(p)
        name = raw.get("name") if isinstance(raw, dict) else None
    except YamlError:
        name = None
    if isinstance(name, str) and NAME_OK.match(name):
        return name
    return _sanitize(p.parent.name if p.stem == "config" else p.stem)


def _check_unique(jobs: list[Job], what: str) -> None:
    by_name: dict[str, list[str]] = {}
    for j in jobs:
        by_name.setdefault(j.name, []).append(j.origin)
    dup = {k: v for k, v in by_name.items() if len(v) > 1}
    if dup:
        lines = "; ".join(f"{k!r} from {', '.join(v)}" for k, v in dup.items())
        raise BatchError(f"two tests of the batch have the same name ({lines}); each {what} needs "
                         "its own name (the run folder and the row of the results table)")


def parse_cell(text: str) -> Any:
    """A manifest cell: int, float, else YAML (null, true, a flow mapping), else the text."""
    s = text.strip()
    for conv in (int, float):
        try:
            return conv(s)
        except ValueError:
            pass
    try:
        value = parse_yaml(s, "manifest cell")     # the config's loader: bounded depth and aliases
    except YamlError:
        return s
    return value if isinstance(value, dict | list | bool) or value is None else s


def set_dotted(raw: dict[str, Any], key: str, value: Any) -> None:
    """raw[a][b][c] = value for key 'a.b.c', creating mappings on the way."""
    parts = key.split(".")
    node = raw
    for i, part in enumerate(parts[:-1]):
        child = node.get(part)
        if child is None:
            child = node[part] = {}
        if not isinstance(child, dict):
            where = ".".join(parts[: i + 1])
            raise ConfigError(f"column {key}: {where} is {child!r} in the template, not a mapping; "
                              f"set the whole value in a column {where} (e.g. a YAML mapping "
                              "{prior: half-normal, scale: 5})")
        node = child
    node[parts[-1]] = value


def read_manifest(path: Path) -> tuple[list[str], list[tuple[int, dict[str, str]]]]:
    """(header, [(line number, {column: cell})]) of a manifest CSV."""
    if not path.is_file():
        raise BatchError(f"{path}: manifest not found")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as err:
        raise BatchError(f"{path}: cannot read the manifest ({err})") from None
    sample = text[:4096]
    try:
        dialect = csv.Sniffer().sniff(sample, delimiters=",;\t")
    except csv.Error:
        dialect = csv.excel
    reader = csv.reader(text.splitlines(), dialect)
    try:
        rows = [(i + 1, r) for i, r in enumerate(reader)
                if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    except csv.Error as err:      # e.g. a cell past the csv module's limit (131 072 characters)
        raise BatchError(f"{path}: line {reader.line_num}: not a manifest row ({err})") from None
    if not rows:
        raise BatchError(f"{path}: the manifest is empty (expected a header row of config keys, "
                         "e.g. name,data.file,data.area0, and one row per test)")
    header = [h.strip() for h in rows[0][1]]
    bad = [h for h in header if not h or not re.match(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z0-9_]+)*$", h)]
    if bad:
        raise BatchError(f"{path}: line {rows[0][0]}: header {bad} is not a dotted config key "
                         "(e.g. data.file, data.window.strain_max)")
    dups = sorted({h for h in header if header.count(h) > 1})
    if dups:
        raise BatchError(f"{path}: line {rows[0][0]}: column(s) {dups} appear twice")
    out = []
    for line, r in rows[1:]:
        if len(r) > len(header):
            raise BatchError(f"{path}: line {line}: {len(r)} cells for {len(header)} columns")
        out.append((line, {h: (r[i] if i < len(r) else "") for i, h in enumerate(header)}))
    if not out:
        raise BatchError(f"{path}: the manifest has a header but no test rows")
    return header, out


def _base(path: Path, what: str) -> dict[str, Any]:
    try:
        base = load_yaml(path, what)
    except YamlError as err:
        raise BatchError(str(err)) from None
    if not isinstance(base, dict):
        raise BatchError(f"{path}: expected a mapping of config keys")
    return base


def jobs_from_manifest(template: Path | None, manifest: Path, out: Path) -> list[Job]:
    """One job per manifest row: the template (or the row's own config, a ``config`` column) with
    the row's overrides, in ``<out>/runs/<name>/`` (a row's own config: where it runs alone)."""
    header, rows = read_manifest(manifest)
    own = CONFIG_COLUMN in header
    if own == (template is not None):
        raise BatchError(f"{manifest}: give a template config or a manifest with a '{CONFIG_COLUMN}' "
                         "column (each row's own config), not " + ("both" if own else "neither"))
    base = _base(template, "template config") if template is not None else None
    mdir = manifest.resolve().parent
    jobs = []
    for line, cells in rows:
        origin = f"{manifest} line {line}"
        inputs = {k: v for k, v in cells.items() if v.strip() != "" and k != CONFIG_COLUMN}
        source = template
        if own:
            source = mdir / cells[CONFIG_COLUMN].strip()
            if source == mdir or not source.is_file():
                jobs.append(Job(_sanitize(inputs.get("name") or f"row{line}"), origin, str(source), None,
                                None, inputs, f"{origin}: config {cells[CONFIG_COLUMN]!r}: no such file "
                                "(the config column is relative to the manifest's folder)"))
                continue
            try:
                base = _base(source, "config")
            except BatchError as err:
                jobs.append(Job(_sanitize(inputs.get("name") or source.parent.name), origin, str(source),
                                None, None, inputs, f"{origin}: {err}"))
                continue
        raw = copy.deepcopy(base)
        error = None
        try:
            for key, text in inputs.items():
                value = parse_cell(text)
                if key in PATH_KEYS and isinstance(value, str) and not Path(value).is_absolute():
                    value = str(mdir / value)
                set_dotted(raw, key, value)
        except ConfigError as err:
            error = f"{origin}: {err}"
        name = inputs.get("name", "").strip()
        if not name and own and isinstance(raw.get("name"), str):
            name = raw["name"]
        elif not name:
            data_file = (raw.get("data") or {}).get("file") if isinstance(raw.get("data"), dict) else None
            name = _sanitize(Path(str(data_file)).stem) if data_file else f"row{line}"
            raw["name"] = name
        elif not NAME_OK.match(name):
            error = error or (f"{origin}: name {name!r}: a run name is letters, digits, '.', '_', '-' "
                              "and starts with a letter or digit")
            name = _sanitize(name)
        if "output.dir" not in inputs and not own:
            raw["output"] = {**(raw.get("output") or {}), "dir": str(out.resolve() / RUNS_FOLDER / name)}
        run_dir = None
        if error is None:
            try:
                cfg = parse_config(copy.deepcopy(raw), source=source.resolve())
                run_dir = str(cfg.run_dir)
            except ConfigError as err:
                error = f"{origin}: {err}"
        given = {**inputs, CONFIG_COLUMN: cells[CONFIG_COLUMN]} if own else inputs
        jobs.append(Job(name, origin, str(source.resolve()), None if error else raw, run_dir,
                        given, error))
    _check_unique(jobs, "manifest row")
    return jobs
