"""``population`` as a run: specimens of one material as a population, from their finished runs.

    python -m bayes_dnlr population runs/population/spec-*

Stage 1 is each specimen's own run (``fit`` and ``sample``, or ``batch``); stage 2 reweights their
posterior draws of E under E_k ~ Normal(μ_E, s_E) (inference/analyses/population.py), one population
per material (the configs' ``material:``), each after the check that its tests look like one
material (inference/analyses/heterogeneity.py) on E(t) at a time every test resolves
(runs/modulus_across.py; E where there is none); each specimen's own verdict (runs/trust.py)
travels into the population's warnings. The result,
population.json, goes into the folder that holds the runs (or ``out``); it records which runs (and
which of their posteriors, by fingerprint) it was made from, so a population.json made from other
runs is never replaced silently (``force``).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bayes_dnlr.config import ConfigError, load_config
from bayes_dnlr.errors import DamagedFileError, RunError
from bayes_dnlr.inference.analyses import heterogeneity
from bayes_dnlr.inference.analyses.agreement import agreement
from bayes_dnlr.inference.analyses.population import Population, population
from bayes_dnlr.inference.posterior.priors import Prior
from bayes_dnlr.readback import read_json
from bayes_dnlr.runs.draws import load_run_draws
from bayes_dnlr.runs.folder import find_config, write_json
from bayes_dnlr.runs.layout import SUMMARY_FILE
from bayes_dnlr.runs.modulus_across import at_common_time
from bayes_dnlr.runs.modulus_view import entries
from bayes_dnlr.runs.trust import run_trust, trusted_count

POPULATION_FILE = "population.json"
UNLABELLED = "(no material given)"      # the group of the runs whose config has no material:
NOT_ONE = "not one material: "          # the warning of a failed heterogeneity check


@dataclass
class PopulationRun:
    """The populations of a set of finished runs (one per material), and where they were written."""

    results: dict[str, Population]        # material (or UNLABELLED) -> its population
    runs: dict[str, str]                  # specimen name -> run directory, relative to out_dir
    fingerprints: dict[str, str]          # specimen name -> its posterior's fingerprint
    truth: dict[str, float] = field(default_factory=dict)    # synthetic specimens: the true values
    out_dir: Path = Path(".")
    wall_time_s: float = 0.0
    written: list[Path] = field(default_factory=list)
    made_by: str = "population"           # or "batch": a batch may replace its own population.json
    materials: dict[str, str | None] = field(default_factory=dict)   # specimen -> its material
    members: dict[str, dict[str, Any]] = field(default_factory=dict)  # specimen -> runs/trust.py
    skipped: dict[str, str] = field(default_factory=dict)   # material -> why it has no population
    between: dict[str, Any] | None = None  # several materials: analyses/heterogeneity.between_groups
    modulus: dict[str, dict[str, Any]] = field(default_factory=dict)  # material -> its pooled E(t)

    @property
    def grouped(self) -> bool:
        """Runs of more than one material: population.json has one entry per material."""
        return len(set(self.materials.values())) > 1

    @property
    def result(self) -> Population:
        """The population of a set of runs of one material."""
        if len(self.results) != 1:
            raise ValueError(f"{len(self.results)} populations (one per material): read .results")
        return next(iter(self.results.values()))

    def trusted(self, names: list[str]) -> dict[str, Any]:
        """How many of ``names`` their own checks trust: ``k`` of ``n`` (those with a verdict), the
        names of the others, and the same for E(t) at its first time (where the runs have it)."""
        flags = {k: (self.members.get(k) or {}).get("trust_interval") for k in names}
        et = {k: ((self.members.get(k) or {}).get("Et") or {}).get("trust") for k in names}
        k, n = trusted_count(list(flags.values()))
        ke, ne = trusted_count(list(et.values()))
        return {"k": k, "n": n, "untrusted": [a for a, f in flags.items() if f is False],
                "Et": {"k": ke, "n": ne} if ne else None}

    def group_dict(self, label: str) -> dict[str, Any]:
        pop = self.results[label]
        return {**pop.to_dict(), "material": None if label == UNLABELLED else label,
                "trusted": self.trusted(pop.names), "modulus_at": self.modulus.get(label)}

    def to_dict(self) -> dict[str, Any]:
        from bayes_dnlr import __version__

        common = {"runs": self.runs, "fingerprints": self.fingerprints, "materials": self.materials,
                  "members": self.members, "truth": self.truth or None,
                  "wall_time_s": self.wall_time_s, "made_by": self.made_by, "version": __version__}
        if not self.grouped:
            return {**self.group_dict(next(iter(self.results))), **common}
        names = [k for label in self.results for k in self.results[label].names]
        parameter = next(iter(self.results.values())).parameter
        return {"parameter": parameter, "specimens": names,
                "groups": {label: self.group_dict(label) for label in self.results},
                "skipped_groups": self.skipped, "heterogeneity": self.between,
                "warnings": [f"{label}: {w}" for label, p in self.results.items() for w in p.warnings]
                + [f"{label}: not pooled: {why}" for label, why in self.skipped.items()],
                **common}


def default_out_dir(run_dirs: list[Path]) -> Path:
    """The folder that holds the runs (their common folder)."""
    parents = {d.resolve().parent for d in run_dirs}
    return parents.pop() if len(parents) == 1 else Path(os.path.commonpath([str(p) for p in parents]))


@dataclass
class Specimen:
    """One finished run as a specimen: its draws of the parameter, the prior they were drawn
    under, what its run reports (summary.json), its material and true value."""

    name: str
    draws: Any
    prior: Prior
    fingerprint: str
    truth: float | None
    material: str | None
    own: dict[str, float] | None       # summary.json's posterior mean and sd of the parameter
    trust: dict[str, Any]              # runs/trust.py run_trust
    modulus: list[dict[str, Any]]      # summary.json's modulus_at: E(t) at its times


def _specimen(run_dir: Path, parameter: str) -> Specimen:
    """One finished run as a specimen of the population."""
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
    post = (draws.summary.get("posterior") or {}).get(parameter) or {}
    own = ({"mean": float(post["mean"]), "sd": float(post["sd"])}
           if post.get("mean") is not None and post.get("sd") else None)
    return Specimen(name, draws.values[parameter], Prior.from_spec(parameter, spec),
                    str(draws.summary.get("fingerprint") or ""), truth, cfg.material, own,
                    run_trust(draws.summary), list(entries(draws.summary).get("") or []))


def _check_dirs(dirs: list[Path]) -> None:
    if len(dirs) < 2:
        raise RunError(f"population needs at least two specimens' run directories, got {len(dirs)}")
    seen: dict[Path, Path] = {}
    for d in dirs:
        r = d.resolve()
        if r in seen:
            raise RunError(f"population: {d} is given twice (as {seen[r]} too)")
        seen[r] = d


def member_warnings(specimens: list[Specimen]) -> list[str]:
    """The population's warnings from its members' own verdicts: one per specimen whose checks do
    not trust E's interval (or whose E(t) at its first time is not trusted)."""
    out = []
    for sp in specimens:
        t = sp.trust
        if t.get("trust_interval") is False:
            fired = ", ".join(t.get("checks_fired") or []) or "see its report"
            out.append(f"{sp.name}: its own checks do not trust E's interval: {t.get('verdict')} "
                       f"(checks: {fired})")
        et = t.get("Et") or {}
        if et.get("trust") is False:
            out.append(f"{sp.name}: its E(t) at t = {et.get('t_s')} s is not trusted by its own checks")
    return out


def one_material(members: list[Specimen], parameter: str,
                 labelled: bool) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """The check before pooling ``members`` (inference/analyses/heterogeneity.py) on their E(t) at
    the time every one resolves (runs/modulus_across.py), else on their own ``parameter`` with the
    reason; and their pooled E(t) there (the random-effects mean, its sd and the spread τ between
    them; None without a common time)."""
    at = at_common_time({m.name: m.modulus for m in members})
    names = [m.name for m in members]
    if at.t is None:
        own = {m.name: m.own or {} for m in members}
        return heterogeneity.one_material(
            names, [own[k].get("mean", math.nan) for k in names], [own[k].get("sd", math.nan)
                                                                   for k in names],
            labelled=labelled, quantity=parameter, note=f"E(t) not compared: {at.why}"), None
    check = heterogeneity.one_material(names, [at.values()[k] for k in names],
                                       [at.sds()[k] for k in names], labelled=labelled,
                                       quantity=at.quantity)
    if check.get("random_effects") is None:
        return check, None
    return check, {"t": at.t, "quantity": at.quantity, **check["random_effects"],
                   "tau": check["tau"], "n": len(names), "agree": check["passed"]}


def _between(results: dict[str, Population], members: list[list[Specimen]],
             parameter: str) -> dict[str, Any]:
    """The materials against each other: their pooled E(t) at a time every test of every one
    resolves, else their populations' μ of ``parameter``."""
    at = at_common_time({m.name: m.modulus for group in members for m in group})
    if at.t is not None:
        pooled = {}
        for label, group in zip(results, members, strict=True):
            a = agreement(at.quantity, {m.name: at.values()[m.name] for m in group},
                          {m.name: at.sds()[m.name] for m in group})
            if a is not None:
                pooled[label] = (a.re_mean, a.re_sd)
        if len(pooled) == len(results):
            return heterogeneity.between_groups(pooled, quantity=at.quantity)
    return heterogeneity.between_groups({label: (p.mu["mean"], p.mu["sd"])
                                         for label, p in results.items()}, quantity=parameter,
                                        note=f"E(t) not compared: {at.why}" if at.why else "")


def run_population(run_dirs: list[Path | str], *, parameter: str = "E", out: Path | str | None = None,
                   force: bool = False, write: bool = True, made_by: str = "population",
                   min_group: int = 2) -> PopulationRun:
    """Pool the finished runs ``run_dirs`` (≥ 2 specimens), one population per material (the
    configs' ``material:``; a material with fewer than ``min_group`` runs is left out with its
    reason); write ``out/population.json``."""
    dirs = [Path(d) for d in run_dirs]
    _check_dirs(dirs)
    t0 = time.perf_counter()
    out_dir = Path(out) if out is not None else default_out_dir(dirs)
    specimens: dict[str, Specimen] = {}
    runs, fps, truth = {}, {}, {}
    for d in dirs:
        sp = _specimen(d, parameter)
        if sp.name in specimens:
            raise RunError(f"population: {d} and {runs[sp.name]} are both named {sp.name!r}; every "
                           "specimen needs its own run name")
        specimens[sp.name] = sp
        fps[sp.name] = sp.fingerprint
        runs[sp.name] = os.path.relpath(d.resolve(), out_dir.resolve())
        if sp.truth is not None:
            truth[sp.name] = float(sp.truth)
    groups: dict[str, list[Specimen]] = {}
    for sp in specimens.values():
        groups.setdefault(sp.material or UNLABELLED, []).append(sp)
    results, skipped, modulus = {}, {}, {}
    for label, members in groups.items():
        if len(members) < min_group:
            skipped[label] = (f"{len(members)} test{'s' if len(members) != 1 else ''} "
                              f"({', '.join(m.name for m in members)}); a population needs at least "
                              f"{min_group}")
            continue
        check, modulus[label] = one_material(members, parameter, label != UNLABELLED)
        pop = population({m.name: m.draws for m in members}, {m.name: m.prior for m in members},
                         parameter=parameter, own={m.name: m.own for m in members if m.own},
                         check=check)
        if pop.heterogeneity.get("passed") is False:
            pop.warnings.insert(0, NOT_ONE + pop.heterogeneity["words"])
        pop.warnings += member_warnings(members)
        results[label] = pop
    if not results:
        raise RunError(f"population: no material has {min_group} runs to pool ("
                       + "; ".join(f"{k}: {v}" for k, v in skipped.items()) + ")")
    between = None
    if len(groups) > 1:
        between = _between(results, [groups[label] for label in results], parameter)
    pr = PopulationRun(results, runs, fps, truth, out_dir, time.perf_counter() - t0, made_by=made_by,
                       materials={k: sp.material for k, sp in specimens.items()},
                       members={k: {"material": sp.material, **sp.trust} for k, sp in specimens.items()},
                       skipped=skipped, between=between,
                       modulus={k: v for k, v in modulus.items() if k in results and v})
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
        return read_json(path, POPULATION_FILE)
    except (OSError, DamagedFileError):
        return {}


def same_inputs(old: dict[str, Any], runs: dict[str, str], fingerprints: dict[str, str],
                parameter: str, materials: dict[str, str | None]) -> bool:
    """Was ``old`` (a population.json) made from these runs, these posteriors of them, this
    parameter, these materials? Then a new one would be the same."""
    return (bool(old) and old.get("fingerprints") == fingerprints and old.get("parameter") == parameter
            and old.get("runs") == runs and old.get("materials") == materials)


def current_population(run_dirs: list[Path | str], *, parameter: str = "E",
                       out: Path | str | None = None) -> dict[str, Any] | None:
    """The population.json in ``out`` when it was made from exactly these finished runs (the same
    posteriors: their fingerprints in summary.json), else None. Reads summary.json only, no draws."""
    dirs = [Path(d) for d in run_dirs]
    out_dir = Path(out) if out is not None else default_out_dir(dirs)
    old = read_existing(out_dir / POPULATION_FILE)
    if not old:
        return None
    runs, fps, materials = {}, {}, {}
    for d in dirs:
        try:
            summary = read_json(d / SUMMARY_FILE, SUMMARY_FILE)
            cfg = load_config(find_config(d))
        except (OSError, DamagedFileError, FileNotFoundError, ConfigError):
            return None
        name = str(summary.get("name") or cfg.name)
        runs[name] = os.path.relpath(d.resolve(), out_dir.resolve())
        fps[name] = str(summary.get("fingerprint") or "")
        materials[name] = cfg.material
    return old if same_inputs(old, runs, fps, parameter, materials) else None


def _check_replace(path: Path, pr: PopulationRun, force: bool) -> None:
    """A population.json made from other runs (or other posteriors of them) is replaced only with
    ``force``."""
    if force or not path.exists():
        return
    parameter = next(iter(pr.results.values())).parameter
    if not same_inputs(read_existing(path), pr.runs, pr.fingerprints, parameter, pr.materials):
        raise RunError(f"{path} exists and was made from other runs or other posteriors of them; pass "
                       "--force to replace it, or --out to write elsewhere")
