"""Outputs made of several files, published whole: a killed command leaves the old set or the new one,
never a mix, and no temporary after the next run.

Two ways, by where the set lives:

- **A folder of its own** (``export``'s card set): written into ``.<folder>.<pid>.tmp`` beside it,
  then swapped with the old folder in one step (Linux ``renameat2(RENAME_EXCHANGE)``; elsewhere
  two renames, the old folder parked as ``.<folder>.<pid>.old`` and put back by ``recover_folder``
  when a kill fell between them).
- **Files among others** (a run's ``report.html`` and ``figures/``, a batch's results table, page
  and population files): ``publishing(folder, name, patterns)`` brackets the writes. It first keeps
  the set's current files as hard links in ``.<name>.<pid>.before/`` and then writes a journal,
  ``.<name>.<pid>.publishing``; the writers replace files atomically (a new inode: the kept link
  still holds the old bytes); at the end the journal is removed (the commit) and the kept links
  after it. ``recover`` (called by the next command on the folder, and by readers that judge a
  set, before they look) rolls back a set whose journal is still there: its kept files return,
  files it added go. So a kill at any instant leaves the old set (journal present, or the new set
  not started) or the new one (journal gone).

The kill points of tests/test_fileset.py are named ``fileset.*`` (diskio.kill_point).
"""

from __future__ import annotations

import ctypes
import errno
import json
import os
import shutil
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from bayes_dnlr.diskio import fsync_dir, kill_point, own_dir, process_alive, storage_error

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2
_NO_EXCHANGE = {errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV}


def _pid_of(name: str, prefix: str, suffix: str) -> int | None:
    """The pid in ``<prefix><pid><suffix>``, else None."""
    if not (name.startswith(prefix) and name.endswith(suffix)):
        return None
    pid = name[len(prefix):len(name) - len(suffix)]
    return int(pid) if pid.isdigit() else None


def _dead(pid: int | None) -> bool:
    return pid is not None and pid != os.getpid() and not process_alive(pid)


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


# ---------------------------------------------------------------- a folder of its own

def _exchange(a: Path, b: Path) -> bool:
    """Swap the paths ``a`` and ``b`` in one step; False where the system cannot (then nothing moved)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in _NO_EXCHANGE:
        return False
    raise OSError(code, os.strerror(code), str(b))


def recover_folder(target: Path) -> None:
    """After a kill: put back a parked old folder whose replacement never arrived, and remove the
    temporaries and parked folders of dead writers."""
    target = Path(target)
    parent = target.parent
    try:
        entries = list(parent.iterdir())
    except OSError:
        return
    for p in entries:
        old = _pid_of(p.name, f".{target.name}.", ".old")
        if _dead(old):
            if not target.exists():
                os.replace(p, target)          # killed between the two renames: the old set back
            else:
                _remove(p)
        if _dead(_pid_of(p.name, f".{target.name}.", ".tmp")):
            _remove(p)


@contextmanager
def folder_set(target: Path) -> Iterator[Path]:
    """Write a set of files into the yielded empty folder; when the block ends without an error it
    becomes ``target`` in one step (the old ``target``, if any, goes with everything in it)."""
    target = Path(target)
    recover_folder(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    _remove(tmp)
    tmp.mkdir()
    try:
        yield tmp
        for p in tmp.rglob("*"):               # the files' bytes on disk before they are named
            if p.is_file():
                with open(p, "rb") as f:
                    os.fsync(f.fileno())
        kill_point("fileset.folder.written")
        if not target.exists():
            os.replace(tmp, target)
        elif _exchange(tmp, target):
            kill_point("fileset.folder.exchanged")
            _remove(tmp)                       # now the old set
        else:
            old = target.with_name(f".{target.name}.{os.getpid()}.old")
            os.replace(target, old)
            kill_point("fileset.folder.parked")
            os.replace(tmp, target)
            _remove(old)
        fsync_dir(target.parent)
    except BaseException as err:
        _remove(tmp)
        clean = storage_error(err, target, "the previous files, if any, are unchanged")
        if clean is not None:
            raise clean from None
        raise


# ---------------------------------------------------------------- files among others

def _through_link(folder: Path, p: Path) -> bool:
    """True when a folder between ``folder`` and its file ``p`` is a symbolic link."""
    return any((folder / q).is_symlink() for q in p.relative_to(folder).parents if q != Path("."))


def _members(folder: Path, patterns: Iterable[str]) -> list[str]:
    """The set's files in ``folder`` (relative paths; patterns as Path.glob, e.g. figures/*.png),
    none through a symbolic link (a linked figures/ holds none of them: it is replaced)."""
    found: set[str] = set()
    for pattern in patterns:
        found.update(str(p.relative_to(folder)) for p in folder.glob(pattern)
                     if p.is_file() and not p.name.startswith(".") and not _through_link(folder, p))
    return sorted(found)


def _own_subfolders(folder: Path, patterns: Iterable[str]) -> None:
    """The subfolders of the set (figures/ of figures/*.png): real folders, not links (diskio.own_dir)."""
    for pattern in patterns:
        parent = Path(pattern).parent
        if parent != Path(".") and not any(c in str(parent) for c in "*?["):
            own_dir(folder / parent, make=False)


def _sweep_temps(folder: Path, patterns: Iterable[str]) -> None:
    """Temporaries (``.<file>.<pid>.tmp``) of dead writers in the folders the set's files live in."""
    dirs = {folder} | {(folder / p).parent for p in patterns}
    for d in dirs:
        try:
            entries = list(d.iterdir())
        except OSError:
            continue
        for p in entries:
            if p.name.startswith(".") and p.name.endswith(".tmp") and p.is_file():
                pid = p.name[:-len(".tmp")].rsplit(".", 1)[-1]
                if pid.isdigit() and _dead(int(pid)):
                    p.unlink(missing_ok=True)


def _journals(folder: Path, name: str) -> list[Path]:
    try:
        return sorted(p for p in folder.iterdir() if _pid_of(p.name, f".{name}.", ".publishing"))
    except OSError:
        return []


def _roll_back(folder: Path, journal: Path) -> None:
    try:
        record = json.loads(journal.read_text())
    except (OSError, ValueError):
        record = None
    if isinstance(record, dict):
        kept = folder / str(record["kept"])
        before = set(record["files"])
        for rel in _members(folder, record["patterns"]):
            if rel not in before:
                (folder / rel).unlink(missing_ok=True)      # new to the set
        for rel in before:
            src = kept / rel
            if src.exists():
                (folder / rel).parent.mkdir(parents=True, exist_ok=True)
                os.replace(src, folder / rel)
        fsync_dir(folder)
    journal.unlink(missing_ok=True)


def recover(folder: Path, name: str, patterns: Iterable[str] = ()) -> None:
    """Roll back the set ``name`` of ``folder`` if a writer was killed while publishing it, and
    remove what dead writers left (kept links, temporaries). A live writer's files are left alone."""
    folder = Path(folder)
    for journal in _journals(folder, name):
        if _dead(_pid_of(journal.name, f".{name}.", ".publishing")):
            _roll_back(folder, journal)
    try:
        entries = list(folder.iterdir())
    except OSError:
        return
    for p in entries:                       # kept links without a journal: that set was committed
        if _dead(_pid_of(p.name, f".{name}.", ".before")):
            _remove(p)
    _sweep_temps(folder, patterns)


def _discard_created(folder: Path, created: bool) -> None:
    if created:
        try:
            folder.rmdir()                   # a folder this call made for a set that never came
        except OSError:
            pass


@contextmanager
def publishing(folder: Path, name: str, patterns: list[str]) -> Iterator[None]:
    """The files of ``folder`` matching ``patterns`` change as one set inside the block (see the
    module doc). Writers must replace files atomically (runs.folder.write_atomic, os.replace of a
    temporary). An error in the block puts the old set back and is raised."""
    folder = Path(folder)
    created = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    _own_subfolders(folder, patterns)
    recover(folder, name, patterns)
    pid = os.getpid()
    kept = folder / f".{name}.{pid}.before"
    journal = folder / f".{name}.{pid}.publishing"
    tmp = folder / f".{name}.publishing.{pid}.tmp"
    _remove(kept)
    files = _members(folder, patterns)
    try:
        for rel in files:
            (kept / rel).parent.mkdir(parents=True, exist_ok=True)
            try:
                os.link(folder / rel, kept / rel)
            except OSError:                  # a file system without hard links
                shutil.copy2(folder / rel, kept / rel)
        kill_point("fileset.kept")
        tmp.write_text(json.dumps({"kept": kept.name, "files": files, "patterns": list(patterns)}))
        os.replace(tmp, journal)
        fsync_dir(folder)
    except OSError as err:                   # e.g. a full disk: nothing of the set changed yet
        _remove(kept)
        tmp.unlink(missing_ok=True)
        _discard_created(folder, created)
        raise (storage_error(err, journal, "the previous files are unchanged") or err) from None
    try:
        yield
    except BaseException:
        _roll_back(folder, journal)
        _remove(kept)
        _discard_created(folder, created)
        raise
    kill_point("fileset.written")
    fsync_dir(folder)
    journal.unlink()                         # the commit
    kill_point("fileset.committed")
    _remove(kept)
