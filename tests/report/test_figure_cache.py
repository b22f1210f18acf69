"""The report's figures are drawn only when their inputs change, and the worker process that draws
some of them beside the page gives the same page and the same PNGs as drawing them one by one."""

from __future__ import annotations

import functools
import json
import os
import re
import shutil
import time
from pathlib import Path

import pytest
from support.drawing import busy_until, logged_figure, pid_figure
from support.finished_run import make_finished_run

from bayes_dnlr.report import build_report, figure_cache


def _text(page: Path) -> str:
    """The page without its footer (build time)."""
    return re.sub(r"<footer>.*?</footer>", "", page.read_text(), flags=re.S)


def _pngs(run: Path) -> dict[str, tuple[int, bytes]]:
    return {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in (run / "figures").glob("*.png")}


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    return make_finished_run(tmp_path_factory.mktemp("figs"))


@pytest.fixture
def run(finished, tmp_path) -> Path:
    return Path(shutil.copytree(finished, tmp_path / "tiny", ignore=shutil.ignore_patterns(
        "report.html", "figures")))


def test_a_rebuild_keeps_every_figure_and_redraws_what_changed(tmp_path):
    # the run with its report as first built, figures and page (drawn once per session)
    run = make_finished_run(tmp_path, figures=True, page=True)
    first = _text(run / "report.html")
    before = _pngs(run)
    assert set(before) >= {"fit.png", "trace.png", "corner.png"}
    assert _text(build_report(run)) == first
    assert _pngs(run) == before                       # not one PNG written again
    fit = json.loads((run / "fit.json").read_text())
    fit["estimate"]["E"] *= 1.01                      # the least-squares curve moves
    (run / "fit.json").write_text(json.dumps(fit))
    build_report(run)
    after = _pngs(run)
    assert after["fit.png"] != before["fit.png"] and after["sensitivity.png"] != before["sensitivity.png"]
    assert after["trace.png"] == before["trace.png"] and after["rank.png"] == before["rank.png"]
    assert figure_cache.stored_key(run / "figures" / "fit.png") is not None


def test_a_figure_no_longer_drawn_is_removed(tmp_path):
    run = make_finished_run(tmp_path, figures=True)     # the figures of its report: none drawn here
    build_report(run)
    stray = run / "figures" / "old-figure.png"
    shutil.copy(run / "figures" / "fit.png", stray)
    build_report(run)
    assert not stray.exists()


# the worker is forced here, whatever the machine's load
def test_the_worker_draws_the_same_page(run, tmp_path, monkeypatch):
    forked = []
    fork = figure_cache._fork_worker

    def counted():
        worker = fork()
        forked.append(worker)
        return worker

    monkeypatch.setattr(figure_cache, "_free_core", lambda: True)
    monkeypatch.setattr(figure_cache, "_single_threaded", lambda: True)
    monkeypatch.setattr(figure_cache, "_fork_worker", counted)
    aside = _text(build_report(run))
    assert forked and forked[0] is not None
    pngs = {k: v[1] for k, v in _pngs(run).items()}
    # the same run's report drawn in one process, without the worker (once per session)
    alone = make_finished_run(tmp_path / "alone", figures=True, page=True)
    assert _text(alone / "report.html") == aside
    assert {k: v[1] for k, v in _pngs(alone).items()} == pngs


def test_a_busy_worker_is_handed_nothing_and_a_free_one_the_next_figure(tmp_path, monkeypatch):
    """A worker is given a figure only when it has none: while it is busy every figure handed over
    stays here, and at the session's end this process draws them all, the last handed over first.
    A free worker takes the next figure at once."""
    monkeypatch.setattr(figure_cache, "_free_core", lambda: True)
    monkeypatch.setattr(figure_cache, "_single_threaded", lambda: True)
    paths = [tmp_path / f"{name}.png" for name in "abcd"]
    log = tmp_path / "order.txt"
    # the worker stays busy until this process has drawn a, the last it draws
    with figure_cache.figure_session(warm=functools.partial(busy_until, paths[0])):
        for path in paths:
            figure_cache.drawn(logged_figure, path, log, aside=True)
        assert figure_cache._session.get().pending == []        # nothing handed to a busy worker
    assert [int(p.read_text()) for p in paths] == [os.getpid()] * 4
    assert log.read_text().split() == ["d.png", "c.png", "b.png", "a.png"]

    late = tmp_path / "late.png"
    with figure_cache.figure_session():
        figure_cache.drawn(pid_figure, late, aside=True)
        deadline = time.monotonic() + 60.0
        while not late.exists() and time.monotonic() < deadline:     # the worker draws it
            time.sleep(0.005)
    assert int(late.read_text()) != os.getpid()


def test_the_worker_waits_for_a_core_idle_now(monkeypatch):
    """The figure worker is forked when a core is idle at this instant, whatever the last minute's
    load says (it still counts the `sample` run just before the report)."""
    monkeypatch.setattr(figure_cache.os, "sched_getaffinity", lambda _pid: {0, 1})
    monkeypatch.setattr(figure_cache.os, "getloadavg", lambda: (1.9, 1.9, 1.9))
    monkeypatch.setattr(figure_cache, "other_runnable", lambda: 0)
    assert figure_cache._free_core()
    monkeypatch.setattr(figure_cache, "other_runnable", lambda: 1)
    assert not figure_cache._free_core()
    monkeypatch.setattr(figure_cache.os, "sched_getaffinity", lambda _pid: {0})
    monkeypatch.setattr(figure_cache, "other_runnable", lambda: 0)
    assert not figure_cache._free_core()


def test_other_runnable_counts_the_tasks_running_now(monkeypatch, tmp_path):
    """The kernel's runnable count less this process; the minute's load where there is none."""
    import builtins

    from bayes_dnlr import machine_load

    real_open = builtins.open
    loadavg = tmp_path / "loadavg"

    def fake_open(path, *args, **kwargs):
        return real_open(loadavg if path == "/proc/loadavg" else path, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", fake_open)
    monkeypatch.setattr(machine_load, "own_runnable", lambda: 1)
    monkeypatch.setattr(machine_load.os, "getloadavg", lambda: (1.25, 1.0, 1.0))
    loadavg.write_text("1.90 1.50 1.20 3/120 999\n")
    assert machine_load.other_runnable() == 2
    loadavg.write_text("0.10 0.10 0.10 1/120 999\n")
    assert machine_load.other_runnable() == 0
    loadavg.unlink()
    assert machine_load.other_runnable() == 1.25


def test_a_task_runnable_for_an_instant_is_not_a_load(monkeypatch):
    """The least of a few counts read 1 ms apart: one count with a passing task does not take
    the figure worker away; a task runnable at every read does."""
    from bayes_dnlr import machine_load

    counts = iter([3, 1, 2])
    monkeypatch.setattr(machine_load, "_runnable_now", lambda: next(counts))
    monkeypatch.setattr(machine_load, "own_runnable", lambda: 1)
    assert machine_load.other_runnable() == 0
    counts = iter([2, 2, 3])
    assert machine_load.other_runnable() == 1


def test_this_process_threads_are_not_another_task(monkeypatch):
    """A thread of this process still running after a parallel call (numba's OpenMP pool spins a
    moment before it sleeps) is not a load: it took the figure worker away from a report made
    right after `sample` in the same process."""
    from bayes_dnlr import machine_load

    monkeypatch.setattr(machine_load, "_runnable_now", lambda: 3)
    monkeypatch.setattr(machine_load, "own_runnable", lambda: 2)
    assert machine_load.other_runnable() == 1
    monkeypatch.setattr(machine_load, "own_runnable", lambda: 3)
    assert machine_load.other_runnable() == 0


def test_own_runnable_counts_the_threads_in_state_r(tmp_path):
    """The threads of /proc/<pid>/task whose state is R; at least 1 (the caller), also where the
    folder cannot be read or a thread ended since the listing."""
    from bayes_dnlr import machine_load

    def task(tid: str, comm: str, state: str | None) -> None:
        (tmp_path / tid).mkdir()
        if state is not None:
            (tmp_path / tid / "stat").write_text(f"{tid} ({comm}) {state} 1 2 3 4\n")

    task("10", "python", "R")
    task("11", "numba (omp) R", "S")       # a name with ') R' in it: the state is after the last ')'
    task("12", "python", "R")
    task("13", "python", None)             # ended: its stat is gone
    assert machine_load.own_runnable(str(tmp_path)) == 2
    assert machine_load.own_runnable(str(tmp_path / "absent")) == 1
    assert machine_load.own_runnable() >= 1         # this process, the real /proc
