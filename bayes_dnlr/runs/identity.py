"""A run's identity: what its fit, chain and summary (runs/layout.py) were computed from, and why a stored
result no longer belongs to a config (worded for the command line: ``--force``, ``--restart``,
``output.dir``).

- **The config by its values after resolution**: the sections a result depends on as pydantic
  dumps them (defaults filled in, ``3e-1`` and ``0.3`` alike), with the data file's path taken
  out (``data.file``, ``tests[i].data.file``): ``small.csv``, ``./small.csv`` and the absolute path
  of the same file are one run, and so is a project moved with its data.
- **The data file by its content**: its sha256. Beside it the resolved path, size and mtime are
  recorded; a later check that finds the same path, size and mtime takes the recorded digest
  without reading the file (a 200 MB file costs 0.5 s to hash), any difference and it is hashed.
- **Results of the previous form** (fit.json and chains.h5 without an ``identity`` record, made
  before this module) digested the sections with ``data.file`` as spelt. They stay current when
  their digests match the config under the spelling they were made with: the current one or one of
  the others of the same file (absolute, resolved, relative to the config's folder or to the run
  folder, with or without ``./``), so no valid chain is discarded by an upgrade.

A stale result is never replaced by a suggestion: the reason names the keys that changed (their old
and new values when the stored record has them) or the data file, and the ways on.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from bayes_dnlr.config import Config
from bayes_dnlr.digests import digest, file_sha256
from bayes_dnlr.errors import DamagedFileError
from bayes_dnlr.readback import read_json
from bayes_dnlr.runs.layout import CHAINS_FILE, FIT_FILE
from bayes_dnlr.runs.testset import REFERENCES, plain_names, sections

FORM = 2                                           # the identity form this version writes
CHAIN_SECTIONS = ("data", "model", "parameters", "noise")   # what the posterior depends on
SAMPLER_KEYS = ("walkers", "seed", "moves")        # what else the chain's values depend on
DATA_FILE = "data file"                            # the data's part of a chain's fingerprint
_PATH_SECTIONS = ("data", "tests")
_SHOWN_CHANGES = 3


# ---------------------------------------------------------------- the config

def _without_path(section: str, value: Any) -> Any:
    if section == "data" and isinstance(value, dict):
        return {k: v for k, v in value.items() if k != "file"}
    if section == "tests" and isinstance(value, list):
        return [{**t, "data": _without_path("data", t.get("data"))} if isinstance(t, dict) else t
                for t in value]
    return value


def section_values(cfg: Config, secs: tuple[str, ...]) -> dict[str, Any]:
    """The values of the sections ``secs`` after resolution, without the data file's path; of
    ``reference_moduli`` the entries in the data (``use: data``), a sweep's file by its content."""
    dumped = cfg.model_dump(mode="json")
    out = {s: _without_path(s, dumped.get(s)) for s in secs}
    if REFERENCES in out:
        out[REFERENCES] = _data_references(cfg, dumped.get(REFERENCES) or [])
    return out


def _data_references(cfg: Config, entries: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The ``use: data`` entries as a result depends on them: without their words (``note``) and a
    sweep's path, with the sha256 of the sweep's file (a missing file: None)."""
    out = []
    for e in entries:
        if e.get("use") != "data":
            continue
        e = {k: v for k, v in e.items() if k not in ("note", "truth")}
        if e.get("file"):
            path = Path(e.pop("file"))
            path = path if path.is_absolute() else cfg.base_dir / path
            e["sha256"] = file_sha256(path) if path.is_file() else None
        out.append(e)
    return out


def config_digest(cfg: Config, secs: tuple[str, ...]) -> str:
    return digest(section_values(cfg, secs))


def section_digests(cfg: Config, secs: tuple[str, ...]) -> dict[str, str]:
    """One digest per section, so a stale result can say which section changed."""
    return {s: digest({s: v}) for s, v in section_values(cfg, secs).items()}


def _sampler_values(cfg: Config) -> dict[str, Any]:
    sampler = cfg.sampler.model_dump(mode="json")
    return {k: sampler[k] for k in SAMPLER_KEYS}


def chain_parts(cfg: Config, data_sha256: str) -> dict[str, str]:
    """The digests a chain's fingerprint is made of: its config sections, the sampler's walkers,
    seed and moves, and the data file's content."""
    parts = section_digests(cfg, sections(cfg, CHAIN_SECTIONS))
    parts["sampler"] = digest(_sampler_values(cfg))
    parts[DATA_FILE] = data_sha256
    return parts


# ---------------------------------------------------------------- the data files

def _data_paths(cfg: Config) -> dict[str, Path]:
    return {name: c.data_path for name, c in zip(cfg.test_names, cfg.test_configs(), strict=True)}


def stat_data(cfg: Config) -> dict[str, tuple[str, int, int]] | None:
    """(resolved path, size, mtime_ns) of each test's data file; None when one is missing. Taken
    before a file is read, it tells whether the file changed while it was being hashed."""
    out = {}
    for name, path in _data_paths(cfg).items():
        try:
            st = path.stat()
        except OSError:
            return None
        out[name] = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    return out


def combined_sha(cfg: Config, shas: Mapping[str, str]) -> str:
    """The data digest of a run: the file's sha256, or a digest of the tests' (as TestSet.sha256)."""
    return shas[cfg.test_names[0]] if plain_names(cfg) else digest(dict(shas))


def data_record(cfg: Config, test, before: Mapping[str, tuple[str, int, int]] | None) -> dict[str, Any]:
    """The identity record of the loaded ``test`` (its TestSet):
    per test the resolved path, size, mtime and sha256. ``before``: ``stat_data`` taken before
    loading; a file whose stat changed meanwhile is recorded without its mtime (no shortcut)."""
    loaded = test.tests
    now = stat_data(cfg) or {}
    files = {}
    for name, t in loaded.items():
        path, size, mtime = now.get(name, (str(Path(t.path).resolve()), None, None))
        same = before is not None and before.get(name) == (path, size, mtime)
        files[name] = {"path": path, "size": size, "mtime_ns": mtime if same else None,
                      "sha256": t.sha256}
    return {"form": FORM, "data_files": files}


def _known_files(stored: Mapping[str, Any] | None) -> dict[str, Any]:
    record = (stored or {}).get("identity")
    if isinstance(record, str):
        try:
            record = json.loads(record)
        except ValueError:
            record = None
    files = record.get("data_files") if isinstance(record, dict) else None
    return files if isinstance(files, dict) else {}


def data_sha(cfg: Config, stored: Mapping[str, Any] | None = None) -> str | None:
    """The run's data digest without loading the data; the digests of ``stored`` (a summary,
    fit.json or chain's identity record) are taken for files with the recorded path, size and
    mtime. None when a data file is missing."""
    known = _known_files(stored)
    now = stat_data(cfg)
    if now is None:
        return None
    shas = {}
    for name, path in _data_paths(cfg).items():
        rec = known.get(name)
        if (isinstance(rec, dict) and rec.get("mtime_ns") is not None
                and (rec.get("path"), rec.get("size"), rec.get("mtime_ns")) == now[name]):
            shas[name] = str(rec.get("sha256"))
        else:
            shas[name] = file_sha256(path)
    return combined_sha(cfg, shas)


# ---------------------------------------------------------------- records

def fit_record(cfg: Config, secs: tuple[str, ...], test, before=None) -> dict[str, Any]:
    """The identity record of fit.json: the form, the section values (to name the keys that change)
    and the data files."""
    return {**data_record(cfg, test, before), "values": section_values(cfg, secs)}


def chain_record(cfg: Config, test, before=None) -> str:
    """The identity attribute of chains.h5 (JSON)."""
    values = section_values(cfg, sections(cfg, CHAIN_SECTIONS))
    values["sampler"] = _sampler_values(cfg)
    return json.dumps({**data_record(cfg, test, before), "values": values})


def _form(record: Any) -> int:
    if isinstance(record, str):
        try:
            record = json.loads(record)
        except ValueError:
            return 1
    return int(record.get("form", 1)) if isinstance(record, dict) else 1


# ---------------------------------------------------------------- the previous form

def _spellings(cfg: Config, run_dir: Path) -> list[dict[str, str] | None]:
    """The spellings a data file may have had in the config a result of the previous form was made
    from (per test): None first (as spelt now)."""
    paths = _data_paths(cfg)
    per_test = {}
    for name, path in paths.items():
        rel_base = os.path.relpath(path, cfg.base_dir)
        rel_run = os.path.relpath(path, run_dir)
        per_test[name] = list(dict.fromkeys([str(path), str(path.resolve()), str(path.absolute()), rel_base,
                                             f"./{rel_base}", rel_run, f"./{rel_run}"]))
    width = max(len(v) for v in per_test.values())
    # the same kind of spelling for every test of a run with tests: (a product would explode)
    return [None] + [{n: v[min(i, len(v) - 1)] for n, v in per_test.items()} for i in range(width)]


def _legacy_digests(cfg: Config, secs: tuple[str, ...], spelling: dict[str, str] | None) -> dict[str, str]:
    dumped = cfg.model_dump(mode="json")
    if spelling is not None:
        for section, name in zip(dumped.get("tests") or [dumped], cfg.test_names, strict=True):
            section["data"]["file"] = spelling[name]
    return {s: digest({s: dumped.get(s)}) for s in secs}


def _legacy_changed(stored: Mapping[str, Any], cfg: Config, secs: tuple[str, ...],
                    run_dir: Path) -> list[str]:
    """The sections of ``secs`` whose previous-form digests in ``stored`` differ from ``cfg``'s
    under every spelling the data file may have had."""
    now = _legacy_digests(cfg, secs, None)
    changed = [s for s in secs if stored.get(s) != now[s]]
    if not any(s in _PATH_SECTIONS for s in changed):
        return changed
    for spelling in _spellings(cfg, run_dir)[1:]:
        respelt = _legacy_digests(cfg, secs, spelling)
        if all(stored.get(s) == respelt[s] for s in _PATH_SECTIONS if s in secs):
            return [s for s in changed if s not in _PATH_SECTIONS]
    return changed


# ---------------------------------------------------------------- why a result is stale

def _flat(value: Any, prefix: str) -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for k, v in value.items():
            out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        out = {}
        for i, v in enumerate(value):
            out.update(_flat(v, f"{prefix}[{i}]"))
        return out
    return {prefix: value}


def _key_changes(old: Mapping[str, Any] | None, new: Mapping[str, Any], secs: list[str]) -> str:
    """``key: old -> new`` for the first changed keys of ``secs`` (empty when ``old`` is unknown)."""
    if not isinstance(old, Mapping):
        return ""
    a, b = _flat({s: old.get(s) for s in secs}, ""), _flat({s: new.get(s) for s in secs}, "")
    keys = [k for k in dict.fromkeys([*a, *b]) if a.get(k) != b.get(k)]
    if not keys:
        return ""
    shown = [f"{k}: {_text(a.get(k))} -> {_text(b.get(k))}" for k in keys[:_SHOWN_CHANGES]]
    more = f", and {len(keys) - _SHOWN_CHANGES} more" if len(keys) > _SHOWN_CHANGES else ""
    return f" ({'; '.join(shown)}{more})"


def _text(v: Any) -> str:
    return "(not set)" if v is None else json.dumps(v) if isinstance(v, dict | list) else str(v)


def _section_words(changed: list[str]) -> str:
    return ", ".join("sampler." + "/".join(SAMPLER_KEYS) if s == "sampler" else s for s in changed)


def _data_words(cfg: Config, old_files: Mapping[str, Any]) -> str:
    names = ", ".join(str(p) for p in _data_paths(cfg).values())
    before = [str(f.get("path")) for f in old_files.values() if isinstance(f, dict) and f.get("path")]
    was = f"; it was made from {', '.join(before)}" if before and before != [names] else ""
    return f"the data file changed ({names}: sha256 differs{was})"


def _stored_values(record: Any, config_text: Any = None) -> dict[str, Any] | None:
    """The section values a stored result records (its identity record, or the resolved config a
    chain of the previous form keeps), to name the keys that changed."""
    if isinstance(record, str):
        try:
            record = json.loads(record)
        except ValueError:
            record = None
    if isinstance(record, dict) and isinstance(record.get("values"), dict):
        return record["values"]
    if isinstance(config_text, str):
        try:
            raw = yaml.safe_load(config_text)
        except yaml.YAMLError:
            return None
        if isinstance(raw, dict):
            values = {k: _without_path(k, v) for k, v in raw.items()}
            if isinstance(values.get("sampler"), dict):
                values["sampler"] = {k: values["sampler"].get(k) for k in SAMPLER_KEYS}
            return values
    return None


def _current_values(cfg: Config, secs: tuple[str, ...], exclude_none: bool) -> dict[str, Any]:
    dumped = cfg.model_dump(mode="json", exclude_none=exclude_none)
    out = {s: _without_path(s, dumped.get(s)) for s in secs}
    out["sampler"] = _sampler_values(cfg)
    return out


def _default_of(cfg: Config, key: str) -> tuple[bool, Any]:
    """(True, the schema's default) of a config key such as ``data.reduce`` or
    ``tests[0].data.reduce`` (an item of a list of sections), or (False, None) for a key without one
    (a mapping of the user's, or required)."""
    *parents, leaf = key.split(".")
    if "[" in leaf:
        return False, None
    obj: Any = cfg
    for part in parents:
        name, _, index = part.partition("[")
        obj = getattr(obj, name, None)
        if index:
            try:
                obj = obj[int(index.rstrip("]"))]
            except (TypeError, ValueError, IndexError):
                return False, None
        if obj is None:
            return False, None
    field = getattr(type(obj), "model_fields", {}).get(leaf)
    if field is None or field.is_required():
        return False, None
    default = field.get_default(call_default_factory=True)
    return True, default.model_dump(mode="json") if hasattr(default, "model_dump") else default


def _only_new_defaults(old: Mapping[str, Any] | None, new: Mapping[str, Any], cfg: Config,
                       section: str) -> bool:
    """Whether ``section`` differs from the stored values only by keys the stored result does not
    know (a newer version's) that hold their default: such a result is still the config's."""
    if not isinstance(old, Mapping) or section not in old:
        return False
    a, b = _flat({section: old.get(section)}, ""), _flat({section: new.get(section)}, "")
    diff = [k for k in dict.fromkeys([*a, *b]) if a.get(k) != b.get(k)]
    if not diff:
        return False
    for k in diff:
        if k in a:
            return False
        known, default = _default_of(cfg, k)
        if not known or json.dumps(default, sort_keys=True) != json.dumps(b.get(k), sort_keys=True):
            return False
    return True


def chain_stale_reason(attrs: Mapping[str, Any], cfg: Config, data_sha256: str, run_dir: Path) -> str | None:
    """Why the chain whose attributes are ``attrs`` does not belong to ``cfg`` and its data (None
    when it does): the changed sections with their keys, and the data file."""
    try:
        stored = json.loads(attrs.get("fingerprint_parts") or "{}")
    except (TypeError, ValueError):
        stored = {}
    secs = sections(cfg, CHAIN_SECTIONS)
    record = attrs.get("identity")
    if _form(record) >= FORM:
        now = chain_parts(cfg, data_sha256)
        changed = [k for k in now if stored.get(k) != now[k]]
        changed += [REFERENCES] if REFERENCES in stored and REFERENCES not in now else []
        old = _stored_values(record)
        current = _current_values(cfg, secs, exclude_none=False)
        changed = [k for k in changed if k == DATA_FILE or not _only_new_defaults(old, current, cfg, k)]
    else:
        changed = _legacy_changed(stored, cfg, secs, run_dir)
        sampler = digest(_sampler_values(cfg))
        changed += ["sampler"] if stored.get("sampler") != sampler else []
        changed += [DATA_FILE] if stored.get(DATA_FILE) != data_sha256 else []
    if not changed:
        return None
    words = []
    config = [k for k in changed if k != DATA_FILE]
    if config:
        old = _stored_values(record, attrs.get("config"))
        keys = _key_changes(old, _current_values(cfg, secs, exclude_none=_form(record) < FORM), config)
        words.append(f"config section(s) {_section_words(config)} changed{keys}")
    if DATA_FILE in changed:
        words.append(_data_words(cfg, _known_files({"identity": record})))
    return " and ".join(words)


def fit_stale_reason(saved: Mapping[str, Any], cfg: Config, secs: tuple[str, ...], data_sha256: str,
                     run_dir: Path) -> str | None:
    """Why a saved fit.json does not belong to ``cfg`` and its data (None when it does)."""
    record = saved.get("identity")
    old = saved.get("config_sections") or {}
    if _form(record) >= FORM:
        changed = ([] if saved.get("config_digest") == config_digest(cfg, secs)
                   else [s for s, d in section_digests(cfg, secs).items() if old.get(s) != d] or list(secs))
        values = section_values(cfg, secs)
        changed = [s for s in changed if not _only_new_defaults(_stored_values(record), values, cfg, s)]
    else:
        changed = _legacy_changed(old, cfg, secs, run_dir) if old else list(secs)
    reasons = []
    if changed:
        keys = _key_changes(_stored_values(record), section_values(cfg, secs), changed)
        reasons.append(f"a different config (sections {', '.join(changed)}{keys})")
    if saved.get("data_sha256") != data_sha256:
        reasons.append(_data_words(cfg, _known_files(saved)).replace("the data file changed",
                                                                      "a different data file"))
    return " and ".join(reasons) or None


def fit_is_current(cfg: Config, data_sha256: str | None = None) -> bool:
    """True when ``cfg.run_dir/fit.json`` exists and was made from this config and data file
    (``data_sha256``: the data file's hash when the caller already has it)."""
    path = Path(cfg.run_dir) / FIT_FILE
    sha = data_sha256 or data_sha(cfg)
    if not path.is_file() or sha is None:
        return False
    try:
        saved = read_json(path, FIT_FILE)
    except (DamagedFileError, OSError):
        return False
    return fit_stale_reason(saved, cfg, sections(cfg), sha, cfg.run_dir) is None


def stale_fit_reason(cfg: Config, data_sha256: str) -> str | None:
    """Why an existing ``cfg.run_dir/fit.json`` does not belong to this config and data (None when
    there is none or it does). Here, not in runs/fit.py, so that a report checks a fit.json without
    importing the fitting code."""
    path = Path(cfg.run_dir) / FIT_FILE
    if not path.exists():
        return None
    try:
        return fit_stale_reason(read_json(path, FIT_FILE), cfg, sections(cfg), data_sha256,
                                cfg.run_dir)
    except DamagedFileError as err:
        return f"an unreadable file ({str(err).removeprefix(f'{path}: ')})"


def chain_fingerprint(cfg: Config, run_dir: Path, data_sha256: str,
                      summary: Mapping[str, Any] | None = None) -> str:
    """The fingerprint a current run's outputs carry: its chain's (which for a chain of the previous
    form is the previous form's digest), else the one a new chain would get."""
    new = digest(chain_parts(cfg, data_sha256))
    if summary is not None and summary.get("fingerprint") == new:
        return new
    from bayes_dnlr.runs.chains import read_attrs

    try:
        attrs = read_attrs(Path(run_dir) / CHAINS_FILE)
    except (OSError, KeyError, ValueError, DamagedFileError):
        return new
    if chain_stale_reason(attrs, cfg, data_sha256, run_dir) is None and attrs.get("fingerprint"):
        return str(attrs["fingerprint"])
    return new
