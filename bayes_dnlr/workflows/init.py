"""``init``: a starting config from a machine export, so that no config is written from a blank page.

``python -m bayes_dnlr init data.csv [--out runs/name/config.yaml]`` sniffs the file (data/sniff.py),
guesses the columns (data/guess.py), writes a commented config and returns the list of edits the
user must make or check before ``fit``: the cross-section (a force column), the gauge length (an
extension column), every column guessed from values rather than named, the units it could not read,
the strain measure and the identification window. It never overwrites a file (issue 15).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from bayes_dnlr.config import NAME_PATTERN, ConfigError, parse_config
from bayes_dnlr.data.guess import FRACTION_MAX, Guess, Pick, guess_columns
from bayes_dnlr.errors import RunError
from bayes_dnlr.numbers import fmt
from bayes_dnlr.units import lookup

PEAK_DROP = 0.05        # the load falls this far below its maximum after it: a peak (yield)


@dataclass
class Edit:
    """One thing to do before ``fit``: ``set`` a value the file cannot give, or ``check`` a guess."""

    action: str                  # "set" | "check"
    key: str                     # dotted config key, e.g. data.area0
    value: Any                   # what the config holds now (None for a value to set)
    why: str

    def line(self) -> str:
        now = "" if self.value is None else f" (now {_flow(self.value)})"
        return f"{self.action:<5} {self.key}{now}: {self.why}"


@dataclass
class InitResult:
    path: Path                   # the config written
    raw: dict[str, Any]          # its content
    edits: list[Edit]
    found: list[str] = field(default_factory=list)     # what was read and guessed, one line each
    problems: list[str] = field(default_factory=list)  # reading with the guesses failed: why

    def text(self) -> str:
        lines = [f"wrote {self.path} (a starting config)", *self.found]
        lines += [f"warning: {p}" for p in self.problems]
        if self.edits:
            lines.append(f"before `python -m bayes_dnlr fit {self.path}`, edit it ({len(self.edits)}):")
            lines += [f"  {i}. {e.line()}" for i, e in enumerate(self.edits, 1)]
        else:
            lines.append(f"nothing to edit: `python -m bayes_dnlr fit {self.path}`")
        lines.append("docs: docs/data-input.md (columns, units, windows), docs/config.md (every key)")
        return "\n".join(lines)


def _flow(v: Any) -> str:
    return yaml.safe_dump(v, default_flow_style=True, width=1000, sort_keys=False,
                          allow_unicode=True).strip().removesuffix("...").strip()


def run_name(text: str) -> str:
    """A valid run name from a file or folder name ('rHDPE Resin 19' -> 'rHDPE-Resin-19')."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-._") or "run"
    return name if re.match(NAME_PATTERN, name) else f"run-{name}"


def _unit_text(unit: str | None) -> str | None:
    return None if unit is None else unit.strip().strip("()[]").strip()


def _column_ref(pick: Pick, guess: Guess) -> str | int:
    return pick.column.name if guess.by_name and pick.column.name else pick.column.number


def _strain_in_fraction(pick: Pick, unit_fraction: float | None) -> np.ndarray:
    v = pick.column.values
    return v * unit_fraction if unit_fraction is not None else v


def _peak_window(guess: Guess, load: Pick | None, strain: Pick | None, strain_factor: float | None
                 ) -> tuple[dict[str, float], str]:
    """The window up to the load peak (yield) when the load falls after it; else the whole test."""
    if load is None:
        return {}, "the whole test"
    v = load.column.values
    ok = np.isfinite(v)
    if ok.sum() < 10:
        return {}, "the whole test"
    k = int(np.nanargmax(v))
    top = float(v[k])
    after = v[k:][np.isfinite(v[k:])]
    if top <= 0 or after.size < 3 or float(after.min()) > (1 - PEAK_DROP) * top:
        return {}, "the whole test (the load rises to the end: no yield peak)"
    if strain is not None and strain_factor is not None and np.isfinite(strain.column.values[k]):
        x = float(strain.column.values[k]) * strain_factor
        if x > 0:
            val = float(fmt(x, 2))
            return ({"strain_max": val}, f"up to the load peak (yield) at strain {fmt(val, 2)}, where the "
                    f"load is {fmt(top)} {_unit_text(load.column.unit) or ''}".rstrip())
    t = guess.picks.get("time")
    if t is not None and np.isfinite(t.column.values[k]):
        val = float(fmt(float(t.column.values[k]), 2))
        return {"time_max": val}, f"up to the load peak (yield) at time {fmt(val, 2)} s"
    return {}, "the whole test"


def _hold_start(guess: Guess, strain: Pick) -> float | None:
    """The time where the strain stops rising when it then stays (within 1 % of its range) for at
    least the last tenth of the test: a relaxation hold. None for a tensile test."""
    t, e = guess.picks["time"].column.values, strain.column.values
    ok = np.isfinite(t) & np.isfinite(e)
    t, e = t[ok], e[ok]
    if t.size < 20 or np.ptp(e) == 0:
        return None
    top = float(e.max())
    flat = np.abs(e - e[-1]) <= 0.01 * np.ptp(e)
    start = int(np.flatnonzero(~flat)[-1]) + 1 if (~flat).any() else 0
    if e[-1] < 0.9 * top or t[-1] - t[start] < 0.1 * (t[-1] - t[0]) or start == 0:
        return None
    return float(t[start])


def _others(pick: Pick) -> str:
    return ", ".join(c.label for c in pick.others)


def _data_file(data: Path, config: Path) -> str:
    """data.file as written in the config: relative to the config when both are in the current
    folder's tree, else absolute."""
    data = data.resolve()
    folder = config.absolute().parent
    here = Path.cwd().resolve()
    if not (data.is_relative_to(here) and folder.resolve().is_relative_to(here)):
        return str(data)
    rel = os.path.relpath(data, folder.resolve())
    return rel if (folder / rel).resolve() == data else str(data)


def build_config(data: Path, out: Path) -> tuple[dict[str, Any], list[Edit], list[str], dict[str, str]]:
    """(config mapping, edits, what was found, comments per data key) for the file ``data``."""
    guess = guess_columns(data)
    p = guess.picks
    edits: list[Edit] = []
    comments: dict[str, str] = {}
    found = ["read: " + ", ".join(guess.notes)]
    if "time" not in p:
        raise RunError(f"{data}: no time column found (a column that increases at every row); "
                       "write the config by hand: docs/data-input.md")
    strain = p.get("strain") or p.get("extension")
    load = p.get("force") or p.get("stress")
    if strain is None or load is None:
        missing = "a strain or extension column" if strain is None else "a force or stress column"
        raise RunError(f"{data}: {missing} cannot be told from the header or the values; write "
                       "data.columns by hand (docs/data-input.md)")
    columns: dict[str, str | int] = {}
    for role in ("time", "force", "stress", "strain", "extension"):
        if role in p and (role in ("time",) or p[role] in (strain, load)):
            columns[role] = _column_ref(p[role], guess)
    d: dict[str, Any] = {"file": _data_file(data, out), "columns": columns}
    found.append("columns: " + ", ".join(f"{r} = {p[r].column.label} ({p[r].how})" for r in columns))
    for role in columns:
        pick = p[role]
        if not pick.sure:
            others = f"; other candidates: {_others(pick)}" if pick.others else ""
            edits.append(Edit("check", f"data.columns.{role}", columns[role],
                              f"guessed from the {'values' if pick.how.startswith('values') else pick.how}"
                              f"{others}"))
    if guess.group is not None:
        d["specimen"] = 1
        n, w = guess.group
        edits.append(Edit("check", "data.specimen", 1, f"the file holds {n} specimens side by side "
                                                       f"(groups of {w} columns): which one?"))
        comments["specimen"] = f"1 of {n} (groups of {w} columns); columns are counted within it"
    # units: read from the file, else assumed (and listed)
    units: dict[str, str] = {}
    strain_factor: float | None = None
    for role, pick in ((r, p[r]) for r in columns):
        unit = _unit_text(pick.column.unit)
        if pick.column.unit_in_suffix and unit is not None:      # read by init, not by the reader
            if role == "strain":
                strain_factor = lookup(unit)[1]
            units[role] = unit
            continue
        if role == "strain":
            if unit is not None and lookup(unit) is not None:
                strain_factor = lookup(unit)[1]
                continue
            top = float(np.nanmax(pick.column.values))
            percent = top > FRACTION_MAX
            d["strain_unit"] = "percent" if percent else "fraction"
            strain_factor = 0.01 if percent else 1.0
            edits.append(Edit("check", "data.strain_unit", d["strain_unit"],
                              f"no unit in the file; values up to {fmt(top)} read as "
                              f"{'percent (too large for a fraction)' if percent else 'a fraction'}"))
            continue
        if unit is not None and lookup(unit) is not None:
            continue
        default = {"time": "s", "force": "N", "stress": "MPa", "extension": "mm"}[role]
        units[role] = default
        edits.append(Edit("check", f"data.units.{role}", default,
                          f"no unit for {pick.column.label} in the file; {default} assumed"))
    if units:
        d["units"] = units
    if "force" in columns:
        d["area0"] = None
        edits.insert(0, Edit("set", "data.area0", None, "the specimen's initial cross-section S0 in "
                                                        "mm² (the force column needs it: σ = F/S0)"))
        comments["area0"] = "EDIT: initial cross-section S0, mm²"
    else:
        d["observable"] = "stress"
        comments["observable"] = "the stress column, taken as the true stress (docs/data-input.md)"
    if "extension" in columns:
        d["gauge_length"] = None
        edits.insert(0, Edit("set", "data.gauge_length", None, "the gauge length L0 in mm (strain = "
                                                               "extension / L0)"))
        comments["gauge_length"] = "EDIT: gauge length L0, mm"
    label = (strain.column.name or "").lower()
    hencky = bool(re.search(r"true|hencky|log", label))
    nominal = bool(re.search(r"eng|nominal|tensile strain", label))
    d["strain_measure"] = "hencky" if hencky else "nominal"
    if not (hencky or nominal) and "strain" in columns:
        edits.append(Edit("check", "data.strain_measure", d["strain_measure"],
                          "nominal (engineering, Δl/l0) or hencky (true, ln(l/l0))? a machine's strain "
                          "channel is usually nominal"))
    comments["strain_measure"] = "nominal (engineering) or hencky (true) strain"
    hold = _hold_start(guess, strain)
    if hold is not None:
        d["relaxation_start"] = "auto"
        comments["relaxation_start"] = f"the strain stops rising near t = {fmt(hold, 3)} s: a relaxation hold"
        edits.append(Edit("check", "data.relaxation_start", "auto",
                          f"the strain stops rising near t = {fmt(hold, 3)} s and stays: a relaxation "
                          "hold after the ramp (auto detects its start; null: a tensile test only)"))
    window, why = ((({}, "the whole test: the ramp and the hold (sigma_inf and tau_max_R are "
                     "identified on the hold)")) if hold is not None else
                   _peak_window(guess, load, strain if "strain" in columns else None, strain_factor))
    d["window"] = window
    comments["window"] = why
    edits.append(Edit("check", "data.window", window,
                      f"the identification window: {why}. {{}} is the whole test: right when the "
                      "strain is measured on the specimen (extensometer, DIC) and the deformation "
                      "stays homogeneous; a crosshead strain past yield (necking) is not"))
    raw = {"name": run_name(out.parent.name), "data": d, "noise": {"sigma0": "residuals"}}
    return raw, edits, found, comments


def config_text(raw: dict[str, Any], comments: dict[str, str], source: Path) -> str:
    """The config as YAML with a comment on the keys the user may need to change."""
    lines = [f"# Starting config written by `python -m bayes_dnlr init {source}`.",
             "# Edit the lines marked EDIT, check the others (docs/data-input.md, docs/config.md);",
             "# the priors, model and sampler are the defaults (docs/config.md).",
             f"name: {raw['name']}                 # run name = this folder: outputs go next to this file",
             "", "data:"]
    for k, v in raw["data"].items():
        note = comments.get(k)
        text = f"  {k}: {'null' if v is None else _flow(v)}"
        lines.append(text + (f"   # {note}" if note else ""))
    lines += ["", "noise:", "  sigma0: residuals                 # the noise sd from the fit's residuals "
              "(MPa); a number if you know it", ""]
    return "\n".join(lines)


def init_config(data: str | Path, out: str | Path | None = None) -> InitResult:
    """Write a starting config for the export ``data`` (module doc); never overwrites."""
    data = Path(data)
    if not data.is_file():
        raise RunError(f"{data}: data file not found (init takes a test export, e.g. a CSV)")
    out = Path(out) if out is not None else Path("runs") / run_name(data.stem) / "config.yaml"
    if out.suffix not in (".yaml", ".yml"):
        raise RunError(f"{out}: --out names the config file to write, e.g. runs/name/config.yaml")
    if out.exists():
        raise RunError(f"{out}: exists; init never overwrites a config (give --out another path)")
    raw, edits, found, comments = build_config(data, out)
    raw["name"] = run_name(out.parent.name) if out.name == "config.yaml" else run_name(out.stem)
    problems = _trial(raw, edits, out)
    text = config_text(raw, comments, data)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with open(out, "x", encoding="utf-8") as f:     # "x": never overwrite, even in a race
            f.write(text)
    except FileExistsError:
        raise RunError(f"{out}: exists; init never overwrites a config (give --out another path)") from None
    except BaseException:
        out.unlink(missing_ok=True)
        raise
    return InitResult(out, raw, edits, found, problems)


PLACEHOLDER = {"data.area0": 1.0, "data.gauge_length": 1.0}


def _trial(raw: dict[str, Any], edits: list[Edit], out: Path) -> list[str]:
    """Read the data with the config as written (placeholders for the values to set): what fails,
    or the reader's warnings about the data (a loaded first sample, a spike, ...)."""
    import copy

    from bayes_dnlr.data import load_test

    trial = copy.deepcopy(raw)
    trial["data"]["file"] = str((out.absolute().parent / raw["data"]["file"]).resolve()
                                if not Path(raw["data"]["file"]).is_absolute() else raw["data"]["file"])
    for e in edits:
        if e.action == "set" and e.key in PLACEHOLDER:
            trial["data"][e.key.split(".", 1)[1]] = PLACEHOLDER[e.key]
    try:
        test = load_test(parse_config(trial, source=out.resolve()))
    except (ConfigError, RunError) as err:
        return [f"the data cannot be read with these guesses yet: {str(err).splitlines()[0]}"]
    except Exception as err:  # noqa: BLE001 - a DataError or any reader failure is reported, not raised
        return [f"the data cannot be read with these guesses yet: {err}"]
    stand_in = [f"{k} = {v:g}" for k, v in PLACEHOLDER.items() if any(e.key == k and e.action == "set"
                                                                     for e in edits)]
    where = f" (read with {', '.join(stand_in)} in place of your value)" if stand_in else ""
    return [n.removeprefix("warning: ") + where for n in test.notes if n.startswith("warning:")]
