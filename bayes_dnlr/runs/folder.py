"""The run directory: where a run's outputs live, and fingerprints that tell a stale result.

Layout (a contract, runs/layout.py and docs/sampling.md): config.yaml, fit.json, chains.h5,
posterior.nc, summary.json, report.html, figures/. When the run directory is the folder of the
user's own config.yaml, that file is left untouched and the resolved config goes to ``config.resolved.yaml``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from bayes_dnlr.config import Config
from bayes_dnlr.config.yamlio import dump_yaml
from bayes_dnlr.digests import digest, jsonable
from bayes_dnlr.diskio import storage_error, sweep_stale_temps, temp_path
from bayes_dnlr.errors import RunError, StorageError
from bayes_dnlr.runs.layout import RESOLVED_CONFIG, RESOLVED_CONFIG_BESIDE_SOURCE


def config_digest(cfg: Config, sections: tuple[str, ...]) -> str:
    """Fingerprint of the config sections a result depends on (e.g. data, model, parameters)."""
    dumped = cfg.model_dump(mode="json")
    return digest({k: dumped.get(k) for k in sections})


def section_digests(cfg: Config, sections: tuple[str, ...]) -> dict[str, str]:
    """One fingerprint per config section, so a stale result can say which section changed."""
    return {s: config_digest(cfg, (s,)) for s in sections}


def resolved_config_path(cfg: Config) -> Path:
    run_dir = cfg.run_dir
    target = run_dir / RESOLVED_CONFIG
    if cfg.source is not None and target.resolve() == Path(cfg.source).resolve():
        return run_dir / RESOLVED_CONFIG_BESIDE_SOURCE
    return target


def resolved_config_text(cfg: Config) -> str:
    """The config as resolved (defaults filled in), with paths that work from the run directory."""
    raw = cfg.as_dict()
    for section, view in zip(raw.get("tests") or [raw], cfg.test_configs(), strict=True):
        section["data"]["file"] = os.path.relpath(view.data_path, cfg.run_dir)
    for entry in raw.get("reference_moduli") or []:          # a DMA sweep's file, likewise
        if entry.get("file"):
            path = Path(entry["file"])
            entry["file"] = os.path.relpath(path if path.is_absolute() else cfg.base_dir / path, cfg.run_dir)
    raw["output"] = {"dir": "."}
    return dump_yaml(raw)


def check_output_dir(run_dir: Path, *, writable: bool) -> None:
    """Refuse, before any work, a run directory that is a file or lies under one, and (``writable``)
    one that cannot be created or written (a read-only folder or file system)."""
    run_dir = Path(run_dir)
    for q in (run_dir, *run_dir.parents):
        if not q.exists():
            continue
        if not q.is_dir():
            what = "is a file" if q == run_dir else f"lies under {q}, which is a file"
            raise RunError(f"{run_dir}: the run directory {what}; set output.dir in the config (or "
                           "rename the run) to write the outputs elsewhere")
        if writable and not os.access(q, os.W_OK | os.X_OK):
            raise StorageError(f"cannot write {run_dir} ({q} is read-only for this user); set "
                               "output.dir in the config to a folder you can write")
        return


def make_dir(run_dir: Path) -> bool:
    """Create the run directory (and its parents); True when this call created it."""
    run_dir = Path(run_dir)
    if run_dir.is_dir():
        return False
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        check_output_dir(run_dir, writable=False)
        raise
    except OSError as err:
        raise (storage_error(err, run_dir) or err) from None
    return True


def discard_if_empty(run_dir: Path) -> None:
    """Remove a run directory a failed command created, when nothing was left in it."""
    try:
        Path(run_dir).rmdir()
    except OSError:
        pass


def prepare_run_dir(cfg: Config) -> Path:
    """Create the run directory and write the config as resolved (defaults filled in)."""
    run_dir = cfg.run_dir
    make_dir(run_dir)
    write_atomic(resolved_config_path(cfg), resolved_config_text(cfg))
    return run_dir


def find_config(run_dir: Path) -> Path:
    """The resolved config of a run directory (for report/compare)."""
    for name in (RESOLVED_CONFIG_BESIDE_SOURCE, RESOLVED_CONFIG):
        p = Path(run_dir) / name
        if p.is_file():
            return p
    raise FileNotFoundError(f"{run_dir}: no config.yaml in this run directory")


def write_atomic(path: Path, content: str | bytes | memoryview) -> None:
    """Replace ``path`` by ``content`` (text is written as UTF-8) in one step: a reader never sees
    half a file, and a failed write (disk full, ...) leaves the old file as it was.

    The bytes go to ``.<name>.<pid>.tmp`` beside ``path``, are fsynced, then renamed onto it (a
    symbolic link at ``path`` is replaced, its target left untouched). On any
    failure the temporary is removed and a write error of the environment becomes a one-line
    StorageError (DiskFullError when the disk is full); temporaries of killed writers of the same
    file are swept first, so retries do not pile them up."""
    path = Path(path)
    data = content.encode("utf-8") if isinstance(content, str) else content
    sweep_stale_temps(path)
    tmp = temp_path(path)
    try:
        tmp.unlink(missing_ok=True)
        with open(tmp, "xb") as f:          # "x": a link planted at the temporary is not followed
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as err:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:         # e.g. a read-only file system: there is no temporary either
            pass
        clean = storage_error(err, path, "the previous version of the file, if any, is unchanged")
        if clean is not None:
            raise clean from None
        raise


def write_json(path: Path, content: Any) -> None:
    """Strict JSON (no NaN), written atomically."""
    write_atomic(path, json.dumps(jsonable(content), indent=2, allow_nan=False) + "\n")
