"""Kill a command at chosen instants and judge its output sets: each must be the old set or a whole
new one, and nothing temporary may be left once the command has run again (bayes_dnlr/fileset.py).
Used by tests/test_fileset.py (a few instants) and benchmarks/kill_sets.py (20 each)."""

from __future__ import annotations

import base64
import contextlib
import csv
import io
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from bayes_dnlr.diskio import KILL_ENV
from bayes_dnlr.fileset import recover, recover_folder
from bayes_dnlr.report.current import REPORT_SET
from bayes_dnlr.workflows.batch.run import BATCH_SET
from support.batch import tiny_campaign
from support.crash import child_running
from support.drawing import figures_not_drawn

LEFTOVER = re.compile(r"(\.tmp|\.before|\.publishing|\.old)$")
_IMG = re.compile(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"')


def files(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (relative path -> bytes)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def set_files(folder: Path, patterns: list[str]) -> dict[str, bytes]:
    out = {}
    for pattern in patterns:
        for p in folder.glob(pattern):
            if p.is_file():
                out[str(p.relative_to(folder))] = p.read_bytes()
    return out


def leftovers(root: Path) -> list[str]:
    """Temporaries, kept links, journals, parked folders under ``root`` (chains.h5.tmp included)."""
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if LEFTOVER.search(p.name))


def run(cmd: list[str], env: dict[str, str] | None = None, timeout: float = 900,
        ok: tuple[int, ...] = (0, 1)) -> float:
    """Run ``cmd`` to its end (``ok``: the exit statuses accepted); its wall time."""
    t0 = time.monotonic()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
    if proc.returncode not in ok:
        raise AssertionError(f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stderr[-2000:]}")
    return time.monotonic() - t0


def run_here(args: list[str]) -> None:
    """Run the command ``args`` to its end by the CLI's main in this process (what
    ``python -m bayes_dnlr`` runs): the next run after a kill, and the old set, which nothing
    times. A fresh interpreter cost each 4-5 s of CPU in imports."""
    from bayes_dnlr.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        code = main(args)
    if code not in (0, 1):
        raise AssertionError(f"{' '.join(args)}: exit {code}\n{out.getvalue()[-2000:]}")


def kill_after(cmd: list[str], seconds: float, env: dict[str, str] | None = None) -> int | None:
    """Start ``cmd`` in its own session and SIGKILL the whole group after ``seconds`` (with a named
    kill point in ``env`` the process may kill itself first). The exit status, None if it ended
    before the kill."""
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)
    try:
        proc.wait(timeout=seconds)
        return proc.returncode if proc.returncode != 0 else None
    except subprocess.TimeoutExpired:
        pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()
    _reap(proc.pid)
    return -9


def _reap(pgid: int) -> None:
    """Wait until no process of the killed group is left (loky workers are in it)."""
    for _ in range(100):
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)


def timed(args: list[str], zygote=None, log: Path | None = None, ok: tuple[int, ...] = (0, 1)) -> float:
    """Run the command ``args`` to its end, in a fresh interpreter or, with ``zygote``
    (support/crash.py), in a process forked from it (``log``: its output); its wall time.
    ``ok``: the exit statuses accepted."""
    if zygote is None:
        return run(command(*args), ok=ok)
    t0 = time.monotonic()
    zygote.start_command(args, log=log)
    code = zygote.wait()
    if code not in ok:
        raise AssertionError(f"{' '.join(args)}: exit {code}\n{log.read_text()[-2000:]}")
    return time.monotonic() - t0


def kill_at(args: list[str], seconds: float, point: str | None, zygote=None,
            log: Path | None = None) -> int | None:
    """``kill_after`` for the command ``args`` (``point``: its named kill point, or None); with
    ``zygote``, the command is a process forked from it in a session of its own, which is killed
    with its whole group as a fresh interpreter is. The exit status, None if it ended first."""
    if zygote is None:
        return kill_after(command(*args), seconds, kill_env(point) if point else None)
    pid = zygote.start_command(args, kill=point or "", log=log)
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and child_running(pid):
        time.sleep(0.01)
    killed = child_running(pid)
    if killed:
        try:
            os.killpg(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    code = zygote.wait()
    if killed:
        _reap(pid)
        return -9
    return code if code != 0 else None


def kill_env(point: str) -> dict[str, str]:
    return {**os.environ, KILL_ENV: point}


def command(*args: str) -> list[str]:
    return [sys.executable, "-m", "bayes_dnlr", *args]


# ---------------------------------------------------------------- judging sets

def report_consistent(run_dir: Path) -> bool:
    """report.html and figures/ of one build: the figures are the images the page embeds."""
    page = run_dir / "report.html"
    figs = {base64.b64encode(p.read_bytes()).decode() for p in (run_dir / "figures").glob("*.png")}
    if not page.is_file():
        return not figs
    return set(_IMG.findall(page.read_text())) == figs


def batch_consistent(out: Path) -> bool:
    """The batch's table, page and figures of one run: the page embeds figures/batch_E.png, and its
    table shows every test with the status results.csv gives it."""
    page, table = out / "batch.html", out / "results.csv"
    if not page.is_file() or not table.is_file():
        return not page.is_file() and not table.is_file()
    text = page.read_text()
    embedded = set(_IMG.findall(text))
    fig = out / "figures" / "batch_E.png"
    if fig.is_file() and base64.b64encode(fig.read_bytes()).decode() not in embedded:
        return False
    rows = list(csv.DictReader(io.StringIO(table.read_text())))
    # the name in the table of all tests is a link to its report when the test has one
    return all(re.search(rf"<th>(?:<a [^>]*>)?{re.escape(r['name'])}(?:</a>)?</th><td class='text'>"
                         rf"{re.escape(r['status'])}</td>", text) for r in rows)


@dataclass
class Tally:
    """What the kills found."""

    kills: int = 0
    old: int = 0
    new: int = 0
    mixed: list[str] = field(default_factory=list)
    left_after_next_run: list[str] = field(default_factory=list)

    def line(self, what: str) -> str:
        return (f"{what}: {self.kills} kills; sets found old {self.old}, new {self.new}, mixed "
                f"{len(self.mixed)}; temporaries left after the next run: {len(self.left_after_next_run)}")


# ---------------------------------------------------------------- export

def export_args(run_dir: Path, out: Path, seed: int, draws: int) -> list[str]:
    return ["export", str(run_dir), "--format", "abaqus", "--nu", "0.45", "--draws", str(draws),
            "--seed", str(seed), "--out", str(out), "--force"]


def export_cmd(run_dir: Path, out: Path, seed: int, draws: int) -> list[str]:
    return command(*export_args(run_dir, out, seed, draws))


def export_kills(run_dir: Path, work: Path, draws: int, instants: int,
                 points: tuple[str, ...] = (), zygote=None) -> Tally:
    """Kill `export --draws` (new seed) over an old card set at ``instants`` evenly spread instants
    of its duration and at the named ``points``; after each kill the folder holds the old set or
    the new one, and after the next export no temporary is left. ``zygote``: the timed and the
    killed exports are forked from it (support/crash.py), not fresh interpreters."""
    target = work / "cards"
    ref_old, ref_new = work / "ref-old", work / "ref-new"
    run_here(export_args(run_dir, ref_old, 0, draws))
    duration = timed(export_args(run_dir, ref_new, 1, draws), zygote, work / "ref-new.log")
    old, new = files(ref_old), files(ref_new)
    assert old != new
    tally = Tally()
    cases = [(duration * (i + 0.5) / instants, None) for i in range(instants)]
    cases += [(duration * 3, p) for p in points]
    for k, (seconds, point) in enumerate(cases):
        if target.exists():
            shutil.rmtree(target)
        shutil.copytree(ref_old, target)
        kill_at(export_args(run_dir, target, 1, draws), seconds, point, zygote, work / f"kill{k}.log")
        tally.kills += 1
        recover_folder(target)                 # what the next export (or a reader) does first
        now = files(target) if target.is_dir() else {}
        if now == old:
            tally.old += 1
        elif now == new:
            tally.new += 1
        else:
            tally.mixed.append(f"{point or f'{seconds:.2f} s'}: {len(now)} files")
        run_here(export_args(run_dir, target, 1, draws))
        assert files(target) == new
        tally.left_after_next_run += leftovers(work)
    return tally


# ---------------------------------------------------------------- batch with reports

def _sets(out: Path) -> dict[str, dict[str, bytes]]:
    sets = {"batch": set_files(out, BATCH_SET)}
    for run_dir in sorted((out / "runs").iterdir()):
        sets[run_dir.name] = set_files(run_dir, REPORT_SET)
    return sets


def batch_kills(campaign: Path, batch_args: list[str], work: Path, instants: int,
                points: tuple[str, ...] = (), duration: float | None = None, zygote=None) -> Tally:
    """``campaign``: a folder whose batch (``batch_args``, --out inside it) has run once (the old
    sets) and whose inputs then changed. Kill the batch at ``instants`` instants of its duration and
    at ``points``, each time from a fresh copy of ``campaign``; judge every set (the batch's and
    each test's report) old or whole new; run the batch again and find nothing temporary.

    ``duration``: the seconds a whole run takes (the campaign's first run is as long: the same
    tests, fit, sample and reports, run the same way); None: a run on a copy measures it first.
    ``zygote``: the killed batches are forked from it (support/crash.py), not fresh interpreters
    (Zygote.start_command)."""
    out_rel = Path(batch_args[batch_args.index("--out") + 1]).relative_to(campaign)

    def args_in(root: Path) -> list[str]:
        return [a.replace(str(campaign), str(root)) for a in batch_args]

    if duration is None:
        probe = work / "probe"
        shutil.copytree(campaign, probe)
        duration = timed(args_in(probe), zygote, work / "probe.log")
        shutil.rmtree(probe)
    old = _sets(campaign / out_rel)
    tally = Tally()
    cases = [(duration * (i + 0.5) / instants, None) for i in range(instants)]
    cases += [(duration * 3, p) for p in points]
    for k, (seconds, point) in enumerate(cases):
        root = work / f"kill{k}"
        shutil.copytree(campaign, root)
        out = root / out_rel
        kill_at(args_in(root), seconds, point, zygote, work / f"kill{k}.log")
        tally.kills += 1
        recover(out, "batch", BATCH_SET)          # what the next batch (or a reader) does first
        for run_dir in (out / "runs").iterdir():
            recover(run_dir, "report", REPORT_SET)
        now = _sets(out)
        for name, content in now.items():
            consistent = batch_consistent(out) if name == "batch" else report_consistent(out / "runs" / name)
            if content == old.get(name):
                tally.old += 1
            elif consistent:
                tally.new += 1
            else:
                tally.mixed.append(f"{point or f'{seconds:.1f} s'}: {name}")
        # the next run: it finds the sets as the kill left them and leaves nothing temporary, which
        # does not depend on what its reports' figures show (a test report's figures: 1-2 s each)
        with pytest.MonkeyPatch.context() as mp:
            figures_not_drawn(mp)
            run_here(args_in(root))
        assert batch_consistent(out)
        tally.left_after_next_run += leftovers(root)
        shutil.rmtree(root)
    return tally


def campaign(folder: Path, tests: int, zygote=None) -> tuple[Path, list[str], float]:
    """A manifest batch with reports, run once (``zygote``: in a process forked from it); then new
    seeds (the runs' inputs changed). The folder, the arguments of the next run and the seconds
    the first one took."""
    template, manifest = tiny_campaign(folder, tests, points=150)
    args = ["batch", str(template), "--manifest", str(manifest), "--out", str(folder / "out"),
            "--jobs", str(min(tests, 2)), "--quiet", "--no-population"]
    seconds = timed(args, zygote, folder.parent / f"{folder.name}.log", ok=(0,))
    rows = list(csv.DictReader(open(manifest)))
    for r in rows:
        r["sampler.seed"] = str(int(r["sampler.seed"]) + 10)
    with open(manifest, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return folder, [*args, "--restart"], seconds
