"""``fit`` as a run: the least-squares result of a config written to ``<run_dir>/fit.json``.

fit.json records the digests of the config sections it depends on and the data file's sha256, so a
later ``fit`` or ``sample`` can tell whether it still belongs to the config and data: a stale
fit.json is never replaced silently (``overwrite`` / ``--force`` does it).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from bayes_dnlr.config import Config
from bayes_dnlr.errors import DamagedFileError, RunError
from bayes_dnlr.inference.lsq.run_fit import RunFit, fit_run
from bayes_dnlr.readback import read_json
from bayes_dnlr.runs import identity
from bayes_dnlr.runs.folder import (
    check_output_dir,
    discard_if_empty,
    prepare_run_dir,
    resolved_config_path,
    write_json,
)
from bayes_dnlr.runs.identity import fit_is_current
from bayes_dnlr.runs.layout import FIT_FILE
from bayes_dnlr.runs.master_curve import fit_master_curve
from bayes_dnlr.runs.modulus_block import fit_rows, stress_refit
from bayes_dnlr.runs.modulus_view import console_lines
from bayes_dnlr.runs.reference_fit import fit_references
from bayes_dnlr.runs.shift_law import leave_one_temperature_out
from bayes_dnlr.runs.testset import load_tests, sections

# fit_is_current lives with the other staleness checks (runs/identity.py), where the report reads it
# without importing the fitting code; it stays part of this module's API (docs/fit.md)
__all__ = ["RunFit", "fit", "fit_is_current", "fit_table", "load_fit"]


def _fit_path(run_dir: Path) -> Path:
    return Path(run_dir) / FIT_FILE


def load_fit(run_dir: str | Path) -> dict[str, Any]:
    """The content of ``<run_dir>/fit.json``."""
    path = _fit_path(Path(run_dir))
    if not path.is_file():
        raise RunError(f"{path}: no fit.json in this run directory (run `fit` first)")
    try:
        return read_json(path, FIT_FILE)
    except DamagedFileError as err:
        raise DamagedFileError(f"{err}; run `fit --force` to redo it") from None


def fit(cfg: Config, *, overwrite: bool = False, write: bool = True, test=None) -> RunFit:
    """Least-squares fit of the configured test(s); writes ``cfg.run_dir/fit.json`` (unless
    write=False). ``RunFit.only`` is the test's fit of a run with one test.

    ``test``: the TestSet of ``cfg`` when the caller has already loaded it.
    An existing fit.json made from another config (sections data, model, parameters, noise, fit,
    tests) or other data is never replaced silently: RunError unless ``overwrite`` (CLI ``--force``).
    """
    t0 = time.perf_counter()
    if write:
        check_output_dir(cfg.run_dir, writable=True)
    before = identity.stat_data(cfg) if test is None else None   # mtime recorded only for our read
    if test is None:
        test = load_tests(cfg)
    path = _fit_path(cfg.run_dir)
    if write and not overwrite and path.exists():
        reason = identity.stale_fit_reason(cfg, test.sha256)
        if reason is not None:
            config = cfg.source if cfg.source is not None else "<config.yaml>"
            raise RunError(f"{path} exists and was made from {reason}; `python -m bayes_dnlr fit "
                           f"--force {config}` replaces it, or set output.dir to fit into another "
                           "run directory and keep it")
    from threadpoolctl import threadpool_limits

    # the fit's linear algebra is on (n, p) arrays with a handful of columns: a second BLAS thread
    # only waits to be woken (the hyperparameter search took 2 ms per quasi-Newton step with two
    # threads on a busy machine, 0.1 ms with one)
    with threadpool_limits(limits=1, user_api="blas"):
        result = fit_run(cfg, test.tests, plain=test.plain)
        fit_references(cfg, result, test.tests)   # the data references in the analyses, first
        for name, single in result.singles.items():
            single.stress_refit = stress_refit(cfg.for_test(name), test.tests[name], single.to_dict())
            found = fit_rows(cfg.for_test(name), test.tests[name], single.to_dict(),
                             "" if test.plain else f"{name}: ")
            single.modulus_at = None if found is None else found.rows
        if not test.plain:
            result.shift_law = leave_one_temperature_out(
                cfg, test, {t: r.to_dict() for t, r in result.singles.items()})
            result.modulus_reference = fit_master_curve(cfg, test, result)
    secs = sections(cfg)
    result.config_digest = identity.config_digest(cfg, secs)
    result.config_sections = identity.section_digests(cfg, secs)
    result.data_sha256 = test.sha256
    result.wall_time_s = time.perf_counter() - t0
    if write:
        created = not cfg.run_dir.exists()
        try:
            prepare_run_dir(cfg)
            write_json(path, {**result.to_dict(), "identity": identity.fit_record(cfg, secs, test, before)})
        except BaseException:
            if created:     # leave no half-made run directory (a config without its fit.json)
                resolved_config_path(cfg).unlink(missing_ok=True)
                discard_if_empty(cfg.run_dir)
            raise
        test.keep_smoothings()       # the run folder exists now: sample and report read it
    return result


def fit_table(result: RunFit) -> str:
    """The console's table of a fit, with each test's E(t) and its trust."""
    block = ({"modulus_at": result.only.modulus_at or []} if result.plain else
             {"single_fits": {t: {"modulus_at": r.modulus_at} for t, r in result.singles.items()},
              "modulus_reference": result.modulus_reference})
    return "\n".join([result.table(), *console_lines(block)])
