"""``fit`` as a run: the least-squares result of a config written to ``<run_dir>/fit.json``.

fit.json records the digests of the config sections it depends on and the data file's sha256, so a
later ``fit`` or ``sample`` can tell whether it still belongs to the config and data: a stale
fit.json is never replaced silently (``overwrite`` / ``--force`` does it).
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from bayes_dnlr.config import Config
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.lsq import FitResult, fit_test
from bayes_dnlr.rundir import config_digest, file_sha256, prepare_run_dir, section_digests, write_json

FIT_FILE = "fit.json"
SECTIONS = ("data", "model", "parameters", "noise", "fit")

def _fit_path(run_dir: Path) -> Path:
    return Path(run_dir) / FIT_FILE


def load_fit(run_dir: str | Path) -> dict[str, Any]:
    """The content of ``<run_dir>/fit.json``."""
    path = _fit_path(Path(run_dir))
    if not path.is_file():
        raise RunError(f"{path}: no fit.json in this run directory (run `fit` first)")
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise RunError(f"{path}: not a readable fit.json ({err}); run `fit --force` to redo it") from None


def _stale_reason(saved: Mapping[str, Any], cfg: Config, sha256: str) -> str | None:
    """Why a saved fit.json does not belong to this config and data (None when it does)."""
    reasons = []
    if saved.get("config_digest") != config_digest(cfg, SECTIONS):
        old = saved.get("config_sections") or {}
        diff = [s for s, d in section_digests(cfg, SECTIONS).items() if old.get(s) != d]
        reasons.append(f"a different config (sections {', '.join(diff) or SECTIONS})")
    if saved.get("data_sha256") != sha256:
        reasons.append("a different data file (sha256 differs)")
    return " and ".join(reasons) or None


def fit_is_current(cfg: Config, data_sha256: str | None = None) -> bool:
    """True when ``cfg.run_dir/fit.json`` exists and was made from this config and data file
    (``data_sha256``: the data file's hash when the caller already has it)."""
    path = _fit_path(cfg.run_dir)
    if not path.is_file() or (data_sha256 is None and not cfg.data_path.is_file()):
        return False
    try:
        saved = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError, OSError):
        return False
    return _stale_reason(saved, cfg, data_sha256 or file_sha256(cfg.data_path)) is None


def fit(cfg: Config, *, overwrite: bool = False, write: bool = True, test=None) -> FitResult:
    """Least-squares fit of the configured test; writes ``cfg.run_dir/fit.json`` (unless write=False).

    ``test``: the TestData of ``cfg`` when the caller has already loaded it (else it is loaded).
    An existing fit.json made from another config (sections data, model, parameters, noise, fit) or
    another data file is never replaced silently: RunError unless ``overwrite`` (CLI ``--force``).
    """
    from bayes_dnlr.data import load_test

    t0 = time.perf_counter()
    if test is None:
        test = load_test(cfg)
    path = _fit_path(cfg.run_dir)
    if write and not overwrite and path.exists():
        try:
            saved = json.loads(path.read_text())
            reason = _stale_reason(saved, cfg, test.sha256)
        except (json.JSONDecodeError, UnicodeDecodeError) as err:
            reason = f"an unreadable file ({err})"
        if reason is not None:
            raise RunError(f"{path} exists and was made from {reason}; pass --force "
                           "(overwrite=True) to replace it")
    result = fit_test(cfg, test)
    result.config_digest = config_digest(cfg, SECTIONS)
    result.config_sections = section_digests(cfg, SECTIONS)
    result.data_sha256 = test.sha256
    result.wall_time_s = time.perf_counter() - t0
    if write:
        prepare_run_dir(cfg)
        write_json(path, result.to_dict())
    return result
