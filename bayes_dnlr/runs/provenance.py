"""Were a run folder's results made from the current config and data? ``report`` marks a fit.json
or a chain made from another config or data file instead of showing it as current.

The current config is the user's own when it is known: the config file ``report`` was given, or
the user's config.yaml beside config.resolved.yaml in the run folder. Otherwise the folder holds
only the config as it was resolved for the results (its data paths rewritten relative to the
folder, so its digests are not the user's): then only the data files are checked.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from bayes_dnlr.config import Config, load_config
from bayes_dnlr.digests import digest
from bayes_dnlr.errors import DamagedFileError
from bayes_dnlr.runs import identity
from bayes_dnlr.runs.layout import (
    CHAINS_FILE,
    FIT_FILE,
    RESOLVED_CONFIG,
    RESOLVED_CONFIG_BESIDE_SOURCE,
    SUMMARY_FILE,
)
from bayes_dnlr.runs.records import FitRecord


def user_config(run_dir: Path, source: Path | str | None = None) -> Path | None:
    """The user's config of a run folder: ``source`` unless it is the folder's resolved config, else
    the config.yaml beside config.resolved.yaml; None when the folder holds only the resolved one."""
    beside = (run_dir / RESOLVED_CONFIG_BESIDE_SOURCE).is_file()
    resolved = run_dir / (RESOLVED_CONFIG_BESIDE_SOURCE if beside else RESOLVED_CONFIG)
    if source is not None and Path(source).resolve() != resolved.resolve():
        return Path(source)
    return run_dir / RESOLVED_CONFIG if beside else None


def _in(cfg: Config, run_dir: Path) -> Config:
    """``cfg`` with its outputs in ``run_dir`` (no result's digest covers the output section)."""
    if cfg.run_dir.resolve() == run_dir.resolve():
        return cfg
    return cfg.model_copy(update={"output": cfg.output.model_copy(update={"dir": str(run_dir.resolve())})})


def stale_results(run_dir: Path, cfg: Config, fit: Mapping[str, Any] | None,
                  summary: Mapping[str, Any] | None, source: Path | str | None = None,
                  problems: list[str] | None = None) -> list[str]:
    """One sentence per result of the folder made from another config or data than the current
    ones (empty when they match, or when it cannot be told). A chains.h5 that cannot be read is
    told in ``problems`` (when given)."""
    run_dir = Path(run_dir)
    path = user_config(run_dir, source)
    try:
        user = _in(load_config(path), run_dir) if path is not None else None
    except Exception as err:  # noqa: BLE001 - an edited config that no longer loads: say so, go on
        return [f"{path} could not be read ({err}): whether the results below belong to it is not "
                "known."]
    current = user or cfg
    sha = identity.data_sha(current, fit or summary)
    shown = path if path is not None else "<config.yaml>"
    out = []
    if fit is not None:
        record = FitRecord.from_dict(fit, current.test_names)
        if user is not None:
            reason = identity.stale_fit_reason(user, sha or record.data_sha256 or "")
        else:
            reason = (None if sha is None or record.data_sha256 == sha
                      else "a different data file (sha256 differs)")
        if reason:
            out.append(f"{FIT_FILE} was made from {reason}: the least-squares results on this page "
                       f"are not those of the current config and data. Redo them with `python -m "
                       f"bayes_dnlr fit --force {shown}`.")
    if sha is None:
        return out
    chains = run_dir / CHAINS_FILE
    reason, what = None, ""
    if chains.is_file():
        from bayes_dnlr.runs.chains import read_attrs

        try:
            attrs = read_attrs(chains)
        except (OSError, DamagedFileError) as err:
            attrs = None           # the report's results do not come from it: said, not fatal
            if problems is not None:
                problems.append(str(err))
        if attrs is not None and user is not None:
            reason = identity.chain_stale_reason(attrs, user, sha, run_dir)
        elif attrs is not None:
            try:
                stored = json.loads(attrs.get("fingerprint_parts") or "{}")
            except (TypeError, ValueError):
                stored = {}
            old = stored.get(identity.DATA_FILE)
            reason = None if old in (None, sha) else "a different data file (sha256 differs)"
        what = f"{CHAINS_FILE} was sampled from another config or data ({reason})"
    elif summary is not None:
        old = summary.get("fingerprint") if user is not None else summary.get("data_sha256")
        now = digest(identity.chain_parts(user, sha)) if user is not None else sha
        reason = None if old is None or old == now else "its fingerprint differs"
        what = f"{SUMMARY_FILE} was made from another config or data"
    if reason:
        out.append(f"{what}: the posterior on this page is not that of the current config and data. "
                   f"Sample it again with `python -m bayes_dnlr sample --restart {shown}`.")
    return out
