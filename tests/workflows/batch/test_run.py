"""The batch runner on tiny synthetic tests: faults stay local, a real Dask cluster gives the very
chains of the local run, a killed batch resumes without recomputing what had finished."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from support.batch import FEW, LONG_STEPS, tiny_campaign
from support.drawing import figures_not_drawn
from support.git_ignore import not_ignored

from bayes_dnlr.cli import main
from bayes_dnlr.runs.chains import read_run
from bayes_dnlr.workflows.batch.page import run_campaign

PARAMS = ("E", "G", "tau_max")


def _batch(template: Path, manifest: Path, out: Path, *extra: str) -> int:
    return main(["batch", str(template), "--manifest", str(manifest), "--out", str(out),
                 "--quiet", *extra])


def test_one_corrupt_data_file_gives_three_results_and_one_error_row(tmp_path, capsys):
    # four tests on two workers, the third corrupt: ok rows before and after the failed one
    template, manifest = tiny_campaign(tmp_path, 4)
    bad = tmp_path / "data" / "t2.csv"
    bad.write_text("t_s,eps,stress_MPa\n0,0,0\n1,0.005,abc\n2,0.01,\x00\x01garbage\n")
    out = tmp_path / "out"
    assert _batch(template, manifest, out, "--jobs", "2", "--no-report") == 1   # a test failed
    printed = capsys.readouterr().out
    assert "3 ok" in printed and "1 failed" in printed and "t2" in printed

    csv = pd.read_csv(out / "results.csv")
    pq = pd.read_parquet(out / "results.parquet")
    assert list(csv["name"]) == list(pq["name"]) == [f"t{i}" for i in range(4)]   # input order
    assert list(pq["status"]) == ["ok"] * 2 + ["failed"] + ["ok"]
    err = pq.loc[2, "error"]
    assert "t2.csv" in err and "DataError" in err                 # which file, what went wrong
    assert pq.loc[2, "origin"].endswith("manifest.csv line 4")
    ok = pq[pq["status"] == "ok"]
    for p in PARAMS:
        for stat in ("mean", "sd", "median", "hdi90_lo", "hdi90_hi", "ess_bulk", "ess_tail", "r_hat",
                     "tau", "gn", "gn_sd"):
            assert ok[f"{p}_{stat}"].notna().all(), f"{p}_{stat}"
    assert (abs(ok["E_mean"] - 2854.0) < 5 * ok["E_sd"]).all()
    assert {"iso527_1", "astm_d638", "warnings", "n_warnings", "converged", "r_hat_max", "ess_min",
            "in:data.file", "in:sampler.seed"} <= set(pq.columns)
    assert pq["E_mean"].dtype == np.float64 and pq["steps"].notna().sum() == 3
    np.testing.assert_allclose(csv["E_mean"].to_numpy(), pq["E_mean"].to_numpy(), rtol=1e-12)
    assert (ok["worker"].str.split(":").str[-1].astype(int) != os.getpid()).all()   # worker processes
    page = (out / "batch.html").read_text()
    assert "1 failed" in page and "t2.csv" in page and "E across the tests" in page
    assert "data:image/png;base64," in page and (out / "figures" / "batch_E.png").is_file()
    assert not (out / "runs" / "t2" / "chains.h5").exists()
    # every file the batch wrote, in its default folder inside the project's runs/, stays out of
    # `git status` as every other run output does
    written = sorted(str(Path("runs/campaign/batch-manifest") / p.relative_to(out))
                     for p in out.rglob("*") if p.is_file())
    assert any(w.endswith("batch.html") for w in written) and any("/rows/" in w for w in written)
    assert not not_ignored(written)

    # fixing the file and running again: only t2 runs, here in this process (what is reused is
    # decided before any worker starts: a worker process for t2 alone would cost its imports only)
    bad.write_bytes((tmp_path / "data" / "t0.csv").read_bytes())
    before = {i: (out / "runs" / f"t{i}" / "summary.json").stat().st_mtime_ns for i in (0, 1, 3)}
    assert _batch(template, manifest, out, "--jobs", "1", "--no-report") == 0
    pq = pd.read_parquet(out / "results.parquet")
    assert list(pq["status"]) == ["ok"] * 4
    assert list(pq["reused"]) == [True] * 2 + [False] + [True]
    assert {i: (out / "runs" / f"t{i}" / "summary.json").stat().st_mtime_ns for i in before} == before


def _worker_pids(client) -> set[int]:
    return set(client.run(os.getpid).values())


@pytest.mark.slow      # a local batch, then a Dask cluster of two worker processes: 17 s of CPU
def test_dask_cluster_gives_the_chains_of_the_local_run(tmp_path):
    distributed = pytest.importorskip("distributed")
    template, manifest = tiny_campaign(tmp_path, 4)
    local, remote = tmp_path / "local", tmp_path / "dask"
    assert _batch(template, manifest, local, "--jobs", "2", "--no-report") == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, host="127.0.0.1") as cluster, \
            distributed.Client(cluster) as client:
        pids = _worker_pids(client)
        assert os.getpid() not in pids and len(pids) == 2
        assert _batch(template, manifest, remote, "--scheduler", cluster.scheduler_address,
                      "--no-report") == 0
    a = pd.read_parquet(local / "results.parquet")
    b = pd.read_parquet(remote / "results.parquet")
    assert {int(w.split(":")[-1]) for w in b["worker"]} <= pids        # ran on the cluster's workers
    for col in [c for c in a.columns if c.split("_")[-1] in ("mean", "sd", "lo", "hi", "hat", "tau")]:
        np.testing.assert_array_equal(a[col].to_numpy(), b[col].to_numpy(), err_msg=col)
    for i in range(4):
        ra, rb = (read_run(d / "runs" / f"t{i}" / "chains.h5") for d in (local, remote))
        assert ra.steps == rb.steps > 0
        np.testing.assert_array_equal(ra.chain, rb.chain)
        np.testing.assert_array_equal(ra.log_prob, rb.log_prob)


def test_unreachable_scheduler_is_a_clear_error(tmp_path, capsys):
    dask = pytest.importorskip("dask")
    pytest.importorskip("distributed")
    template, manifest = tiny_campaign(tmp_path, 1)
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        code = _batch(template, manifest, tmp_path / "out", "--scheduler", "tcp://127.0.0.1:9")
    assert code == 2
    assert "cannot reach the Dask scheduler" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()                # nothing written


def _run_files(run: Path) -> dict[str, int]:
    names = ("fit.json", "chains.h5", "posterior.nc", "summary.json", "report.html")
    return {n: (run / n).stat().st_mtime_ns for n in names}


def test_killed_batch_resumes_and_recomputes_nothing_finished(tmp_path, monkeypatch):
    # three tests on two workers: t2, which never converges, starts when t0 or t1 has finished
    template, manifest = tiny_campaign(tmp_path, 3, long={2})
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "bayes_dnlr", "batch", str(template), "--manifest", str(manifest),
           "--out", str(out), "--jobs", "2", "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)       # its own process group, workers included
    chains = out / "runs" / "t2" / "chains.h5"
    t0 = time.monotonic()
    while True:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < 300, "the batch did not get far enough in time"
        finished = sorted(p.stem for p in (out / "rows").glob("*.json")) if (out / "rows").is_dir() else []
        steps = 0
        if chains.exists():
            try:
                steps = read_run(chains).steps
            except OSError:
                steps = 0
        if finished and steps >= 100:
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=60)
    finished = sorted(p.stem for p in (out / "rows").glob("*.json"))   # rows written before the kill
    assert "t2" not in finished and finished
    cut = read_run(chains)
    assert 100 <= cut.steps < LONG_STEPS and not cut.finished
    done = {n: _run_files(out / "runs" / n) for n in finished}

    # the resume in this process: what is reused and what resumes does not depend on the workers
    # (its reports are built whole, their figures not drawn: the page is what is read here)
    figures_not_drawn(monkeypatch)
    result = run_campaign([str(template)], manifest=manifest, out=out, n_jobs=1, progress=False)
    rows = {r["name"]: r for r in result.rows}
    assert [r["status"] for r in result.rows] == ["ok"] * 3, [r.get("error") for r in result.rows]
    for n in finished:
        assert rows[n]["reused"] is True
        assert _run_files(out / "runs" / n) == done[n]           # nothing finished was recomputed
    assert rows["t2"]["reused"] is False
    run = read_run(chains)
    assert run.finished and run.steps == LONG_STEPS
    np.testing.assert_array_equal(run.chain[: cut.steps], cut.chain)   # resumed, not restarted
    table = pd.read_parquet(out / "results.parquet")
    assert list(table["status"]) == ["ok"] * 3 and table["E_mean"].notna().all()
    assert all((out / "runs" / f"t{i}" / "report.html").is_file() for i in range(3))
    row2 = json.loads((out / "rows" / "t2.json").read_text())
    assert row2["steps"] == LONG_STEPS and row2["converged"] is False


def test_restart_redoes_only_the_tests_whose_chain_is_stale(tmp_path, capsys):
    """A test sampled from other data fails with a pointer to `batch --restart`; with it, that test
    starts again and the current ones are reused untouched."""
    template, manifest = tiny_campaign(tmp_path, 3, sampler=FEW)
    out = tmp_path / "out"
    assert _batch(template, manifest, out, "--jobs", "1", "--no-report", "--no-population") == 0
    other = (tmp_path / "data" / "t0.csv").read_bytes()
    (tmp_path / "data" / "t1.csv").write_bytes(other)                  # t1's data changed
    before = {i: (out / "runs" / f"t{i}" / "summary.json").stat().st_mtime_ns for i in (0, 2)}
    assert _batch(template, manifest, out, "--jobs", "1", "--no-report", "--no-population") == 1
    pq = pd.read_parquet(out / "results.parquet")
    assert list(pq["status"]) == ["ok", "failed", "ok"]
    assert "StaleRunError" in pq.loc[1, "error"] and "batch --restart" in pq.loc[1, "error"]
    capsys.readouterr()
    assert _batch(template, manifest, out, "--jobs", "1", "--no-report", "--no-population",
                  "--restart") == 0
    pq = pd.read_parquet(out / "results.parquet")
    assert list(pq["status"]) == ["ok"] * 3 and list(pq["reused"]) == [True, False, True]
    assert {i: (out / "runs" / f"t{i}" / "summary.json").stat().st_mtime_ns for i in before} == before
    assert read_run(out / "runs" / "t1" / "chains.h5").finished


def test_a_batch_says_when_its_workers_compile_the_model(tmp_path, capsys, monkeypatch):
    """The note of model/compiled.py, before the tests run (a test that fails on its data costs no
    fit); none with --quiet."""
    from bayes_dnlr.model import compiled

    monkeypatch.setattr(compiled, "first_compile_note", lambda: compiled.FIRST_COMPILE_NOTE)
    template, manifest = tiny_campaign(tmp_path, 1)
    (tmp_path / "data" / "t0.csv").write_text("t_s,eps,stress_MPa\n0,0,0\n1,0.005,abc\n")
    args = ["batch", str(template), "--manifest", str(manifest), "--jobs", "1", "--no-report",
            "--no-population"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 1          # the test failed on its data
    assert compiled.FIRST_COMPILE_NOTE in capsys.readouterr().err
    assert main([*args, "--out", str(tmp_path / "b"), "--quiet"]) == 1
    assert compiled.FIRST_COMPILE_NOTE not in capsys.readouterr().err


def test_a_replaced_worker_is_not_a_warning(recwarn):
    """loky replaces a worker whose memory grew by 300 MB (its leak guard) and warns from its
    manager thread when tests are queued: every test still finished, so the batch's local pool
    keeps that warning off stderr, and only that one."""
    import threading
    import warnings
    from contextlib import ExitStack

    from bayes_dnlr.workflows.batch.run import WORKER_REPLACED, _results

    def warn(text: str) -> None:          # from another thread, as loky's manager thread does
        th = threading.Thread(target=warnings.warn, args=(text, UserWarning))
        th.start()
        th.join()

    full = WORKER_REPLACED + ". This can be caused by a too short worker timeout or by a memory leak."
    with ExitStack() as stack:
        _results(stack, [], 1, None, None)
        warn(full)
        warn("another warning")
    assert [str(w.message) for w in recwarn] == ["another warning"]
    warn(full)                            # outside the batch's pool: not hidden
    assert [str(w.message) for w in recwarn][-1] == full
