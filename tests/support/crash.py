"""Many `sample` processes killed at chosen instants, fast: a zygote process imports bayes_dnlr,
emcee and ArviZ once, then forks one child per run; the child runs the CLI exactly as
``python -m bayes_dnlr sample <config> --quiet`` does (``cli.main``, then ``cli.exit_now``),
with ``BAYES_DNLR_KILL_AT`` set to the kill point. A fork costs milliseconds where a fresh
interpreter costs seconds of imports.

    with Zygote() as z:
        code = z.sample(config, kill="append.step@2", log=tmp / "run.log")   # -9: killed there
        pid = z.start(config, log=tmp / "run.log")     # running: signal it, then
        code = z.wait()
        pid = z.start_command(["export", ...], log=tmp / "export.log")   # any command, then wait
"""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent


class Zygote:
    """The forking server (this file run as a script), and its client."""

    def __enter__(self) -> Zygote:
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve())],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     cwd=HERE)
        assert self.proc.stdout.readline().strip() == "ready"
        self._waiting = False          # a child started whose code is not read yet
        return self

    def __exit__(self, *exc) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=60)

    def sample(self, config: Path, *, kill: str = "", log: Path, precheck: bool = True,
               pace: float = 0.0) -> int:
        """Run `sample config --quiet` in a forked child; its return code (negative: the signal).

        ``precheck=False``: the store's free-space check before each write is switched off, so a
        full disk is met by HDF5's own writes. ``pace``: seconds the child sleeps after each
        evaluation of the log-posterior (``start``)."""
        self.start(config, kill=kill, log=log, precheck=precheck, pace=pace)
        return self.wait()

    def start(self, config: Path, *, kill: str = "", log: Path, precheck: bool = True,
              pace: float = 0.0) -> int:
        """Fork `sample config --quiet` and return at once with the child's pid (to signal it);
        ``wait`` gives its return code. One child at a time.

        ``pace`` > 0: the child sleeps that long after each evaluation of the log-posterior, so
        that a signal sent from outside meets it mid-run however fast the machine is, at the cost
        of wall time, not of CPU (the chain is the same)."""
        job = {"config": str(config), "kill": kill, "log": str(log), "precheck": precheck,
               "pace": pace}
        return self._fork(job)

    def start_command(self, args: list[str], *, kill: str = "", log: Path) -> int:
        """Fork ``python -m bayes_dnlr <args>`` (the CLI's main) in a session of its own, so that a
        kill of its process group takes the worker processes it starts with it (as
        ``start_new_session`` does for a subprocess), and return at once with its pid; ``wait``
        gives its return code. One child at a time. A forked child computes in one thread
        (``model.threads.parallel_allowed``); a `batch --jobs 2` starts its workers afresh (loky)."""
        job = {"argv": list(args), "kill": kill, "log": str(log), "precheck": True, "pace": 0.0,
               "session": True}
        return self._fork(job)

    def wait(self) -> int:
        """The return code of the child ``start`` forked (negative: the signal that ended it)."""
        self._waiting = False
        return self._read()

    def _fork(self, job: dict) -> int:
        # the zygote is shared by the session: a test that failed between its start and its wait
        # left the code of its child unread, which the next test would take for its child's pid
        if self._waiting:
            self.wait()
        self.proc.stdin.write(json.dumps(job) + "\n")
        self.proc.stdin.flush()
        self._waiting = True
        return self._read()

    def _read(self) -> int:
        line = self.proc.stdout.readline()
        assert line, "the zygote died"
        return int(line)


def child_running(pid: int) -> bool:
    """True while a child the zygote forked runs (the zygote reaps it only when it has ended, so an
    ended child is a zombie until then)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        # gone, or reaped by the zygote between the open and the read (ESRCH)
        return False


def _warm_up() -> None:
    """One whole `sample` of a tiny case: every lazy import and numba's cache loaded before forking
    (no HDF5 file stays open). It computes in one thread, as the forked children do
    (``model.threads.parallel_allowed``): the serial variants of the compiled functions are the ones
    loaded, not loaded again by every child (0.05 s each)."""
    import contextlib
    import io
    import tempfile
    from unittest import mock

    import bayes_dnlr.cli as cli
    from bayes_dnlr.model import threads
    from support.sampling import write_case

    with (mock.patch.object(threads, "parallel_allowed", lambda: False),
          tempfile.TemporaryDirectory() as tmp):
        path = write_case(Path(tmp), n=300, sampler={"walkers": 8, "max_steps": 20,
                                                      "checkpoint_every": 20, "target_ess": 1e9})
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            assert cli.main(["sample", str(path), "--quiet"]) == 0


def _pace(seconds: float) -> None:
    """Every evaluation of the log-posterior in this process followed by a sleep of ``seconds``."""
    import time

    from bayes_dnlr.inference.posterior.density import LogPosterior

    evaluate = LogPosterior.__call__

    def paced(self, z):
        out = evaluate(self, z)
        time.sleep(seconds)
        return out

    LogPosterior.__call__ = paced


def _serve() -> None:
    import bayes_dnlr.cli as cli
    from bayes_dnlr import diskio

    _warm_up()
    gc.freeze()      # the children's garbage collector leaves the zygote's objects (and pages) alone
    print("ready", flush=True)
    # the only other thread is OpenBLAS's idle worker, which OpenBLAS re-creates after a fork
    warnings.filterwarnings("ignore", "This process .* is multi-threaded", DeprecationWarning)
    for line in sys.stdin:
        job = json.loads(line)
        pid = os.fork()
        if pid == 0:
            fd = os.open(job["log"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(fd, 1)
            os.dup2(fd, 2)
            os.environ[diskio.KILL_ENV] = job["kill"]
            diskio._KILL_AT = diskio._kill_spec(job["kill"])
            diskio._reached.clear()
            if not job["precheck"]:
                from bayes_dnlr.runs import chains as store

                store.ensure_free = lambda *args, **kwargs: None
            if job["pace"] > 0:
                _pace(job["pace"])
            if job.get("session"):
                os.setsid()
            # as bayes_dnlr/__main__.py ends: the interpreter's finalization skipped (0.13 s a child)
            cli.exit_now(cli.main(job.get("argv") or ["sample", job["config"], "--quiet"],
                                  ends_process=True))
        print(pid, flush=True)
        _, status = os.waitpid(pid, 0)
        print(os.waitstatus_to_exitcode(status), flush=True)


if __name__ == "__main__":
    sys.path.insert(0, str(HERE.parent))      # run as a script: tests/ holds the support package
    _serve()
