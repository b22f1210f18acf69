"""Shared fixtures: small configs and CSV files in a temporary folder."""

from __future__ import annotations

import os

# BLAS on one thread in the test session and in every process it starts. The suite's matrices are
# small, and on a loaded 2-core machine OpenBLAS's second thread spins while it waits: it cost
# tests/inference/discrepancy/test_gp.py 6 times the CPU. (The model's own threads, numba's, are
# left as they are: the thread tests set them.)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import signal
import sys

# Ctrl-C as in a terminal, for this process and the runs it forks: a shell that starts `make test`
# in the background (`make test &`, some CI runners) hands it SIGINT ignored, and the package keeps
# an ignored SIGINT ignored (interrupt.py), so the tests of Ctrl-C would see no signal at all.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from threadpoolctl import threadpool_limits

from bayes_dnlr.config import Config, parse_config

threadpool_limits(limits=1, user_api="blas")      # in case numpy was loaded before this file

DEFAULT_DATA: dict[str, Any] = {
    "file": "test.csv",
    "columns": {"time": "t_s", "force": "F_N", "eps11": "eps11"},
    "area0": 24.0,
}


@pytest.fixture
def write_csv(tmp_path: Path) -> Callable[[str, str], Path]:
    """write_csv(text, name='test.csv') -> path of the file in tmp_path."""

    def write(text: str, name: str = "test.csv") -> Path:
        path = tmp_path / name
        path.write_text(text)
        return path

    return write


@pytest.fixture
def make_config(tmp_path: Path) -> Callable[..., Config]:
    """make_config(name='t', truth=None, **data_keys) -> a validated Config anchored in tmp_path.

    data keys override DEFAULT_DATA (e.g. columns=..., window=...); ``truth`` adds a truth: section.
    """

    def make(truth: dict[str, Any] | None = None, **data: Any) -> Config:
        raw: dict[str, Any] = {"name": "t", "data": {**DEFAULT_DATA, **data}}
        if truth is not None:
            raw["truth"] = truth
        return parse_config(raw, source=tmp_path / "config.yaml")

    return make


@pytest.fixture(scope="session")
def zygote():
    """Forks `sample` processes at the cost of a fork (tests/support/crash.py)."""
    from support.crash import Zygote

    with Zygote() as z:
        yield z


# ------------------------------------------- the real curves and the browser, counted in the summary

_REAL_REPORTS: dict[str, list] = {"ran": [], "skipped": []}
_BROWSER_REPORTS: dict[str, list] = {"ran": [], "skipped": []}


@pytest.hookimpl(wrapper=True)
def pytest_collection(session):
    """pytest's rewritten test modules are kept as bytecode (tests/**/__pycache__/*-pytest-*.pyc)
    even where PYTHONDONTWRITEBYTECODE is set (as on the benchmark machine), for the collection
    only: pytest reads them whatever the setting, but writes them only where bytecode is written,
    and rewriting the asserts of every test module cost each session 11-12 s of CPU (collection
    21 -> 9.5 s). The modules the collection imports get their bytecode too, as `make bytecode`
    gives the package's; the setting is restored for the tests themselves."""
    was = sys.dont_write_bytecode
    sys.dont_write_bytecode = False
    try:
        return (yield)
    finally:
        sys.dont_write_bytecode = was


def pytest_configure(config) -> None:
    config.addinivalue_line("markers", "real_data: reads the real curves of tests/support/real_data.py "
                                       "(skipped when they are absent)")
    config.addinivalue_line("markers", "browser: opens a page in headless Chromium (tests/support/"
                                       "browser.py; skipped when it is not installed)")


def pytest_runtest_logreport(report) -> None:
    for mark, reports in (("real_data", _REAL_REPORTS), ("browser", _BROWSER_REPORTS)):
        if mark not in report.keywords:
            continue
        if report.when == "call":
            reports["ran"].append(report)
        elif report.skipped:
            reports["skipped"].append(report)


class _Counted:
    """An entry of pytest's last line that is counted there and nowhere else: the tests' own
    reports, listed under a second key, would be counted twice by ``--durations``."""


def pytest_terminal_summary(terminalreporter) -> None:
    """Say whether the real-data tests ran, on a line of its own (where the curves are, or how to
    give them) and in pytest's last summary line ('11 real-data tests ran'), so that a clone without
    the curves does not run fewer tests silently; the same for the tests that open a page in
    Chromium ('2 browser tests ran', or '2 browser tests skipped (no Chromium)')."""
    from support import browser, real_data

    _summary(terminalreporter, _BROWSER_REPORTS, browser.PRESENT,
             f"browser: {{ran}} tests ran ({browser.EXE})", "browser tests ran",
             f"browser: {{skipped}} tests skipped: {browser.REASON}",
             "browser tests skipped (no Chromium)")
    _summary(terminalreporter, _REAL_REPORTS, real_data.PRESENT,
             f"real data: {{ran}} tests ran ({real_data.REAL})", "real-data tests ran",
             f"real data: absent, {{skipped}} tests skipped (set {real_data.ENV} to the folder of the "
             "real curves)", "real-data tests skipped (curves absent)")


def _summary(terminalreporter, reports: dict, present: bool, ran_text: str, ran_key: str,
             absent_text: str, absent_key: str) -> None:
    """One line of its own and one entry of pytest's last line for a kind of test that needs
    something a clone may lack; nothing when no test of that kind was collected."""
    ran, skipped = reports["ran"], reports["skipped"]
    if not ran and not skipped:
        return
    if present:
        text = ran_text.replace("{ran}", str(len(ran))) + (f", {len(skipped)} skipped" if skipped else "")
        terminalreporter.stats[ran_key] = [_Counted() for _ in ran]
    else:
        text = absent_text.replace("{skipped}", str(len(skipped)))
        terminalreporter.stats[absent_key] = [_Counted() for _ in skipped]
    terminalreporter.write_line(text, yellow=not present, bold=True)


@dataclass
class Ran:
    """What ``cli_here`` returns: the command's exit status and its stderr."""
    returncode: int
    stderr: str


@pytest.fixture
def cli_here(capsys) -> Callable[..., Ran]:
    """cli_here(*args): the command run by the CLI's main in this process (what `python -m
    bayes_dnlr` runs; a fresh interpreter costs each call 3-5 s of CPU in imports); its exit
    status and stderr."""
    from bayes_dnlr.cli import main

    def run(*args: str) -> Ran:
        capsys.readouterr()
        code = main(list(args))
        return Ran(code, capsys.readouterr().err)

    return run
