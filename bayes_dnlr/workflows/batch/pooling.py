"""Which tests of a finished batch feed its population step, and what that step did.

After a batch, the tests that are ok, each one specimen (a single-test run, not a run with
``tests:``) with E sampled, are pooled by the two-stage population method (workflows/population/run.py,
docs/population.md), one population per material, into ``<out>/population.json`` (and .md, .png by
the report layer). The others are excluded, each with its reason. A material with fewer than
``MIN_TESTS`` such tests is not pooled; with none that has them, the step is skipped.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bayes_dnlr.config import ConfigError, load_config
from bayes_dnlr.runs.folder import find_config
from bayes_dnlr.runs.testset import plain_names
from bayes_dnlr.workflows.population.run import UNLABELLED

MIN_TESTS = 3
PARAMETER = "E"


@dataclass
class PopulationStep:
    """The population step of a batch.

    status: ``done`` (computed now), ``reused`` (population.json already made from these very runs
    and posteriors), ``skipped`` (fewer than MIN_TESTS usable tests), ``off`` (``--no-population``),
    ``failed`` (an error: the batch itself still succeeds)."""

    status: str
    note: str
    used: dict[str, str] = field(default_factory=dict)        # test name -> run directory
    excluded: dict[str, str] = field(default_factory=dict)    # test name -> why it is left out
    data: dict[str, Any] | None = None                        # population.json's content
    files: list[Path] = field(default_factory=list)           # population.json, .md, .png
    wall_time_s: float = 0.0

    def line(self) -> str:
        """One line for the console summary."""
        head = f"population ({self.status}): {self.note.rstrip('.')}"
        if self.excluded and self.status in ("done", "reused"):
            head += f"; left out: {', '.join(self.excluded)}"
        return head + "."


def _excluded_reason(row: dict[str, Any]) -> str | None:
    """Why an ok test cannot be a specimen of the population (None: it can)."""
    run_dir = row.get("run_dir")
    if not run_dir:
        return "no run directory"
    try:
        cfg = load_config(find_config(Path(run_dir)))
    except (OSError, FileNotFoundError, ConfigError) as err:
        return f"its config cannot be read ({err})"
    if not plain_names(cfg):
        return "a run with tests: (one E shared by several tests, not one specimen)"
    spec = cfg.parameters.get(PARAMETER)
    if spec is None or spec.fixed:
        return f"{PARAMETER} is fixed in its config"
    if row.get(f"{PARAMETER}_mean") is None:
        return f"no posterior of {PARAMETER}"
    return None


def select(rows: list[dict[str, Any]]) -> tuple[dict[str, str], dict[str, str]]:
    """(usable tests: name -> run directory, excluded tests: name -> reason), in input order."""
    used, excluded = {}, {}
    for r in rows:
        status = r.get("status")
        if status == "failed":
            excluded[r["name"]] = f"failed ({r.get('error')})"
            continue
        if status != "ok":
            excluded[r["name"]] = "not run"
            continue
        why = _excluded_reason(r)
        if why is None:
            used[r["name"]] = str(r["run_dir"])
        else:
            excluded[r["name"]] = why
    return used, excluded


def group_sizes(rows: list[dict[str, Any]], used: dict[str, str]) -> dict[str, int]:
    """The usable tests per material (the rows' ``material``; UNLABELLED without one)."""
    sizes: dict[str, int] = {}
    for r in rows:
        if r["name"] in used:
            label = r.get("material") or UNLABELLED
            sizes[label] = sizes.get(label, 0) + 1
    return sizes
