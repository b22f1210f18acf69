"""``init``: a starting config from a machine export, so that no config is written from a blank page.

``python -m bayes_dnlr init data.csv [--out runs/name/config.yaml]`` sniffs the file (data/sniff.py),
guesses the columns (data/guess.py), writes a commented config and returns the list of edits the
user must make or check before ``fit``: the cross-section (a force column), the gauge length (an
extension column), every column guessed from values rather than named, the units it could not read,
the strain measure and the identification window. It never overwrites a file.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.config import NAME_PATTERN, ConfigError, parse_config
from bayes_dnlr.data.checks import LOADED_START
from bayes_dnlr.data.cycles import Turns, turning_points
from bayes_dnlr.data.guess import FRACTION_MAX, Guess, Pick, guess_columns
from bayes_dnlr.data.hints import peak_window
from bayes_dnlr.data.temperature import in_file_name, in_metadata
from bayes_dnlr.diskio import storage_error
from bayes_dnlr.errors import RunError
from bayes_dnlr.numbers import fmt
from bayes_dnlr.units import lookup
from bayes_dnlr.workflows.init_labels import Labels
from bayes_dnlr.workflows.init_start import apply, other_words, remedies
from bayes_dnlr.workflows.init_text import config_text as _config_text
from bayes_dnlr.workflows.init_text import flow

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
    return flow(v)


def run_name(text: str) -> str:
    """A valid run name from a file or folder name ('rHDPE Resin 19' -> 'rHDPE-Resin-19')."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-._") or "run"
    return name if re.match(NAME_PATTERN, name) else f"run-{name}"


def _unit_text(unit: str | None) -> str | None:
    return None if unit is None else unit.strip().strip("()[]").strip()


def _column_ref(pick: Pick, guess: Guess) -> str | int:
    """The column by its header name when names may be used, by number when its name is overruled."""
    named = guess.by_name and pick.column.name and not pick.column.overruled
    return pick.column.name if named else pick.column.number


def _hencky(values: np.ndarray, factor: float, measure: str) -> np.ndarray:
    """A strain column's values as the Hencky strain the window is written on (eq. 1)."""
    x = values * factor
    return np.log1p(np.where(x > -1, x, np.nan)) if measure == "nominal" else x


def _load_for_peak(guess: Guess, load: Pick, strain_h: np.ndarray | None) -> tuple[np.ndarray, str]:
    """The column whose peak is the yield point: the force, the engineering stress beside a true
    stress, or the nominal stress σ·exp(-ε) of a true stress (eq. 4-6)."""
    if load.role == "force":
        return load.column.values, f"{load.column.label} (the force)"
    if guess.engineering is not None:
        return guess.engineering.values, f"{guess.engineering.label} (the engineering stress)"
    if strain_h is not None:
        return load.column.values * np.exp(-strain_h), f"{load.column.label} × exp(-ε) (the nominal stress)"
    return load.column.values, load.column.label


def _peak_window(guess: Guess, load: Pick, strain_h: np.ndarray | None, strain_label: str
                 ) -> tuple[dict[str, float], str]:
    """The window up to the load peak (yield) when the load falls after it; else the whole test.
    strain_max is the Hencky strain the model's window reads, rounded down so that the window ends at
    the peak, never past it."""
    v, what = _load_for_peak(guess, load, strain_h)
    ok = np.isfinite(v)
    if ok.sum() < 10:
        return {}, "the whole test"
    k = int(np.nanargmax(v))
    top = float(v[k])
    after = v[k:][np.isfinite(v[k:])]
    if top <= 0 or after.size < 3 or float(after.min()) > (1 - PEAK_DROP) * top:
        return {}, f"the whole test ({what} rises to the end: no yield peak)"
    t = guess.picks.get("time")
    at = f" at t = {fmt(float(t.column.values[k]), 4)} s" if t is not None else ""
    if strain_h is not None and np.isfinite(strain_h[k]) and strain_h[k] > 0:
        x = float(strain_h[k])
        val = math.floor(x / 10 ** (math.floor(math.log10(x)) - 2)) * 10 ** (math.floor(math.log10(x)) - 2)
        val = float(f"{val:.3g}")
        return ({"strain_max": val}, f"up to the load peak (yield) of {what}: {fmt(top)}{at}, Hencky "
                f"strain {fmt(x, 4)} ({strain_label})")
    if t is not None and np.isfinite(t.column.values[k]):
        val = float(fmt(float(t.column.values[k]), 4))
        return {"time_max": val}, f"up to the load peak (yield) of {what}: {fmt(top)}{at}"
    return {}, "the whole test"


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


@dataclass
class _Draft:
    """The config being written: its data keys, comments, the notes beside each column, the edits."""

    data: dict[str, Any]
    comments: dict[str, str] = field(default_factory=dict)
    column_notes: dict[str, str] = field(default_factory=dict)
    edits: list[Edit] = field(default_factory=list)
    found: list[str] = field(default_factory=list)


def build_config(data: Path, out: Path, guess: Guess | None = None
                 ) -> tuple[dict[str, Any], list[Edit], list[str], dict[str, str], dict[str, str]]:
    """(config mapping, edits, what was found, comments per data key, notes per column) for ``data``
    (``guess``: its columns, when already guessed)."""
    guess = guess if guess is not None else guess_columns(data)
    p = guess.picks
    if "time" not in p:
        raise RunError(f"{data}: no time column found (a column that increases at every row); "
                       "write the config by hand: docs/data-input.md")
    strain = p.get("strain") or p.get("extension")
    load = p.get("force") or p.get("stress")
    if strain is None or load is None:
        missing = "a strain or extension column" if strain is None else "a force or stress column"
        raise RunError(f"{data}: {missing} cannot be told from the header or the values; write "
                       "data.columns by hand (docs/data-input.md)")
    dr = _Draft({"file": _data_file(data, out)}, found=["read: " + ", ".join(guess.notes),
                                                        *guess.overruled])
    _specimens(guess, dr)
    columns: dict[str, str | int] = {}
    for role in ("time", "force", "stress", "strain", "extension"):
        if role in p and (role == "time" or p[role] in (strain, load)):
            columns[role] = _column_ref(p[role], guess)
    dr.data["columns"] = columns
    dr.found.append("columns: " + ", ".join(f"{r} = {p[r].column.label} ({p[r].how})" for r in columns))
    for role in columns:
        pick = p[role]
        if pick.relation:
            dr.column_notes[role] = pick.relation
            dr.found.append(f"  {role}: {pick.relation}")
            continue
        dr.column_notes[role] = ("guessed from the values" if pick.how.startswith("values") else
                                 f"from the {pick.how}")
        if not pick.sure:
            others = f"; other candidates: {_others(pick)}" if pick.others else ""
            dr.edits.append(Edit("check", f"data.columns.{role}", columns[role],
                                 f"guessed from the {'values' if pick.how.startswith('values') else pick.how}"
                                 f"{others}"))
    factor = _units(guess, dr, columns)
    _stress_keys(guess, dr, columns)
    measure = _measure(guess, dr, strain, columns)
    strain_h = (_hencky(strain.column.values, factor, measure) if "strain" in columns and factor is not None
                else None)
    _window(guess, dr, load, strain, strain_h)
    _temperature(guess, dr)
    raw = {"name": run_name(out.parent.name), "data": dr.data, "noise": {"sigma0": "residuals"}}
    return raw, dr.edits, dr.found, dr.comments, dr.column_notes


def _specimens(guess: Guess, dr: _Draft) -> None:
    if guess.group is None:
        return
    n, w = guess.group
    dr.data["specimen"] = 1
    dr.data["specimen_columns"] = w
    dr.edits.append(Edit("check", "data.specimen", 1, f"the file holds {n} specimens side by side "
                                                      f"(groups of {w} columns): which one?"))
    dr.comments["specimen"] = f"1 of {n}; columns are counted within its group"
    dr.comments["specimen_columns"] = f"groups of {w} columns ({guess.group_from})"


def _units(guess: Guess, dr: _Draft, columns: dict) -> float | None:
    """Units the reader reads itself, units init read from a name (written out, since the reader
    does not read them there), units a relation confirms, or units assumed (a check line each);
    returns the strain column's factor to a fraction."""
    p = guess.picks
    units: dict[str, str] = {}
    factor: float | None = None
    for role, pick in ((r, p[r]) for r in columns):
        c = pick.column
        unit = _unit_text(c.unit)
        hit = lookup(unit) if unit is not None else None
        if role == "strain":
            if hit is not None and hit[0] == "strain":
                factor = hit[1]
                if not c.unit_read:
                    dr.data["strain_unit"] = "percent" if factor == 0.01 else "fraction"
                    dr.comments["strain_unit"] = f"{c.label} is in {unit} (its name)"
            elif guess.percent is not None:
                dr.data["strain_unit"] = "percent" if guess.percent.value else "fraction"
                dr.comments["strain_unit"] = guess.percent.why
                factor = 0.01 if guess.percent.value else 1.0
            else:
                top = float(np.nanmax(c.values))
                percent = top > FRACTION_MAX
                dr.data["strain_unit"] = "percent" if percent else "fraction"
                factor = 0.01 if percent else 1.0
                dr.edits.append(Edit("check", "data.strain_unit", dr.data["strain_unit"],
                                     f"no unit in the file; values up to {fmt(top)} read as "
                                     f"{'percent (too large for a fraction)' if percent else 'a fraction'}"))
            continue
        if hit is not None:
            if not c.unit_read:
                units[role] = unit
            continue
        default = {"time": "s", "force": "N", "stress": "MPa", "extension": "mm"}[role]
        units[role] = default
        dr.edits.append(Edit("check", f"data.units.{role}", default,
                             f"no unit for {c.label} in the file; {default} assumed"))
    if units:
        dr.data["units"] = units
    return factor


def _stress_keys(guess: Guess, dr: _Draft, columns: dict) -> None:
    p = guess.picks
    if "force" in columns:
        if guess.area0 is not None:
            dr.data["area0"] = guess.area0.value
            dr.comments["area0"] = f"S0, mm²: {guess.area0.why}"
        else:
            dr.data["area0"] = None
            why = "the specimen's initial cross-section S0 in mm² (the force column needs it: σ = F/S0)"
            dr.edits.insert(0, Edit("set", "data.area0", None, why))
            dr.comments["area0"] = "EDIT: initial cross-section S0, mm²"
    else:
        dr.data["observable"] = "stress"
        pick = p["stress"]
        if pick.relation:
            dr.comments["observable"] = f"the true stress: {p['stress'].column.label} (its relation above)"
        elif guess.stress_measure is not None:
            dr.data["stress_measure"] = guess.stress_measure.value
            dr.comments["observable"] = "the stress column, converted below"
            dr.comments["stress_measure"] = (f"{guess.stress_measure.why}: the true stress is s·exp(ε) "
                                             f"= s·(1 + e) (isovolumic, eq. 4-6)")
            dr.edits.append(Edit("check", "data.stress_measure", guess.stress_measure.value,
                                 f"{guess.stress_measure.why} (a name, no relation): it is converted "
                                 "to the true stress s·exp(ε) (eq. 4-6); `true` if it is a true stress"))
        else:
            dr.comments["observable"] = "the stress column, taken as the true stress (docs/data-input.md)"
            dr.edits.append(Edit("check", "data.observable", "stress",
                                 f"{pick.column.label} is taken as the true stress; an engineering "
                                 "stress (F/S0) would bias E and G: the file holds no relation to tell"))
    if "extension" in columns:
        dr.data["gauge_length"] = None
        dr.edits.insert(0, Edit("set", "data.gauge_length", None, "the gauge length L0 in mm (strain = "
                                                                  "extension / L0)"))
        dr.comments["gauge_length"] = "EDIT: gauge length L0, mm"


def _measure(guess: Guess, dr: _Draft, strain: Pick, columns: dict) -> str:
    if guess.measure is not None:
        dr.data["strain_measure"] = guess.measure.value
        dr.comments["strain_measure"] = guess.measure.why
        return str(guess.measure.value)
    dr.data["strain_measure"] = "nominal"
    dr.comments["strain_measure"] = "nominal (engineering) or hencky (true) strain"
    if "strain" in columns:
        dr.edits.append(Edit("check", "data.strain_measure", "nominal",
                             "nominal (engineering, Δl/l0) or hencky (true, ln(l/l0))? a machine's strain "
                             "channel is usually nominal"))
    return "nominal"


def _window(guess: Guess, dr: _Draft, load: Pick, strain: Pick, strain_h: np.ndarray | None) -> None:
    hold = guess.hold
    if hold is not None:
        dr.data["relaxation_start"] = "auto"
        said = hold.describe(strain.column.label, load.column.label)
        dr.comments["relaxation_start"] = f"a relaxation hold: {said}"
        dr.found.append(f"hold: {said}: relaxation_start: auto")
        window, why = {}, ("the whole test: the ramp and the hold (sigma_inf and tau_max_R are identified "
                           "on the hold)")
    else:
        cycles = None
        if strain_h is not None and "time" in guess.picks:
            t, s = guess.picks["time"].column.values, load.column.values
            ok = np.isfinite(strain_h) & np.isfinite(t) & np.isfinite(s)
            cycles = _cycles_window(t[ok], strain_h[ok], turning_points(strain_h[ok], s[ok]))
        window, why = cycles or _peak_window(guess, load, strain_h, strain.column.label)
    dr.data["window"] = window
    dr.comments["window"] = why
    dr.edits.append(Edit("check", "data.window", window, _window_why(why)))


def _temperature(guess: Guess, dr: _Draft) -> None:
    """data.temperature: a temperature column (its name or unit says so), else a temperature in
    the file's metadata or name (data/temperature.py), which the user checks."""
    shift = "model.shift.temperature shifts the spectrum to a reference temperature (docs/config.md)"
    t = guess.temperature
    if t is not None:
        ref = _column_ref(t, guess)
        unit = (t.column.unit or "").strip().strip("()[]").strip()
        kelvin = unit.lower() in ("k", "kelvin")
        dr.data["temperature"] = {"column": ref, "unit": "K"} if kelvin and not t.column.unit_read else ref
        v = t.column.values[np.isfinite(t.column.values)] - (273.15 if kelvin else 0.0)
        dr.comments["temperature"] = (f"read per row from {t.column.label} ({t.how}), "
                                      f"{float(v.min()):.4g} to {float(v.max()):.4g} °C; {shift}")
        dr.found.append(f"temperature: {t.column.label} ({t.how}), {float(v.min()):.4g} to "
                        f"{float(v.max()):.4g} °C, read per row")
        return
    first, last = guess.layout.metadata or (0, -1)
    lines = guess.path.read_text(errors="replace").splitlines()[first - 1:last] if first else []
    hit, where = in_metadata(lines), "metadata"
    if hit is None:
        hit, where = in_file_name(guess.path.stem), "name"
    if hit is None:
        return
    value, text = hit
    dr.data["temperature"] = value
    dr.comments["temperature"] = f"°C, from the file's {where} ({text!r}); {shift}"
    dr.found.append(f"temperature: {value:g} °C, from the file's {where} ({text!r})")
    dr.edits.append(Edit("check", "data.temperature", value,
                         f"read from the file's {where} ({text!r}): the test's temperature in °C?"))


def config_text(raw: dict[str, Any], comments: dict[str, str], source: Path,
                column_notes: dict[str, str] | None = None) -> str:
    """The config as YAML with a comment on the keys the user may need to change."""
    return _config_text(raw, comments, str(source), column_notes or {})


def init_config(data: str | Path, out: str | Path | None = None, *, specimen: int | None = None,
                guess: Guess | None = None, labels: Labels | None = None) -> InitResult:
    """Write a starting config for the export ``data`` (module doc); never overwrites. A DMA
    export gives the ``reference_moduli`` entry that reads it instead (workflows/init_sweep.py).
    ``specimen``: this specimen of a file with several side by side (default: the first, with a
    check line asking which); ``guess``: the file's columns when already guessed; ``labels``: the
    material the file states (workflows/init_labels.py)."""
    data = Path(data)
    if not data.is_file():
        raise RunError(f"{data}: data file not found (init takes a test export, e.g. a CSV)")
    from bayes_dnlr.data.dma import looks_like_sweep

    if looks_like_sweep(data):          # a DMA export: a reference_moduli entry, not a config
        from bayes_dnlr.workflows.init_sweep import init_sweep

        return init_sweep(data, None if out is None else Path(out), run_name(data.stem))
    out = Path(out) if out is not None else Path("runs") / run_name(data.stem) / "config.yaml"
    if out.suffix not in (".yaml", ".yml"):
        raise RunError(f"{out}: --out names the config file to write, e.g. runs/name/config.yaml")
    if out.exists():
        raise RunError(f"{out}: exists; init never overwrites a config (give --out another path)")
    raw, edits, found, comments, column_notes = build_config(data, out, guess)
    raw["name"] = run_name(out.parent.name) if out.name == "config.yaml" else run_name(out.stem)
    if specimen is not None and "specimen" in raw["data"]:
        n = comments["specimen"].split(" of ", 1)[1].split(";", 1)[0]
        raw["data"]["specimen"] = specimen
        comments["specimen"] = f"{specimen} of {n}; columns are counted within its group"
        edits[:] = [e for e in edits if e.key != "data.specimen"]
    _labelled(raw, comments, labels)
    problems, test = _trial(raw, edits, out, comments)
    if test is not None and any(p.startswith(LOADED_START) for p in problems):
        remedy, started = _loaded_start(test, raw, edits, comments, out)
        if started is not None:             # the window on the strain as the remedy measures it
            test = started
            found += [n for n in started.notes if n.startswith(("toe compensation", "initial_state"))]
            wrote = f"; init wrote data.{remedy.key}: {remedy.value} (its line below)"
            problems = [re.sub(r"; set data\.toe: .*?\(docs/data-input\.md, 'The first sample'\)", wrote, p)
                        if p.startswith(LOADED_START) else p for p in problems]
    if test is not None and "relaxation_start" not in raw["data"]:
        _window_at_peak(test, raw, edits, comments)
    text = config_text(raw, comments, data, column_notes)
    made = [q for q in (out.parent, *out.parent.parents) if not q.exists() and not q.is_symlink()]
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with open(out, "x", encoding="utf-8") as f:     # "x": never overwrite, even in a race
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
    except FileExistsError:
        raise RunError(f"{out}: exists; init never overwrites a config (give --out another path)") from None
    except BaseException as err:
        out.unlink(missing_ok=True)
        for q in made:                   # the folders this call made, innermost first, when empty
            try:
                q.rmdir()
            except OSError:
                break
        clean = storage_error(err, out, "nothing was written")
        if clean is not None:
            raise clean from None
        raise
    return InitResult(out, raw, edits, found, problems)


def _labelled(raw: dict[str, Any], comments: dict[str, str], labels: Labels | None) -> None:
    """The material the file states as the config's ``material:``."""
    if labels is not None and labels.material is not None:
        raw["material"] = labels.material.value
        comments["material"] = f"read from {labels.material.where}"


PLACEHOLDER = {"data.area0": 1.0, "data.gauge_length": 1.0}


def _loaded_start(test: Any, raw: dict[str, Any], edits: list[Edit], comments: dict[str, str],
                  out: Path) -> tuple[Any, Any]:
    """A first sample that already carries load (the reader's warning): the remedy the strain points
    to (workflows/init_start.py), else the other, whichever the file reads with; ``toe: none``
    marked EDIT when neither does. (the remedy, the TestData read with it), or (None, None)."""
    for remedy in remedies(test.strain[test.virtual_start:]):
        trial = {**raw, "data": apply(raw["data"], remedy)}
        _, started = _trial(trial, edits, out, {})
        if started is None:
            continue
        raw["data"] = apply(raw["data"], remedy)
        comments[remedy.key] = (f"the first sample carries load (init's warning): {remedy.why}; none "
                                "biases E (docs/data-input.md, 'The first sample')")
        edits.append(Edit("check", f"data.{remedy.key}", remedy.value,
                          f"the first sample carries load (the warning above): {remedy.why}; "
                          f"{other_words(remedy)}; `toe: none` keeps the model's unloaded start "
                          "there, which biases E"))
        return remedy, started
    raw["data"]["toe"] = "none"
    comments["toe"] = ("EDIT: the first sample carries load (init's warning) and neither remedy reads "
                       "here: give a toe band {stress_min: .., stress_max: ..} (MPa); none biases E "
                       "(docs/data-input.md, 'The first sample')")
    edits.append(Edit("check", "data.toe", "none",
                      "the first sample carries load (the warning above) and neither `compensate` nor "
                      "`data.initial_state: ramp-from-zero` reads this file: give `toe: {stress_min: "
                      "a, stress_max: b}` (MPa) on the linear part; `none` keeps the model's unloaded "
                      "start there, which biases E"))
    return None, None


def _trial(raw: dict[str, Any], edits: list[Edit], out: Path, comments: dict[str, str]
           ) -> tuple[list[str], Any]:
    """Read the data with the config as written (placeholders for the values to set; the whole test
    as the window): what fails, or the reader's warnings about the data (a loaded first sample, a
    spike, ...), and the TestData read (None when reading failed). A time stamp repeated by the
    logger is answered in the config (``data.repeated_time: drop``) and read again."""
    import copy

    from bayes_dnlr.data import load_test
    from bayes_dnlr.data.repeats import RepeatedTime

    trial = copy.deepcopy(raw)
    trial["data"]["file"] = str((out.absolute().parent / raw["data"]["file"]).resolve()
                                if not Path(raw["data"]["file"]).is_absolute() else raw["data"]["file"])
    trial["data"]["window"] = {}
    placeholders = {}
    for e in edits:
        if e.action == "set" and e.key in PLACEHOLDER:
            trial["data"][e.key.split(".", 1)[1]] = placeholders[e.key] = PLACEHOLDER[e.key]
    try:
        try:
            test = load_test(parse_config(trial, source=out.resolve()))
        except RepeatedTime as err:
            _repeated_time(raw, edits, comments, err.seen)
            trial["data"]["repeated_time"] = raw["data"]["repeated_time"]
            test = load_test(parse_config(trial, source=out.resolve()))
    except (ConfigError, RunError) as err:
        return [f"the data cannot be read with these guesses yet: {str(err).splitlines()[0]}"], None
    except Exception as err:  # noqa: BLE001 - a DataError or any reader failure is reported, not raised
        return [f"the data cannot be read with these guesses yet: {err}"], None
    where = (f" (read with {', '.join(f'{k} = {v:g}' for k, v in placeholders.items())} in place of "
             f"your value)" if placeholders else "")
    notes = list(test.notes)
    if "data.area0" in placeholders:                    # no stress in MPa without the real S0
        notes = [_force_only(n, test) for n in notes if not n.startswith("warning: data.area0 is")]
    return [n.removeprefix("warning: ") + where for n in notes if n.startswith("warning:")], test


def _repeated_time(raw: dict[str, Any], edits: list[Edit], comments: dict[str, str], seen: str) -> None:
    """The file repeats time stamps (the reader's error, ``seen``: how many, where):
    data.repeated_time: drop, written after the columns, with what was seen and a check line."""
    data = raw["data"]
    keys = list(data)
    at = keys.index("columns") + 1 if "columns" in keys else len(keys)
    raw["data"] = {**{k: data[k] for k in keys[:at]}, "repeated_time": "drop",
                   **{k: data[k] for k in keys[at:]}}
    comments["repeated_time"] = (f"{seen}: the first row of each time stamp is kept (average: their "
                                 "mean)")
    edits.append(Edit("check", "data.repeated_time", "drop",
                      f"{seen}; `drop` keeps the first row of each time stamp, `average` takes their "
                      "mean"))


def _force_only(note: str, test: Any) -> str:
    """The first-sample warning in newtons: with a placeholder area a stress in MPa means nothing."""
    from bayes_dnlr.data.checks import first_sample_warning

    if not note.startswith("warning: the first sample") or test.force is None:
        return note
    return first_sample_warning(test.stress, test.strain, int(test.lines[0]), force=test.force) or note


def _cycles_window(time: np.ndarray, strain: np.ndarray, turns: Turns,
                   lines: np.ndarray | None = None) -> tuple[dict[str, float], str] | None:
    """For a loading-unloading test (its ``turns``, data/cycles.py, indices of ``time``): its first
    loading, the whole history named; None for a test without cycles. The model follows no
    unloading (docs/model-form.md, "Loading-unloading cycles"), with or without its stress shift."""
    if not turns.cyclic:
        return None
    k = turns.first_loading_end
    first = peak_window(time, strain, k)
    at = f" (line {int(lines[k])})" if lines is not None else ""
    return first, (f"the first loading of {len(turns.peaks)} loading-unloading cycles, to where the "
                   f"strain turns back first (t = {fmt(float(time[k]), 5)} s{at}, Hencky strain "
                   f"{fmt(float(strain[k]), 4)}): the model does not follow unloading; the whole "
                   "history is {}")


def _window_at_peak(test: Any, raw: dict[str, Any], edits: list[Edit], comments: dict[str, str]) -> None:
    """The window of the test as the reader reads it: for a loading-unloading test the whole history
    (data/cycles.py); else up to the peak of the nominal load (yield), ending on the peak sample
    itself, the bound on the measured Hencky strain that the window's strain bounds read
    (``data.hints.peak_window``: strain_max, or time_max when the strain turns there)."""
    first = test.virtual_start
    cycles = _cycles_window(test.time[first:], test.strain[first:], test.turns.shifted(-first),
                            test.lines[first:])
    load = test.force if test.force is not None else test.nominal_stress
    if load is None:
        load = test.stress * np.exp(-test.strain)
    what = "the force" if test.force is not None else "the nominal stress"
    unit = "N" if test.force is not None else "MPa"
    v = np.asarray(load[first:], float)
    k = int(np.argmax(v))
    top = float(v[k])
    if cycles is not None:
        window, why = cycles
    elif not top > 0 or float(v[k:].min()) > (1 - PEAK_DROP) * top:
        window, why = {}, f"the whole test ({what} rises to the end: no yield peak)"
    else:
        x = float(test.strain[first + k])
        if not x > 0:
            return
        window = peak_window(test.time[first:], test.strain[first:], k)
        line = int(test.lines[first + k])
        why = (f"up to the load peak (yield): {what} {fmt(top, 4)} {unit} at t = "
               f"{fmt(float(test.time[first + k]), 5)} s (line {line}), Hencky strain {fmt(x, 4)}")
    raw["data"]["window"] = window
    comments["window"] = why
    for e in edits:
        if e.key == "data.window":
            e.value = window
            e.why = _window_why(why)


def _window_why(why: str) -> str:
    return (f"the identification window: {why}. {{}} is the whole test: right when the strain is measured "
            "on the specimen (extensometer, DIC) and the deformation stays homogeneous; a crosshead "
            "strain past yield (necking) is not")
