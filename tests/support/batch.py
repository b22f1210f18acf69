"""Tiny synthetic tests for the batch tests: a template config and a manifest of data files."""

from __future__ import annotations

import csv
from pathlib import Path

import yaml

from support.sampling import write_case

# under a second of sampling per test: 250 points, 16 walkers, 200 steps, checkpoints every 50
# steps. The batch tests are about the batch, not the chains: these rarely converge (ESS 100 would
# take about 600 steps) and need not (a chain stopped at max_steps is an ok test)
TINY = {"walkers": 16, "max_steps": 200, "target_ess": 100, "checkpoint_every": 50}


LONG_STEPS = 600     # a test that never converges: long enough to be killed midway, no longer

# fewer still, for the tests of what a batch does with finished runs (reuse, restart, the population
# step, the rerun of one test), which read no chain's numbers: 8 walkers x 20 steps, a twentieth of
# TINY's draws (its fit and outputs left, a test costs a third)
FEW = {"walkers": 8, "max_steps": 20, "checkpoint_every": 10}


def tiny_campaign(folder: Path, n: int, *, long: set[int] = frozenset(),
                  points: int = 250, sampler: dict | None = None,
                  params: dict[int, dict] | None = None) -> tuple[Path, Path]:
    """``n`` data files (different noise seeds) in folder/data, a template config and a manifest
    (name, data.file, sampler.seed); tests in ``long`` never converge and run to LONG_STEPS steps.
    ``sampler``: keys over TINY's in the template (FEW: a shorter chain); ``params``: test index ->
    the true parameters of its data (the default synthetic specimen's else)."""
    data = folder / "data"
    data.mkdir(parents=True, exist_ok=True)
    rows = []
    sampler = {**TINY, **(sampler or {})}
    for i in range(n):
        cfg = write_case(folder / "cases", f"t{i}", n=points, seed=100 + i, sampler=sampler,
                         params=(params or {}).get(i))
        (cfg.parent / "data.csv").replace(data / f"t{i}.csv")
        row = {"name": f"t{i}", "data.file": f"data/t{i}.csv", "sampler.seed": str(i + 1),
               "sampler.max_steps": "", "sampler.target_ess": ""}
        if i in long:
            row["sampler.max_steps"], row["sampler.target_ess"] = str(LONG_STEPS), "1e9"
        rows.append(row)
    raw = yaml.safe_load(cfg.read_text())
    raw["name"] = "template"
    raw["data"]["file"] = "data/t0.csv"
    template = folder / "template.yaml"
    template.write_text(yaml.safe_dump(raw, sort_keys=False))
    manifest = folder / "manifest.csv"
    with open(manifest, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return template, manifest
