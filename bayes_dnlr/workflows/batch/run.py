"""Many tests at once: fit, sample and (optionally) report each test of a batch, on all local cores
(joblib, loky processes) or on a Dask distributed cluster (joblib's dask backend).

- **One test per process**, one thread each: the workers run with OMP/OpenBLAS/MKL/NUMBA threads
  limited to 1 (loky's ``inner_max_num_threads``; on Dask workers ``threadpoolctl`` and
  ``numba.set_num_threads`` at run time), so tests running side by side do not oversubscribe.
- **Resumable**: each finished test leaves ``<out>/rows/<name>.json``; a re-run skips a test whose
  row is current (same config fingerprint and data file as its summary.json, report present) and
  dispatches the rest, where ``sample`` resumes an interrupted chain from chains.h5 and skips a
  finished one, and the report is made only when missing or older than summary.json.
- **Faults stay local**: an exception in one test becomes a row with status ``failed`` and the
  error; the others go on.
- **Outputs** in ``out``: ``results.csv`` and ``results.parquet`` (one row per test: every parameter's
  posterior summary, R-hat, ESS, τ, the Gauss-Newton estimate, warnings, standards moduli), ``rows/``.

``run_batch(jobs, out, ...)`` returns a ``BatchResult``; the report layer adds the batch page
(``bayes_dnlr.workflows.batch.page``). Results are identical whichever backend runs them: each test's chain
depends only on its config (seed) and data.
"""

from __future__ import annotations

import json
import os
import socket
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bayes_dnlr.config import load_config
from bayes_dnlr.csvcells import safe_cell
from bayes_dnlr.diskio import own_dir
from bayes_dnlr.errors import BayesDnlrError, StaleRunError
from bayes_dnlr.readback import read_json
from bayes_dnlr.runs.folder import (
    jsonable,
    resolved_config_path,
    resolved_config_text,
    write_atomic,
    write_json,
)
from bayes_dnlr.runs.layout import FIT_FILE, REPORT_FILE, SUMMARY_FILE
from bayes_dnlr.runs.lock import run_lock
from bayes_dnlr.runs.modulus_across import run_entries
from bayes_dnlr.runs.trust import ET_FIELDS, run_trust
from bayes_dnlr.vocabulary import DISCREPANCY_PARAMETERS, PARAMETER_NAMES
from bayes_dnlr.workflows.batch.manifest import BatchError, Job

ROWS_DIR = "rows"
TABLE_CSV = "results.csv"
TABLE_PARQUET = "results.parquet"
LOCK_FILE = "batch.lock"
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS",
               "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
# loky replaces a worker whose memory grew by 300 MB since its first test (its leak guard: a long
# real curve and its report's figures do) and warns when tests are queued; they run in the new
# worker and nothing is lost, so the warning only alarmed (docs/batch.md, "Reading the batch page")
WORKER_REPLACED = "A worker stopped while some jobs were given to the executor"
STATS = ("mean", "sd", "median", "hdi90_lo", "hdi90_hi", "ess_bulk", "ess_tail", "r_hat", "tau")
ORDER = (*PARAMETER_NAMES, "sigma0", *DISCREPANCY_PARAMETERS)

Reporter = Callable[[Path], Any]
# the batch's outputs in --out, published as one set (bayes_dnlr/fileset.py): a killed batch leaves
# the table, page and population of the run before it, or all of this run's
BATCH_SET = ["results.csv", "results.parquet", "batch.html", "figures/batch_E.png", "population.json",
             "population.md", "population.png"]


@dataclass
class BatchResult:
    """What a batch did: one row per test (input order), where the outputs are, counts."""

    rows: list[dict[str, Any]]
    out: Path
    backend: str
    elapsed_s: float
    written: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)      # further lines of the summary (population)

    def count(self, status: str) -> int:
        return sum(r.get("status") == status for r in self.rows)

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r.get("status") == "failed"]

    @property
    def reused(self) -> int:
        return sum(bool(r.get("reused")) and r.get("status") == "ok" for r in self.rows)

    def summary(self) -> str:
        n = len(self.rows)
        ok = self.count("ok")
        lines = [f"{n} tests ({self.backend}): {ok} ok ({self.reused} already done, skipped), "
                 f"{self.count('failed')} failed, {self.count('pending')} not run; "
                 f"{self.elapsed_s:.1f} s"]
        lines += [f"  failed: {r['name']}: {r.get('error')}" for r in self.failed]
        lines += [f"  {n}" for n in self.notes]
        lines += [f"  wrote {p}" for p in self.written]
        return "\n".join(lines)


# ---------------------------------------------------------------- one test (runs in a worker)

@contextmanager
def single_threaded() -> Iterator[None]:
    """BLAS/OpenMP and numba limited to one thread in this process while a test runs."""
    import numba
    from threadpoolctl import threadpool_limits

    before = numba.get_num_threads()
    with threadpool_limits(limits=1):
        numba.set_num_threads(1)
        try:
            yield
        finally:
            numba.set_num_threads(before)


def _stale_report(run_dir: Path) -> bool:
    from bayes_dnlr.fileset import recover
    from bayes_dnlr.report.current import REPORT_SET

    recover(run_dir, "report", REPORT_SET)          # a report killed while written: the one before
    report, summary = run_dir / REPORT_FILE, run_dir / SUMMARY_FILE
    return not report.is_file() or report.stat().st_mtime < summary.stat().st_mtime


def run_job(job: Job, report: Reporter | None = None) -> dict[str, Any]:
    """Fit, sample and report one test; never raises for a failing test: the row says what failed."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {"name": job.name, "origin": job.origin, "run_dir": job.run_dir,
                           "worker": f"{socket.gethostname()}:{os.getpid()}", "reused": False,
                           "inputs": job.inputs}
    try:
        if job.error is not None:
            raise BatchError(job.error)
        with single_threaded():
            from bayes_dnlr.runs.sample import sample

            cfg = job.config()
            curves = report is not None      # the report's curves while the model is loaded
            try:
                sample(cfg, progress=False, report_curves=curves)
            except StaleRunError:
                if not job.restart:
                    raise
                sample(cfg, progress=False, restart=True, report_curves=curves)   # only stale runs
            if report is not None and _stale_report(cfg.run_dir):
                report(cfg.run_dir)
            row.update(result_row(job, cfg))
        row["status"] = "ok"
    except Exception as err:  # noqa: BLE001 - one failing test must not stop the batch
        row["status"] = "failed"
        row["error"] = f"{type(err).__name__}: {err}"
        if isinstance(err, StaleRunError):
            row["error"] += " (in a batch: `batch --restart` restarts such tests and keeps the others)"
        if not isinstance(err, BayesDnlrError):
            row["traceback"] = "".join(traceback.format_exception(err)[-6:])
    row["elapsed_s"] = time.perf_counter() - t0
    return row


def fingerprint(cfg, summary: dict[str, Any] | None = None) -> dict[str, Any]:
    """What a finished test's outputs depend on: the chain's fingerprint (config values, sampler
    walkers/seed/moves, data file content: runs/identity.py) and the settings that decide its length
    and burn-in. ``summary``: the run's summary.json, whose record spares hashing unchanged data."""
    from bayes_dnlr.runs import identity
    from bayes_dnlr.runs.chain_outputs import stopping_settings

    sha = identity.data_sha(cfg, summary)     # the data's sha256 (a digest of them with tests:)
    if sha is None:
        raise BatchError(f"{cfg.name}: a data file is missing")
    return {"chain": identity.chain_fingerprint(cfg, cfg.run_dir, sha, summary),
            "settings": stopping_settings(cfg)}


def result_row(job: Job, cfg) -> dict[str, Any]:
    """A finished run's numbers, flat: one column per parameter statistic (summary.json, fit.json)."""
    run_dir = cfg.run_dir
    summary = read_json(run_dir / SUMMARY_FILE, SUMMARY_FILE)
    fit_path = run_dir / FIT_FILE
    fit = read_json(fit_path, FIT_FILE) if fit_path.is_file() else {}
    post = summary.get("posterior") or {}
    tau = summary.get("autocorr_time") or {}
    gn = summary.get("gauss_newton") or {}
    truth = cfg.truth.params if cfg.truth is not None else {}
    row: dict[str, Any] = {
        "material": cfg.material,
        "data_file": ", ".join(str(c.data_path) for c in cfg.test_configs()),
        "n_points": summary.get("n_points"),
        "walkers": summary.get("walkers"), "steps": summary.get("steps"),
        "converged": summary.get("converged"), "stop_reason": summary.get("stop_reason"),
        "sampling_time_s": summary.get("wall_time_s"),
        "noise_model": (summary.get("noise") or {}).get("model"), "sigma0_used": summary.get("sigma0"),
    }
    for p in [n for n in ORDER if n in post] + [n for n in post if n not in ORDER]:
        s = post[p]
        hdi = s.get("hdi_90") or [None, None]
        vals = {"mean": s.get("mean"), "sd": s.get("sd"), "median": s.get("median"),
                "hdi90_lo": hdi[0], "hdi90_hi": hdi[1], "ess_bulk": s.get("ess_bulk"),
                "ess_tail": s.get("ess_tail"), "r_hat": s.get("r_hat"), "tau": tau.get(p)}
        row.update({f"{p}_{k}": v for k, v in vals.items()})
        est, sd = (gn.get("estimate") or {}).get(p), (gn.get("sd") or {}).get(p)
        if est is not None:
            row[f"{p}_gn"], row[f"{p}_gn_sd"] = est, sd
        if p in truth:
            row[f"{p}_true"] = truth[p]
    for p, v in cfg.fixed_values.items():
        row[f"{p}_fixed"] = v
    std = summary.get("standards") or {}
    for key in ("iso527_1", "astm_d638"):      # one value, or one per test in a run with tests:
        v = std.get(key)
        if isinstance(v, int | float) or v is None:
            row[key] = v
    for test, values in std.items():
        if isinstance(values, dict):
            row.update({f"{key}[{test}]": values.get(key) for key in ("iso527_1", "astm_d638")})
    row["deborah_max"] = summary.get("deborah_max")
    row.update(trust_columns(summary))
    row["modulus_at"] = run_entries(summary)       # E(t) at each time, for the page's comparisons
    rhats = [s.get("r_hat") for s in post.values() if s.get("r_hat") is not None]
    esss = [min(s.get("ess_bulk") or 0, s.get("ess_tail") or 0) for s in post.values()]
    row["r_hat_max"] = max(rhats) if rhats else None
    row["ess_min"] = min(esss) if esss else None
    warnings = list(summary.get("warnings") or []) + [
        w for w in (fit.get("warnings") or []) if w not in (summary.get("warnings") or [])]
    row["n_warnings"] = len(warnings)
    row["warnings"] = " | ".join(warnings)
    row["report"] = str(run_dir / REPORT_FILE) if (run_dir / REPORT_FILE).is_file() else None
    row["fingerprint"] = fingerprint(cfg, summary)
    return row


def trust_columns(summary: dict[str, Any]) -> dict[str, Any]:
    """A run's trust as table cells (runs/trust.py): ``trust_interval``, ``adequate``, ``verdict``
    (its first sentence), ``checks_fired`` (names, comma-separated), and E(t) at its first time:
    ``Et_t_s``, ``Et_mean``, ``Et_sd``, ``Et_hdi_lo``, ``Et_hdi_hi``, ``Et_trust`` (empty without
    summary.json's ``modulus_at``; ``Et_mean[test]`` ... per test of a run with several)."""
    trust = run_trust(summary)
    fired = trust.pop("checks_fired")
    cells: dict[str, Any] = {**{k: trust.pop(k) for k in ("trust_interval", "adequate", "verdict")},
                             "checks_fired": None if fired is None else ", ".join(fired)}
    cells.update({f"Et_{f}": None for f in ET_FIELDS})
    for key, values in trust.items():          # Et, or Et[test]
        test = key[len("Et"):]
        cells.update({f"Et_{f}{test}": values[f] for f in ET_FIELDS})
    return cells


# ---------------------------------------------------------------- the batch (parent process)

def _row_path(out: Path, name: str) -> Path:
    return out / ROWS_DIR / f"{name}.json"


def current_row(job: Job, out: Path, want_report: bool) -> dict[str, Any] | None:
    """The stored row of a test that is finished and still current, else None (run it)."""
    path = _row_path(out, job.name)
    if job.error is not None or not path.is_file():
        return None
    try:
        row = read_json(path, "row")
        if row.get("status") != "ok":
            return None
        cfg = job.config()
        summary = read_json(cfg.run_dir / SUMMARY_FILE, SUMMARY_FILE)
        fp = fingerprint(cfg, summary)
    except (OSError, ValueError, BayesDnlrError):
        return None
    if row.get("fingerprint") != fp or summary.get("fingerprint") != fp["chain"]:
        return None
    if summary.get("settings") != fp["settings"]:
        return None
    if want_report and _stale_report(cfg.run_dir):
        return None
    _relabel(cfg)
    return {**row, "reused": True, "origin": job.origin, "material": cfg.material,
            "modulus_at": run_entries(summary)}


def _relabel(cfg) -> None:
    """A finished run whose config now names another material (a label, no part of its chain):
    its resolved config takes the new label, as ``sample`` would write it, so that ``population``
    and ``compare`` of the run folder read the same material as this batch."""
    path = resolved_config_path(cfg)
    try:
        written = load_config(path).material
    except (OSError, ValueError, BayesDnlrError):
        written = object()           # unreadable: written anew
    if written != cfg.material:
        write_atomic(path, resolved_config_text(cfg))


def _batch_lock(out: Path):
    """One batch per output folder at a time (bayes_dnlr/runs/lock.py: released even on SIGKILL,
    removed when the batch ends)."""
    out.mkdir(parents=True, exist_ok=True)
    return run_lock(out, LOCK_FILE, f"{out}: another batch is running into this folder; wait for it "
                    "or stop it (finished tests are kept and the next run resumes)", BatchError)


def _dask_client(scheduler: str):
    """A client of the Dask scheduler: an address (tcp://host:8786), a scheduler file, or
    ``config`` for the Dask config's ``scheduler-address`` (e.g. DASK_SCHEDULER_ADDRESS)."""
    try:
        import dask
        from dask.distributed import Client
    except ImportError as err:
        raise BatchError(f"--scheduler needs dask[distributed] ({err}); pip install "
                         "'dask[distributed]'") from None
    try:
        if scheduler == "config":
            address = dask.config.get("scheduler-address", None)
            if not address:
                raise BatchError("--scheduler config: the Dask config has no scheduler-address (set "
                                 "DASK_SCHEDULER_ADDRESS or scheduler-address in ~/.config/dask/)")
            return Client(address, set_as_default=False)
        if Path(scheduler).is_file():
            return Client(scheduler_file=scheduler, set_as_default=False)
        # waits distributed.comm.timeouts.connect (Dask config, 30 s by default) for the scheduler
        return Client(scheduler, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as err:
        raise BatchError(f"--scheduler {scheduler}: cannot reach the Dask scheduler ({err})") from None


def _stop_local_workers() -> None:
    """Stop loky's worker processes once the batch has its rows. joblib keeps them for reuse and
    joins them at interpreter exit, which took 0.7 s after the last result of a 2-process batch;
    every chain is committed by then (and a killed writer loses nothing: docs/sampling.md)."""
    from joblib.externals.loky import reusable_executor

    executor = getattr(reusable_executor, "_executor", None)
    if executor is not None:
        executor.shutdown(wait=False)


def _results(stack: ExitStack, todo: list[Job], n_jobs: int, client,
             report: Reporter | None) -> tuple[Iterator[dict[str, Any]], str]:
    """Rows of ``todo`` as they finish (any order) and the backend's description; the joblib
    backend stays configured until ``stack`` closes. ``client``: a Dask client, or None (local)."""
    import joblib

    calls = (joblib.delayed(run_job)(j, report) for j in todo)
    if client is None:
        n = n_jobs if n_jobs > 0 else (os.cpu_count() or 1)
        n = max(1, min(n, len(todo)))
        stack.enter_context(warnings.catch_warnings())
        warnings.filterwarnings("ignore", message=WORKER_REPLACED, category=UserWarning)
        stack.enter_context(joblib.parallel_config(backend="loky", n_jobs=n, inner_max_num_threads=1))
        stack.callback(_stop_local_workers)
        gen = joblib.Parallel(return_as="generator_unordered", batch_size=1)(calls)
        return gen, f"{n} local process{'es' if n > 1 else ''} (joblib, loky)"
    workers = client.scheduler_info().get("workers", {})
    threads = sum(w.get("nthreads", 1) for w in workers.values())
    stack.enter_context(joblib.parallel_config(backend="dask", client=client,
                                               wait_for_workers_timeout=60))
    gen = joblib.Parallel(n_jobs=-1, return_as="generator_unordered", batch_size=1)(calls)
    return gen, (f"Dask cluster {client.scheduler.address} ({len(workers)} workers, {threads} "
                 "threads, joblib dask backend)")


def max_jobs() -> int:
    """The most local worker processes ``--jobs`` takes: four per core (each test is one CPU-bound
    process; more only share the cores and multiply the memory)."""
    return 4 * (os.cpu_count() or 1)


def check_jobs(n_jobs: int) -> None:
    """``--jobs N``: 1 <= N <= max_jobs() (0 and negatives were taken as 'all cores' silently)."""
    if not 1 <= n_jobs <= max_jobs():
        raise BatchError(f"--jobs {n_jobs}: give 1 to {max_jobs()} worker processes (4 per core of "
                         f"this machine's {os.cpu_count() or 1}); leave it out for one per core")


def _table_only(result: BatchResult, interrupted: bool) -> list[Path]:
    return write_table(result.rows, result.out)


def run_batch(jobs: list[Job], out: Path, *, n_jobs: int = -1, scheduler: str | None = None,
              report: Reporter | None = None, progress: bool = True,
              publish: Callable[[BatchResult, bool], list[Path]] | None = None) -> BatchResult:
    """Run every job not already done (see the module doc); write the results table into ``out``.
    ``scheduler``: a Dask scheduler (address, scheduler file or ``config``), else local processes.
    ``publish(result, interrupted)``: writes the outputs instead of the table alone (the batch page
    publishes its whole set), holding the batch's lock; also after Ctrl-C."""
    publish = publish or _table_only
    if not jobs:
        raise BatchError("the batch has no tests")
    out = Path(out).resolve()
    t0 = time.perf_counter()
    with ExitStack() as stack:
        client = None
        if scheduler is not None:       # connect first: an unreachable cluster writes nothing
            client = _dask_client(scheduler)
            stack.callback(client.close)          # disconnects; the cluster keeps running
        stack.enter_context(_batch_lock(out))
        own_dir(out / ROWS_DIR)
        rows: dict[str, dict[str, Any]] = {}
        for j in jobs:
            done = current_row(j, out, report is not None)
            if done is not None:
                rows[j.name] = done
        todo = [j for j in jobs if j.name not in rows]
        backend = "all done earlier: nothing to run"
        if todo:
            gen, backend = _results(stack, todo, n_jobs, client, report)
            if progress and client is None:     # this machine's workers compile on a first run
                from bayes_dnlr.model.compiled import announce_first_compile

                announce_first_compile()
            for j in todo:              # a stale row must not survive a failed re-run
                _row_path(out, j.name).unlink(missing_ok=True)
            interrupted = True
            try:
                _collect(gen, rows, len(jobs), out, progress)
                interrupted = False
            finally:                    # also after Ctrl-C: the table of what finished
                result = BatchResult(_ordered(jobs, rows), out, backend, time.perf_counter() - t0)
                result.written = publish(result, interrupted)
        else:
            result = BatchResult(_ordered(jobs, rows), out, backend, time.perf_counter() - t0)
            result.written = publish(result, False)
    return result


def _collect(gen: Iterator[dict[str, Any]], rows: dict[str, dict[str, Any]], total: int, out: Path,
             progress: bool) -> None:
    from tqdm import tqdm

    failed = sum(r.get("status") == "failed" for r in rows.values())
    with tqdm(total=total, initial=len(rows), unit="test", desc="batch", disable=not progress,
              file=sys.stderr) as bar:
        for row in gen:
            write_json(_row_path(out, row["name"]), row)
            rows[row["name"]] = row
            failed += row["status"] == "failed"
            bar.set_postfix_str(f"last {row['name']} ({row['status']}), {failed} failed")
            bar.update()


def _ordered(jobs: list[Job], rows: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for j in jobs:
        row = rows.get(j.name) or {"name": j.name, "origin": j.origin, "run_dir": j.run_dir,
                                   "status": "pending", "error": "not run (the batch stopped)"}
        row = {**row, "inputs": j.inputs}
        out.append(row)
    return out


# a row's nested values that the table leaves out (the E(t) entries are its Et_* columns at the first
# time; all of them stay in rows/<name>.json and each run's summary.json)
NOT_IN_TABLE = ("inputs", "fingerprint", "traceback", "modulus_at")


def table_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows as table records: manifest cells as ``in:<key>`` columns, nested values dropped."""
    flat = []
    for r in rows:
        rec = {k: v for k, v in r.items() if k not in NOT_IN_TABLE}
        rec.update({f"in:{k}": v for k, v in (r.get("inputs") or {}).items()})
        flat.append(rec)
    return flat


def _cell(v: Any) -> Any:
    """A table cell: nested values (per-test values of a run with tests:) as JSON text."""
    return json.dumps(v, sort_keys=True) if isinstance(v, dict | list) else v


FIRST = ("name", "material", "status", "trust_interval", "verdict", "checks_fired", "error", "reused",
         "origin", "run_dir", "data_file", "worker", "elapsed_s")


def write_table(rows: list[dict[str, Any]], out: Path) -> list[Path]:
    """results.csv and results.parquet (pandas + pyarrow), each replaced atomically."""
    import pandas as pd

    recs = table_rows(rows)
    cols: list[str] = [c for c in FIRST if any(c in r for r in recs)]
    for r in recs:
        cols += [k for k in r if k not in cols]
    df = pd.DataFrame([{k: _cell(v) for k, v in jsonable(r).items()} for r in recs], columns=cols)
    for c in df.columns:
        if df[c].dtype != object:
            continue
        values = [v for v in df[c] if v is not None and v == v]
        if all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
            df[c] = pd.to_numeric(df[c])               # numbers stay numbers: None -> NaN
        elif not all(isinstance(v, bool) for v in values):
            df[c] = df[c].map(lambda v: None if v is None or v != v else str(v))  # one type per column
    csv_path, pq_path = out / TABLE_CSV, out / TABLE_PARQUET
    write_atomic(csv_path, df.map(safe_cell).rename(columns=safe_cell).to_csv(index=False))
    tmp = out / f".{TABLE_PARQUET}.{os.getpid()}.tmp"
    df.to_parquet(tmp, index=False)
    os.replace(tmp, pq_path)
    return [csv_path, pq_path]
