"""``python -m bayes_dnlr export RUN_DIR --format abaqus|ls-dyna|ansys|csv|json``: material cards of a
finished run with its uncertainty (docs/export.md).

Writes ``<run_dir>/export/<format>/`` (or ``--out``): one file per card (median, q05, q95 and
``--draws`` ensemble members) and ``cards.csv``, the index of the cards with their parameters and
checks. Nothing is written when an input is wrong; a different existing file is never replaced
without ``--force``.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayes_dnlr.diskio import own_dir
from bayes_dnlr.errors import BayesDnlrError, RunError
from bayes_dnlr.fileset import folder_set, recover_folder
from bayes_dnlr.inference.test_model import shift_of
from bayes_dnlr.numbers import fmt
from bayes_dnlr.runs.layout import EXPORT_DIR
from bayes_dnlr.runs.testset import plain_names
from bayes_dnlr.vocabulary import UNIVERSAL_EXPONENT, unit
from bayes_dnlr.workflows.export import FORMAT_NAMES, abaqus, ansys, lsdyna, table
from bayes_dnlr.workflows.export.cards import (
    RAMP_CHECK_STRAIN,
    SMALL_STRAIN_TOLERANCE,
    STRAIN_FLOOR,
    Card,
    CardSet,
    Poisson,
    TimeRange,
    bracket_checks,
    check_poisson,
    make_cards,
    poisson_from_strains,
    ramp_error,
    small_strain_limit,
)
from bayes_dnlr.workflows.export.context import Context
from bayes_dnlr.workflows.export.prony import from_parameters
from bayes_dnlr.workflows.export.shift_law import ShiftLaw, Support, spread_of


@dataclass(frozen=True)
class Format:
    render: Callable[[Card, Context], str]
    extension: str
    solver: str | None          # a solver that needs ν < 0.5, or None (csv, json)
    shift: Callable[[ShiftLaw, dict[str, float]], Support]   # what it carries of a shift law


FORMATS = {
    "abaqus": Format(abaqus.render, abaqus.EXTENSION, abaqus.SOLVER, abaqus.shift_support),
    "ls-dyna": Format(lsdyna.render, lsdyna.EXTENSION, lsdyna.SOLVER, lsdyna.shift_support),
    "ansys": Format(ansys.render, ansys.EXTENSION, ansys.SOLVER, ansys.shift_support),
    "csv": Format(table.render_csv, "csv", None, table.shift_support),
    "json": Format(table.render_json, "json", None, table.shift_support),
}
INDEX_FILE = "cards.csv"
assert tuple(FORMATS) == FORMAT_NAMES
MAX_DRAWS = 10_000       # ensemble cards: an FE ensemble of more runs than this is no ensemble one runs
MAX_MATERIAL = 64        # so that <name>_<card> (``_draw10000`` the longest) fits 80-character labels
MAX_REFIT_TERMS = 100    # Ansys's TB,PRONY limit; beyond it the 400 refit times no longer pin terms down
MAX_SEED = 2**32
CARD_SUFFIX = len("_draw") + len(str(MAX_DRAWS))


@dataclass
class ExportResult:
    out_dir: Path
    fmt: str
    files: list[Path]
    cards: CardSet
    context: Context
    status: str                        # written | up to date
    removed: list[Path] = field(default_factory=list)
    shift: str | None = None           # what the format carries of the run's shift law (None: no shift)

    def table(self) -> str:
        ctx, cs = self.context, self.cards
        nu = "not given" if ctx.poisson.value is None else f"{ctx.poisson.value:.4g}"
        lines = [f"export {ctx.run} -> {self.out_dir} ({self.fmt}; ν = {nu}, {ctx.poisson.source}): "
                 f"{self.status}"]
        head = (f"{'card':<10}{'E MPa':>10}{'G MPa':>10}{'tau_max s':>11}{'E(0) MPa':>11}"
                f"{'E_inf MPa':>11}{'terms':>7}")
        lines.append(head)
        for c in cs.cards[:3]:
            p = c.params
            lines.append(f"{c.label:<10}{fmt(p['E'], 5):>10}{fmt(p['G'], 5):>10}{fmt(p['tau_max'], 5):>11}"
                         f"{fmt(c.prony.e0, 5):>11}{fmt(c.prony.e_inf, 4):>11}{c.prony.terms:>7}")
        extra = cs.cards[3:]
        if extra:
            lines.append(f"ensemble: {len(extra)} cards from posterior draws ({extra[0].label} .. "
                         f"{extra[-1].label}), listed in {INDEX_FILE}")
        ch = cs.checks
        e0 = ", ".join(fmt(v, 5) for v in ch["E0"])
        until = ch["modulus_bracketed_until_s"]
        rng = cs.time_range
        brk = (f"in E(t) over the whole test range ({fmt(rng.t_lo, 3)}-{fmt(rng.t_hi, 4)} s)" if until is None
               else f"in E(t) up to t = {fmt(until, 3)} s only: beyond, the cards cross (a lower E comes "
                    "with a longer tau_max on the posterior ridge), so they are quantiles of E, not of the "
                    "long-time modulus: use the --draws ensemble for that")
        lines.append(f"check: q05/q95 bracket the median in E(0) ({e0} MPa): "
                     f"{'yes' if ch['E0_bracketed'] else 'NO'}; in the ramp to {100 * RAMP_CHECK_STRAIN:g} % "
                     f"at {fmt(rng.strain_rate, 3)} 1/s: {'yes' if ch['ramp_bracketed'] else 'NO'}; {brk}")
        law = ctx.shift
        at_ref = ("" if law is None or not law.has_temperature else
                  f" (the test's times at {law.test_temperature:g} °C; at T_ref = {law.reference:g} °C, "
                  "those times over each card's a_T)")
        if cs.terms is not None:
            lines.append(f"--terms {cs.terms}: refitted on {fmt(rng.t_lo, 3)}-{fmt(rng.t_hi, 4)} s{at_ref}; "
                         f"max error of E(t) {100 * ch['refit_max_error']:.3g} %, of the ramp to "
                         f"{100 * RAMP_CHECK_STRAIN:g} % (from {fmt(rng.t_lo, 3)} s) "
                         f"{100 * ch['refit_ramp_error']:.3g} % (worst card)")
        lines.append(f"limit: the card follows the DNLR model within {100 * SMALL_STRAIN_TOLERANCE:g} % "
                     f"up to a strain of {fmt(ctx.small_strain_limit, 3)} at {fmt(rng.strain_rate, 3)} 1/s"
                     f"{_against(law)}; the viscoplastic hardening beyond needs a user material (the files "
                     "say so)")
        if self.shift is not None:
            lines.append(f"shift: {self.shift}")
        lines.append(f"files: {len(self.files)} in {self.out_dir}"
                     + (f"; removed {len(self.removed)} stale draw cards" if self.removed else ""))
        return "\n".join(lines)


def _against(law: ShiftLaw | None) -> str:
    """How the limit was measured for a shifted model (nothing without a shift)."""
    if law is None:
        return ""
    at = (f" and {law.test_temperature:g} °C (the card shifted there by a_T)"
          if law.has_temperature and law.test_temperature is not None else "")
    stress = ", its stress shift included" if law.has_stress else ""
    return f"{at}, against the model with its shift factor{stress}"


def material_name(name: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return s if s[:1].isalpha() else f"M_{s}"


def printable(text: str) -> str:
    """``text`` for a comment line of a card: control characters (a newline would end the comment and
    the rest be read as input) and non-ASCII (Abaqus reads 7-bit ASCII) written as escapes."""
    return "".join(c if " " <= c <= "~" else c.encode("unicode_escape").decode("ascii") for c in text)


def _check_options(terms: int | None, draws: int, seed: int, material: str | None, modes: int,
                   run_name: str) -> str:
    """The options that size the work, within bounds (before any work); the material name."""
    if not 0 <= draws <= MAX_DRAWS:
        raise BayesDnlrError(f"--draws {draws}: give 0 to {MAX_DRAWS} ensemble cards")
    if terms is not None:
        top = min(modes, MAX_REFIT_TERMS)
        if not 1 <= terms <= top:
            raise BayesDnlrError(
                f"--terms {terms}: give 1 to {top} terms (a refit of the model's {modes}-mode series, "
                f"model.modes; at most {MAX_REFIT_TERMS}, Ansys's limit); without --terms the cards "
                "hold the model's own series")
    if not 0 <= seed < MAX_SEED:
        raise BayesDnlrError(f"--seed {seed}: give 0 <= seed < 2**32")
    mat = material_name(material if material is not None else run_name)
    if len(mat) > MAX_MATERIAL:
        what = (f"{len(mat)} characters" if material is not None
                else f"the run's name, the default material name, has {len(mat)} characters")
        raise BayesDnlrError(
            f"--material: {what}, more than {MAX_MATERIAL}; Abaqus labels and LS-DYNA's "
            f"title line hold 80, and the card's name adds up to {CARD_SUFFIX} (_draw{MAX_DRAWS}): give "
            f"--material with at most {MAX_MATERIAL} letters, digits or _")
    return mat


def _config(run_dir: Path):
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.folder import find_config

    try:
        return load_config(find_config(run_dir))
    except FileNotFoundError as err:
        raise RunError(f"export: {err}") from None


def _time_range(fit: dict, run_dir: Path) -> TimeRange:
    try:
        t0, t1 = (float(v) for v in fit["window"]["time"])
        n = int(fit["window"]["n_points"])
        rate = float(fit["strain_rate"])
    except (KeyError, TypeError, ValueError):
        raise RunError(f"{run_dir}/fit.json: no window time range or strain rate; re-run `fit`") from None
    if not (t1 > t0 and n > 1 and rate > 0):
        raise RunError(f"{run_dir}/fit.json: the window spans {t0:g}-{t1:g} s with {n} points at "
                       f"{rate:g} 1/s: no time range to export for")
    step = (t1 - t0) / (n - 1)
    return TimeRange(min(step, STRAIN_FLOOR / rate), t1 - t0, rate)


def resolve_poisson(nu: float | None, cfg) -> Poisson:
    """--nu, else the slope of the data's transverse strain, else None (said so)."""
    if nu is not None:
        return Poisson(float(nu), "--nu")
    if cfg.data is not None and cfg.data.columns.eps22 is not None:
        from bayes_dnlr.data import load_test

        test = load_test(cfg)
        end = test.strain.size
        if test.relaxation_start is not None:
            end = int(np.searchsorted(test.time, test.relaxation_start, "right"))
        value, n, top = poisson_from_strains(test.strain[:end], test.transverse_strain[:end])
        return Poisson(value, f"from the data's transverse strain: slope of -ε22 against ε11 over "
                              f"0 < ε11 <= {top:.3g}, {n} samples")
    return Poisson(None, "the data have no transverse strain (data.columns.eps22) and --nu was not given")


CARD_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*_(median|q05|q95|draw\d+)\.")


def _targets(out_dir: Path, files: dict[str, str], force: bool, extension: str) -> tuple[str, list[Path]]:
    """Refuse to replace a different file without ``force``; the stale cards the new set drops. The
    set is published as a whole folder, so a folder holding other files is refused outright."""
    if out_dir.exists() and not out_dir.is_dir():
        raise RunError(f"{out_dir}: a file, not a folder for the cards; give --out a folder")
    present = sorted(p for p in out_dir.iterdir()) if out_dir.is_dir() else []
    foreign = [p.name for p in present if p.name not in files and p.name != INDEX_FILE
               and not (p.is_file() and CARD_NAME.match(p.name) and p.suffix == f".{extension}")]
    if foreign:
        raise RunError(f"{out_dir}: holds {len(foreign)} file(s) that are not cards of this format "
                       f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}); the cards are "
                       "published as a whole folder that replaces it: give --out an empty or new folder")
    differ = [n for n, text in files.items()
              if (out_dir / n).is_file() and (out_dir / n).read_text() != text]
    stale = [p for p in present if p.name not in files]
    if (differ or stale) and not force:
        what = differ[:3] + [p.name for p in stale[:3]]
        raise RunError(f"{out_dir}: {len(differ) + len(stale)} existing file(s) differ from this export "
                       f"({', '.join(what)}{', ...' if len(differ) + len(stale) > 3 else ''}); not "
                       "overwritten. Pass --force to replace them, or --out for another folder")
    same = all((out_dir / n).is_file() for n in files) and not differ and not stale
    return ("up to date" if same else "written"), stale


def export(run_dir: str | Path, fmt_name: str, *, terms: int | None = None, draws: int = 0,
           nu: float | None = None, density: float | None = None, out: str | Path | None = None,
           material: str | None = None, seed: int = 0, force: bool = False) -> ExportResult:
    """Write the cards of the finished run ``run_dir`` in ``fmt_name`` (docs/export.md)."""
    from bayes_dnlr.runs.draws import load_run_draws

    if fmt_name not in FORMATS:
        raise BayesDnlrError(f"--format {fmt_name!r}: expected one of {', '.join(FORMATS)}")
    form = FORMATS[fmt_name]
    if density is not None and not (math.isfinite(density) and density > 0):
        raise BayesDnlrError(f"--density {density:g}: a mass density in kg/m³ is > 0")
    run_dir = Path(run_dir)
    run = load_run_draws(run_dir, key="export")
    cfg = _config(run_dir)
    if not plain_names(cfg):
        raise BayesDnlrError(f"export: {run_dir} is a run with several tests (tests:); export one "
                             "test's own run directory instead (not supported yet for joint runs)")
    modes, decades = cfg.model.modes, cfg.model.decades
    mat = _check_options(terms, draws, seed, material, modes, cfg.name)
    if fmt_name == "ls-dyna":
        n_terms = (terms if terms is not None else modes) + 1
        if n_terms > lsdyna.MAX_TERMS:
            raise BayesDnlrError(
                f"--terms: LS-DYNA *MAT_GENERAL_VISCOELASTIC takes at most {lsdyna.MAX_TERMS} terms (the "
                f"long-term one included); the model's series has {modes}: give --terms "
                f"{lsdyna.MAX_TERMS - 1} or fewer (a refit over the test's time range; its error is printed)")
        if density is None:
            raise BayesDnlrError("--density: LS-DYNA needs the mass density RO (in kg/m³; it is written "
                                 "in tonne/mm³)")
    poisson = resolve_poisson(nu, cfg)
    check_poisson(poisson, form.solver)
    if poisson.value is not None and not -1.0 < poisson.value <= 0.5:
        raise BayesDnlrError(f"--nu {poisson.value:g}: Poisson's ratio lies in (-1, 0.5]")
    shift = shift_of(cfg)
    values = {k: (run.values[k] if k in run.values
                  else np.full(run.n_draws, float(cfg.fixed_values[k])) if k in cfg.fixed_values else None)
              for k in ("E", "G", "tau_max", "alpha", *shift.parameters)}
    if values["alpha"] is None:         # a run made before the spectrum's exponent: eq. 12
        del values["alpha"]
    missing = [k for k, v in values.items() if v is None]
    if missing:
        needs = "E, G and tau_max" + (" and the shift law's parameters" if shift.parameters else "")
        raise RunError(f"{run_dir}: the posterior has no draws of {missing} and the config does not fix "
                       f"them; export needs {needs}")
    if not run.fit:
        raise RunError(f"{run_dir}: no fit.json (the test's time range comes from it); run `fit`")
    rng = _time_range(run.fit, run_dir)
    law = _shift_law(cfg, shift, values)
    cards = make_cards(values, modes, decades, rng, terms=terms, draws=draws, seed=seed,
                       a_test=None if law is None or not law.has_temperature else law.a_T)
    cards.checks = bracket_checks(cards.cards, rng)
    if terms is not None:
        errs = [(c.refit.max_error,
                 ramp_error(c.at_test, from_parameters(c.params["E"], c.params["G"], c.params["tau_max"],
                                                       modes, decades,
                                                       c.params.get("alpha", UNIVERSAL_EXPONENT)
                                                       ).scaled(c.a_test),
                            rng.strain_rate, rng.t_lo))
                for c in cards.cards]
        cards.checks["refit_max_error"] = max(e for e, _ in errs)
        cards.checks["refit_ramp_error"] = max(r for _, r in errs)
    median = cards.cards[1] if cards.cards[1].label == "median" else cards.cards[0]
    limit = small_strain_limit(median, rng.strain_rate, modes, decades, shift=shift,
                               temperature=None if law is None else law.test_temperature)
    ctx = Context(material=mat, run=printable(str(run_dir)), poisson=poisson, density=density, modes=modes,
                  decades=decades, strain_rate=rng.strain_rate, small_strain_limit=limit,
                  t_range=(rng.t_lo, rng.t_hi), notes=_notes(cfg), shift=law)
    files = {f"{mat}_{c.label}.{form.extension}": form.render(c, ctx) for c in cards.cards}
    carried = None if law is None else form.shift(law, median.params).summary
    files[INDEX_FILE] = index_csv(cards, ctx, carried)
    # the default folder is the run's own: no link in it is followed (--out is the user's choice)
    out_dir = (Path(out) if out is not None
               else own_dir(own_dir(run_dir / EXPORT_DIR, make=False) / fmt_name, make=False))
    recover_folder(out_dir)
    status, stale = _targets(out_dir, files, force, form.extension)
    if status == "written":
        # the whole set at once: a killed export leaves the old cards or the new ones
        with folder_set(out_dir) as tmp:
            for name, text in files.items():
                (tmp / name).write_text(text, encoding="utf-8")
    return ExportResult(out_dir, fmt_name, [out_dir / n for n in files], cards, ctx, status, stale,
                        carried)


def _shift_law(cfg, shift, values: dict[str, np.ndarray]) -> ShiftLaw | None:
    """The run's shift law for its cards (None without one): the test's temperature (a column's
    mean), and the posterior's spread of the law's parameters."""
    if shift.is_none:
        return None
    temperature = None
    if shift.temperature != "none":
        from bayes_dnlr.data import load_test
        from bayes_dnlr.runs.modulus_block import at_temperature

        temperature = at_temperature(cfg, load_test(cfg)).value
    return ShiftLaw(shift.temperature, shift.reference_temperature, shift.stress, shift.driving,
                    temperature, spread_of(values, cfg.fixed_values, shift.parameters))


def _notes(cfg) -> list[str]:
    notes = []
    fixed = [k for k in ("E", "G", "tau_max", *cfg.model.shift.parameters) if k in cfg.fixed_values]
    if fixed:
        notes.append(f"{', '.join(fixed)} fixed in the run's config (no uncertainty from them).")
    if cfg.has_relaxation:
        notes.append("The run's relaxation phase (sigma_inf, tau_max_R: a shifted spectrum during the "
                     "hold, section 4.1) is not in the card: it is the tensile phase's response.")
    return notes


def _column(name: str) -> str:
    """A parameter's column in cards.csv: its name and unit (``Ea_kJ_mol``; ``C1``: no unit)."""
    u = unit(name)
    return name if u in ("", "-") else f"{name}_{u.replace('/', '_')}"


def index_csv(cards: CardSet, ctx: Context, carried: str | None = None) -> str:
    """One row per card: its draw, parameters, series and checks (the file's header says more); a
    shifted run's also its shift parameters, and what the format carries of the law."""
    law = ctx.shift
    names = () if law is None else law.parameters
    lines = [f"# bayes_dnlr export of {ctx.run}: cards of the small-strain Prony series (docs/export.md)",
             f"# checks: {json.dumps(cards.checks)}"]
    if law is not None:
        lines.append(f"# shift: temperature {law.temperature}, stress {law.stress}; the series are at the "
                     f"reference state; this format: {carried}")
    lines.append("card,quantile_of_E,posterior_draw,E_MPa,G_MPa,tau_max_s,alpha,E0_MPa,E_inf_MPa,terms,"
                 "refit_max_error" + "".join(f",{_column(k)}" for k in names))
    for c in cards.cards:
        p = c.params
        q = "" if c.quantile_of_E is None else f"{c.quantile_of_E:g}"
        err = "" if c.refit is None else f"{c.refit.max_error:.4g}"
        lines.append(f"{c.label},{q},{c.draw_index},{p['E']:.10g},{p['G']:.10g},{p['tau_max']:.10g},"
                     f"{p.get('alpha', UNIVERSAL_EXPONENT):.10g},{c.prony.e0:.10g},"
                     f"{c.prony.e_inf:.10g},{c.prony.terms},{err}" + "".join(f",{p[k]:.10g}" for k in names))
    return "\n".join(lines) + "\n"
