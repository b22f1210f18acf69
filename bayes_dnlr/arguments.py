"""What a command's path argument means: a config file or a run folder, whichever the user gave.

A config names its run folder (``Config.run_dir``: the config's own folder when the folder is named
after the run), so the commands that work on a finished run (report, compare, export) also take the
config, and those that start from a config (simulate, fit, sample) also take a run folder that holds
the config the user wrote. Where a form cannot work the error says what is expected, with an example.
"""

from __future__ import annotations

from pathlib import Path

from bayes_dnlr.config import ConfigError, load_config
from bayes_dnlr.config.yamlio import YamlError, load_yaml
from bayes_dnlr.errors import RunError
from bayes_dnlr.runs.layout import (
    CHAINS_FILE,
    RESOLVED_CONFIG,
    RESOLVED_CONFIG_BESIDE_SOURCE,
    RESULT_FILES,
)

EXAMPLE_RUN = "runs/hdpe-a-5e-3"
CONFIG_SUFFIXES = (".yaml", ".yml")


def _is_written_copy(folder: Path) -> bool:
    """True when ``folder/config.yaml`` is the resolved copy that fit/sample wrote into the run
    folder of a config kept elsewhere (``output: {dir: .}`` and no config.resolved.yaml beside it),
    not a config the user wrote."""
    if (folder / RESOLVED_CONFIG_BESIDE_SOURCE).is_file():
        return False
    try:
        raw = load_yaml(folder / RESOLVED_CONFIG)
    except YamlError:       # unreadable, not UTF-8, not YAML: not a copy the package wrote
        return False
    return isinstance(raw, dict) and raw.get("output") == {"dir": "."}


def config_file(arg: str | Path, command: str) -> Path:
    """The config file for ``command`` (simulate, fit, sample): ``arg`` itself, or the config.yaml
    the user wrote in the run folder ``arg``."""
    p = Path(arg)
    if p.is_file():
        return p
    example = f"{p}/config.yaml" if p.suffix not in CONFIG_SUFFIXES else f"{EXAMPLE_RUN}/config.yaml"
    if p.is_dir():
        own = p / RESOLVED_CONFIG
        if own.is_file() and not _is_written_copy(p):
            return own
        what = (f"{own} is the copy that fit/sample wrote (the config as resolved), not the config "
                "you wrote: give that one" if own.is_file() else f"{p} is a directory with no config.yaml")
        raise ConfigError(f"{p}: {command} takes the config file, e.g. {example}; {what}")
    raise ConfigError(f"{p}: config file not found ({command} takes the config file, e.g. {example})")


def _release(folder: Path) -> None:
    """A chain left "open for write" by a killed `sample`: plain h5py reads it again (runs/chains.py)."""
    from bayes_dnlr.runs.chains import release_stale_writer

    release_stale_writer(folder / CHAINS_FILE)


def _named_run(folder: Path) -> Path | None:
    """The run folder that the config the user wrote in ``folder`` names, when it is another folder
    and ``folder`` itself holds no results (a config whose ``name:`` differs from its folder's
    writes into ``folder/<name>``); None otherwise."""
    if any((folder / name).exists() for name in (*RESULT_FILES, CHAINS_FILE)):
        return None
    own = folder / RESOLVED_CONFIG
    if not own.is_file() or _is_written_copy(folder):
        return None
    try:
        named = load_config(own).run_dir
    except ConfigError:
        return None              # the command itself says what is wrong with the folder
    return named if named.resolve() != folder.resolve() else None


def run_folder(arg: str | Path, command: str) -> Path:
    """The run folder for ``command`` (report, compare, export): ``arg`` itself, or the folder the
    config file ``arg`` names. A folder holding no results but the config the user wrote is
    taken as that config: both forms name the same run."""
    p = Path(arg)
    if p.is_dir():
        named = _named_run(p)
        if named is not None:
            p = Path(named)
            if not p.is_dir():
                raise RunError(f"{arg}: holds no results, and its config.yaml writes them into {p}, "
                               f"which does not exist yet: run `python -m bayes_dnlr sample "
                               f"{Path(arg) / RESOLVED_CONFIG}` first")
        _release(p)
        return p
    expected = (f"{command} takes a run folder or its config file, e.g. {EXAMPLE_RUN} or "
                f"{EXAMPLE_RUN}/config.yaml")
    if p.is_file() and p.suffix in CONFIG_SUFFIXES:
        folder = load_config(p).run_dir
        if not folder.is_dir():
            raise RunError(f"{p}: its run folder {folder} does not exist yet: run "
                           f"`python -m bayes_dnlr sample {p}` first")
        _release(folder)
        return folder
    if p.is_file():
        raise RunError(f"{p}: not a run folder or a config file (.yaml); {expected}")
    raise RunError(f"{p}: no such run folder or config file; {expected}")
