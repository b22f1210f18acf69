"""``population`` as a run: specimens of one material as a population, from their finished runs.

    python -m bayes_dnlr population runs/population/spec-*

Stage 1 is each specimen's own run (``fit`` and ``sample``, or ``batch``); stage 2 reweights their
posterior draws of E under E_k ~ Normal(μ_E, s_E) (inference/analyses/population.py). The result,
population.json, goes into the folder that holds the runs (or ``out``); it records which runs (and
which of their posteriors, by fingerprint) it was made from, so a population.json made from other
runs is never replaced silently (``force``).
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bayes_dnlr.config import ConfigError, load_config
from bayes_dnlr.errors import RunError
from bayes_dnlr.inference.analyses.population import Population, population
from bayes_dnlr.inference.posterior.priors import Prior
from bayes_dnlr.runs.draws import load_run_draws
from bayes_dnlr.runs.folder import find_config, write_json
from bayes_dnlr.runs.layout import SUMMARY_FILE

POPULATION_FILE = "population.json"


@dataclass
class PopulationRun:
    """The population of a set of finished runs, and where it was written."""

    result: Population
    runs: dict[str, str]                  # specimen name -> run directory, relative to out_dir
    fingerprints: dict[str, str]          # specimen name -> its posterior's fingerprint
    truth: dict[str, float] = field(default_factory=dict)    # synthetic specimens: the true values
    out_dir: Path = Path(".")
    wall_time_s: float = 0.0
    written: list[Path] = field(default_factory=list)
    made_by: str = "population"           # or "batch": a batch may replace its own population.json

    def to_dict(self) -> dict[str, Any]:
        from bayes_dnlr import __version__

        return {**self.result.to_dict(), "runs": self.runs, "fingerprints": self.fingerprints,
                "truth": self.truth or None, "wall_time_s": self.wall_time_s, "made_by": self.made_by,
                "version": __version__}


def default_out_dir(run_dirs: list[Path]) -> Path:
    """The folder that holds the runs (their common folder)."""
    parents = {d.resolve().parent for d in run_dirs}
    return parents.pop() if len(parents) == 1 else Path(os.path.commonpath([str(p) for p in parents]))


def _specimen(run_dir: Path, parameter: str) -> tuple[str, Any, Prior, str, float | None]:
    """(name, draws, prior, fingerprint, true value) of one finished run."""
    draws = load_run_draws(run_dir, key="population")
    if parameter not in draws.values:
        joint = " (a run with tests: shares E across its tests; run each specimen alone)" \
            if any("[" in k for k in draws.values) else ""
        raise RunError(f"population: {run_dir} has no posterior draws of {parameter}{joint}")
    try:
        cfg = load_config(find_config(run_dir))
    except (FileNotFoundError, ConfigError) as err:
        raise RunError(f"population: {run_dir}: its config cannot be read ({err})") from None
    spec = cfg.parameters.get(parameter)
    if spec is None or spec.fixed:
        raise RunError(f"population: {run_dir}: {parameter} is fixed in its config: nothing to pool")
    truth = cfg.truth.params.get(parameter) if cfg.truth is not None else None
    name = str(draws.summary.get("name") or cfg.name)
    return (name, draws.values[parameter], Prior.from_spec(parameter, spec), str(
        draws.summary.get("fingerprint") or ""), truth)


def _check_dirs(dirs: list[Path]) -> None:
    if len(dirs) < 2:
        raise RunError(f"population needs at least two specimens' run directories, got {len(dirs)}")
    seen: dict[Path, Path] = {}
    for d in dirs:
        r = d.resolve()
        if r in seen:
            raise RunError(f"population: {d} is given twice (as {seen[r]} too)")
        seen[r] = d


def run_population(run_dirs: list[Path | str], *, parameter: str = "E", out: Path | str | None = None,
                   force: bool = False, write: bool = True, made_by: str = "population") -> PopulationRun:
    """Pool the finished runs ``run_dirs`` (≥ 2 specimens); write ``out/population.json``."""
    dirs = [Path(d) for d in run_dirs]
    _check_dirs(dirs)
    t0 = time.perf_counter()
    out_dir = Path(out) if out is not None else default_out_dir(dirs)
    draws, priors, runs, fps, truth = {}, {}, {}, {}, {}
    for d in dirs:
        name, x, prior, fp, true = _specimen(d, parameter)
        if name in draws:
            raise RunError(f"population: {d} and {runs[name]} are both named {name!r}; every specimen "
                           "needs its own run name")
        draws[name], priors[name], fps[name] = x, prior, fp
        runs[name] = os.path.relpath(d.resolve(), out_dir.resolve())
        if true is not None:
            truth[name] = float(true)
    result = population(draws, priors, parameter=parameter)
    pr = PopulationRun(result, runs, fps, truth, out_dir, time.perf_counter() - t0, made_by=made_by)
    if write:
        path = out_dir / POPULATION_FILE
        _check_replace(path, pr, force)
        out_dir.mkdir(parents=True, exist_ok=True)
        write_json(path, pr.to_dict())
        pr.written.append(path)
    return pr


def read_existing(path: Path) -> dict[str, Any]:
    """The population.json at ``path`` ({} when missing or unreadable)."""
    try:
        old = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError, UnicodeDecodeError):
        return {}
    return old if isinstance(old, dict) else {}


def same_inputs(old: dict[str, Any], runs: dict[str, str], fingerprints: dict[str, str],
                parameter: str) -> bool:
    """Was ``old`` (a population.json) made from these runs, these posteriors of them, this
    parameter? Then a new one would be the same."""
    return (bool(old) and old.get("fingerprints") == fingerprints and old.get("parameter") == parameter
            and old.get("runs") == runs)


def current_population(run_dirs: list[Path | str], *, parameter: str = "E",
                       out: Path | str | None = None) -> dict[str, Any] | None:
    """The population.json in ``out`` when it was made from exactly these finished runs (the same
    posteriors: their fingerprints in summary.json), else None. Reads summary.json only, no draws."""
    dirs = [Path(d) for d in run_dirs]
    out_dir = Path(out) if out is not None else default_out_dir(dirs)
    old = read_existing(out_dir / POPULATION_FILE)
    if not old:
        return None
    runs, fps = {}, {}
    for d in dirs:
        try:
            summary = json.loads((d / SUMMARY_FILE).read_text())
            name = str(summary.get("name") or load_config(find_config(d)).name)
        except (OSError, ValueError, FileNotFoundError, ConfigError):
            return None
        runs[name] = os.path.relpath(d.resolve(), out_dir.resolve())
        fps[name] = str(summary.get("fingerprint") or "")
    return old if same_inputs(old, runs, fps, parameter) else None


def _check_replace(path: Path, pr: PopulationRun, force: bool) -> None:
    """A population.json made from other runs (or other posteriors of them) is replaced only with
    ``force``."""
    if force or not path.exists():
        return
    if not same_inputs(read_existing(path), pr.runs, pr.fingerprints, pr.result.parameter):
        raise RunError(f"{path} exists and was made from other runs or other posteriors of them; pass "
                       "--force to replace it, or --out to write elsewhere")
