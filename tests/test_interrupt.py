"""Ctrl-C during sampling is taken at a step boundary (bayes_dnlr/interrupt.py), and the run lock
(bayes_dnlr/runs/lock.py) leaves no file behind and survives the removal race."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from bayes_dnlr.errors import RunError
from bayes_dnlr.interrupt import deferred_interrupt
from bayes_dnlr.runs import lock as runlock


def test_first_sigint_is_a_request_and_the_second_interrupts() -> None:
    with deferred_interrupt() as ctrl_c:
        os.kill(os.getpid(), signal.SIGINT)
        assert ctrl_c.requested                      # no KeyboardInterrupt here
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)      # the default handler is back
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_the_handler_is_restored_without_a_signal() -> None:
    before = signal.getsignal(signal.SIGINT)
    with deferred_interrupt() as ctrl_c:
        assert signal.getsignal(signal.SIGINT) is not before
    assert not ctrl_c.requested
    assert signal.getsignal(signal.SIGINT) is before


def test_lock_is_exclusive_and_its_file_removed(tmp_path: Path) -> None:
    with runlock.run_lock(tmp_path, "sample.lock", "busy"):
        assert (tmp_path / "sample.lock").is_file()
        with pytest.raises(RunError, match="busy"), runlock.run_lock(tmp_path, "sample.lock", "busy"):
            pass
    assert not (tmp_path / "sample.lock").exists()
    with runlock.run_lock(tmp_path, "sample.lock", "busy"):    # free again
        pass


def test_lock_file_replaced_while_waiting_is_locked_anew(tmp_path: Path, monkeypatch) -> None:
    """The removal race: the file this process opened is removed (by a holder that finished) and a
    new one made before this process locks it. Locking the removed file would let two processes
    in; the inode check makes this one lock the file that is there."""
    path = tmp_path / "sample.lock"
    real = runlock.fcntl.flock
    calls = {"n": 0}

    def flock(f, op):
        calls["n"] += 1
        if calls["n"] == 1:                  # between our open and our flock
            path.unlink()
            path.write_text("")
        return real(f, op)

    monkeypatch.setattr(runlock.fcntl, "flock", flock)
    with runlock.run_lock(tmp_path, "sample.lock", "busy"):
        monkeypatch.setattr(runlock.fcntl, "flock", real)
        # the current file is the locked one: a second locker is refused
        with pytest.raises(RunError), runlock.run_lock(tmp_path, "sample.lock", "busy"):
            pass
    assert calls["n"] >= 2
    assert not path.exists()
