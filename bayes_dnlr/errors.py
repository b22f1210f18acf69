"""Errors a user can act on. The CLI prints their message (no traceback) and exits with 2."""


class BayesDnlrError(Exception):
    """Base of every error caused by input, config or run state (not by a bug)."""


class RunError(BayesDnlrError):
    """A run directory is in a state that forbids the action (e.g. a result would be overwritten)."""


class StaleRunError(RunError):
    """A run directory holds a fit or a chain made from another config or data (or one that cannot
    be continued): ``sample --restart`` (``batch --restart``) discards it and starts again."""


class DamagedFileError(StaleRunError):
    """A file the package wrote into a run folder cannot be read back: cut, its bytes changed on
    disk, or another program's file put in its place. The message names the file, what is damaged
    and what can still be read (readback.py)."""


class StorageError(BayesDnlrError):
    """A file could not be written (I/O error, read-only or full file system); nothing committed
    before was lost."""


class DiskFullError(StorageError):
    """The file system holding an output is full (ENOSPC) or the user's quota is used up (EDQUOT)."""
