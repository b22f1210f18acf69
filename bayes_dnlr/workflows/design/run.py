"""``python -m bayes_dnlr design design.yaml``: the predicted uncertainty of every planned test and
the recommended one (docs/design.md).

Writes ``<design folder>/<name>/`` (or ``output.dir``): design.csv (every candidate), design.md
(the best candidates, the recommendation), design.json (all of it, with the design's digest) and,
from the report layer, err_E.png. A design.json made from another design is never replaced without
``overwrite`` (``--force``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bayes_dnlr.config import ConfigError
from bayes_dnlr.csvcells import safe_cell
from bayes_dnlr.digests import digest, file_sha256
from bayes_dnlr.errors import BayesDnlrError, DamagedFileError, RunError
from bayes_dnlr.inference.test_model import shift_of
from bayes_dnlr.numbers import fmt, share
from bayes_dnlr.readback import read_json
from bayes_dnlr.runs.folder import jsonable, write_atomic, write_json
from bayes_dnlr.runs.layout import POSTERIOR_FILE
from bayes_dnlr.runs.testset import plain_names
from bayes_dnlr.vocabulary import PARAMETER_NAMES, RELAXATION_PARAMETERS, TENSILE_PARAMETERS
from bayes_dnlr.workflows.design.candidates import expand
from bayes_dnlr.workflows.design.config import DesignConfig
from bayes_dnlr.workflows.design.fisher import Draws, ErrorModel, NoiseDraw, Prediction, predict

RESULT_FILE = "design.json"
TABLE_FILE = "design.csv"
MARKDOWN_FILE = "design.md"
FIGURE_FILE = "err_E.png"
TOP = 10


# ---------------------------------------------------------------- what to average over

def _run_noise(run, keep: np.ndarray) -> tuple[list[NoiseDraw], str, str, str]:
    """The noise model a finished run's posterior used, one NoiseDraw per kept draw."""
    s, v = run.summary, run.values
    n = keep.size
    if "sigma0" in v:
        sigma0 = v["sigma0"][keep]
    else:
        s0 = s.get("sigma0")
        if not isinstance(s0, int | float):
            raise RunError(f"from_run: {run.run_dir}: summary.json has no single sigma0 ({s0!r}); give "
                           "noise: {sigma0: ...} in the design")
        sigma0 = np.full(n, float(s0))
    block = s.get("noise") or {}
    if block.get("model") != "discrepancy":
        return [NoiseDraw(float(x)) for x in sigma0], "exp", "time", "white (as the run's posterior)"

    def hyper(name: str, key: str) -> np.ndarray:
        if name in v:
            return v[name][keep]
        value = (block.get(key) or {}).get("value")
        if value is None:
            raise RunError(f"from_run: {run.run_dir}: summary.json's noise block has no {key}; give "
                           "noise: in the design")
        return np.full(n, float(value))

    amp, length = hyper("disc_amplitude", "amplitude"), hyper("disc_length", "length")
    noise = [NoiseDraw(float(a), float(b), float(c)) for a, b, c in zip(sigma0, amp, length, strict=True)]
    return noise, block.get("kernel", "exp"), block.get("axis", "time"), \
        f"the run's model discrepancy ({block.get('kernel')} kernel on the {block.get('axis')} axis)"


def run_error_models(fit: dict[str, Any], sampled: str) -> list[ErrorModel]:
    """The kernels of a run's model of the error with their weights and maximum-likelihood noise
    (fit.json ``discrepancy.projection.kernels``) when they put weight on another kernel than the
    sampled one: then the run's intervals are the sampled posterior widened by their sandwich, and
    the predictions carry the same sandwich. Empty otherwise."""
    kernels = (((fit.get("discrepancy") or {}).get("projection") or {}).get("kernels") or {})
    models = []
    for kind, k in kernels.items():
        h, w = k.get("hyperparameters") or {}, float(k.get("weight") or 0.0)
        if w > 0 and all(h.get(key) is not None for key in ("sigma0", "amplitude", "length")):
            models.append(ErrorModel(w, kind, NoiseDraw(float(h["sigma0"]), float(h["amplitude"]),
                                                        float(h["length"]))))
    return models if any(m.kernel != sampled for m in models) else []


def error_model_note(models: list[ErrorModel], summary: dict[str, Any]) -> str:
    """The design's words on the sandwich it carries from the run (empty: none)."""
    if not models:
        return ""
    proj = ((summary.get("noise") or {}).get("projection") or {})
    factors = ", ".join(f"{k} {float(f):.3g}x" for k, f in (proj.get("sd_factor") or {}).items())
    weights = ", ".join(f"{m.kernel} {share(m.weight)}" for m in models)
    return (f"the predicted sd carry the run's widening for the kernels' model of the error ({weights}, "
            "their maximum-likelihood hyperparameters), as `sample` reports the run's intervals"
            + (f" (there: sd {factors} the sampled kernel's alone)" if factors else "")
            + " (docs/design.md, 'Method')")


def resolve_draws(cfg: DesignConfig) -> tuple[Draws, list[str], dict[str, Any]]:
    """(the draws to average over, the free parameters, facts about the source)."""
    if cfg.parameters is not None:
        params = [dict(cfg.parameters)]
        noise = cfg.noise
        d = noise.discrepancy
        nd = (NoiseDraw(noise.sigma0) if d == "none" else NoiseDraw(noise.sigma0, d.amplitude, d.length))
        draws = Draws(params, [nd], kernel="exp" if d == "none" else d.kernel,
                      axis="time" if d == "none" else d.axis, source="the parameter guess",
                      start="stationary" if d == "none" else d.start)
        default_free = [k for k in PARAMETER_NAMES if k in cfg.parameters]
        return draws, cfg.free or default_free, {"parameters": "guess"}
    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.draws import load_run_draws
    from bayes_dnlr.runs.folder import find_config

    run = load_run_draws(cfg.run_path, key="from_run")
    try:
        run_cfg = load_config(find_config(cfg.run_path))
    except FileNotFoundError as err:
        raise RunError(f"from_run: {err}") from None
    if not plain_names(run_cfg):
        raise BayesDnlrError(f"from_run: {cfg.run_path} is a run with several tests; give one test's run "
                             "(joint runs are not supported by design yet)")
    fixed = run_cfg.fixed_values
    missing = [k for k in TENSILE_PARAMETERS if k not in run.values and k not in fixed]
    if missing:
        raise RunError(f"from_run: {cfg.run_path} has no draws or fixed values of {missing}")
    needs_relax = max(cfg.conditions.hold.points()) > 0
    names = [k for k in PARAMETER_NAMES if k in run.values or k in fixed]
    if needs_relax and not all(k in names for k in RELAXATION_PARAMETERS):
        raise ConfigError(f"{cfg.source}: conditions.hold: a hold > 0 needs sigma_inf and tau_max_R, which "
                          f"the run {cfg.run_path} has no draws of (it had no relaxation)")
    rng = np.random.default_rng(cfg.seed)
    keep = np.sort(rng.choice(run.n_draws, size=min(cfg.draws, run.n_draws), replace=False))
    params = [{k: float(run.values[k][i]) if k in run.values else float(fixed[k]) for k in names}
              for i in keep]
    if cfg.noise == "from_run":
        noise, kernel, axis, what = _run_noise(run, keep)
        start = run_cfg.noise.discrepancy.start if run_cfg.noise.has_discrepancy else "stationary"
    else:
        d = cfg.noise.discrepancy
        nd = (NoiseDraw(cfg.noise.sigma0) if d == "none"
              else NoiseDraw(cfg.noise.sigma0, d.amplitude, d.length))
        noise, kernel, axis = [nd] * keep.size, ("exp" if d == "none" else d.kernel), \
            ("time" if d == "none" else d.axis)
        start = "stationary" if d == "none" else d.start
        what = "the design's noise"
    models = run_error_models(run.fit, kernel) if cfg.noise == "from_run" else []
    draws = Draws(params, noise, kernel, axis,
                  source=f"{keep.size} posterior draws of {cfg.run_path}; noise: {what}", start=start,
                  note=error_model_note(models, run.summary or {}), widen=models)
    free = cfg.free or [k for k in run.parameters if k in PARAMETER_NAMES]
    nc = Path(cfg.run_path) / POSTERIOR_FILE
    facts = {"run": str(cfg.run_path), "posterior_sha256": file_sha256(nc), "draws": int(keep.size)}
    return draws, free, facts


# ---------------------------------------------------------------- the result

@dataclass
class DesignResult:
    cfg: DesignConfig
    draws: Draws
    free: list[str]
    predictions: list[Prediction]
    recommended: Prediction
    criterion: str
    out_dir: Path
    wall_time_s: float
    source: dict[str, Any] = field(default_factory=dict)
    digest: str = ""
    files: list[Path] = field(default_factory=list)

    def ranked(self) -> list[Prediction]:
        """Feasible, identifiable candidates, best first."""
        ok = [p for p in self.predictions if p.feasible and math.isfinite(p.value(self.criterion))]
        return sorted(ok, key=lambda p: p.value(self.criterion))

    def noise_text(self) -> str:
        nz = self.draws.noise[0]
        if self.draws.white:
            per = " (per draw)" if self.draws.n > 1 else ""
            return f"white noise, sigma0 {fmt(nz.sigma0, 3)} MPa{per}"
        unit = "s" if self.draws.axis == "time" else "strain"
        pinned = ", pinned at the start" if self.draws.start == "pinned" else ""
        return (f"sigma0 {fmt(nz.sigma0, 3)} MPa + model discrepancy ({self.draws.kernel} on the "
                f"{self.draws.axis} axis{pinned}, amplitude {fmt(nz.amplitude, 3)} MPa, length "
                f"{fmt(nz.length, 3)} {unit})" + (" (first draw shown)" if self.draws.n > 1 else ""))

    def rows(self) -> list[dict[str, Any]]:
        """One flat row per candidate (design.csv)."""
        names = [k for k in PARAMETER_NAMES if any(k in p.names for p in self.predictions)]
        out = []
        for p in self.predictions:
            c = p.candidate
            row: dict[str, Any] = {
                "candidate": c.index, "strain_rate": c.strain_rate, "strain_max": c.strain_max,
                "sample_rate": c.sample_rate, "n_points_planned": c.n_points, "hold": c.hold,
                "window": c.window, "duration_s": c.duration, "points": p.total_points,
                "window_points": p.n_points, "feasible": p.feasible, "identifiable": p.identifiable,
                "free": " ".join(p.names)}
            for k in names:
                row[f"sd_{k}"] = p.sd.get(k)
                row[f"err_{k}"] = p.err.get(k)
            for i, a in enumerate(p.names):
                for j in range(i + 1, len(p.names)):
                    row[f"rho_{a}_{p.names[j]}"] = float(p.correlation[i, j])
            row.update({"D": p.D, "A": p.A, "criterion": p.value(self.criterion), "note": p.note})
            out.append(row)
        return out

    def table(self, top: int = TOP) -> str:
        """Console output: the best candidates and the recommendation."""
        r = self.recommended
        c = r.candidate
        lines = [f"design {self.cfg.name}: {len(self.predictions)} candidates, {self.draws.source}; "
                 f"{self.noise_text()}; criterion {self.criterion}; {self.wall_time_s:.2f} s"]
        lines += _ranking_lines(self, top)
        lines.append(f"recommended: {c.label()} ({c.duration:.4g} s, {r.total_points} points): "
                     + ", ".join(f"Err({k}) {100 * v:.3g} %" for k, v in r.err.items())
                     + f"; sd(E) {fmt(r.sd.get('E'), 3)} MPa")
        if len(r.names) > 1:
            i, j = np.unravel_index(np.argmax(np.abs(np.triu(r.correlation, 1))), r.correlation.shape)
            lines.append(f"  strongest correlation: rho({r.names[i]}, {r.names[j]}) = "
                         f"{r.correlation[i, j]:+.4f}")
        skipped = [p for p in self.predictions if not p.feasible]
        if skipped:
            lines.append(f"outside the constraints: {len(skipped)} candidates")
        unident = [p for p in self.predictions if p.feasible and not p.identifiable]
        if unident:
            lines.append(f"not identifiable: {len(unident)} candidates ({unident[0].note})")
        if self.draws.note:
            lines.append(f"note: {self.draws.note}")
        if self.files:
            lines.append(f"outputs: {self.out_dir}/{{{', '.join(f.name for f in self.files)}}}")
        return "\n".join(lines)


def _ranking_lines(res: DesignResult, top: int) -> list[str]:
    ranked = res.ranked()[:top]
    names = [k for k in PARAMETER_NAMES if any(k in p.names for p in ranked)]
    head = (f"{'#':>3} {'rate 1/s':>9} {'strain':>7} {'sampling':>11} {'hold s':>7} {'window':>8} "
            f"{'dur. s':>8} {'points':>7} " + " ".join(f"{'Err(' + k + ') %':>14}" for k in names)
            + f" {'D':>8} {'A':>9}")
    lines = [head]
    for rank, p in enumerate(ranked, 1):
        c = p.candidate
        samp = f"{c.sample_rate:g} Hz" if c.sample_rate is not None else f"{c.n_points} pts"
        errs = " ".join(f"{(100 * p.err[k]) if k in p.err else float('nan'):>14.4g}" for k in names)
        lines.append(f"{rank:>3} {c.strain_rate:>9.3g} {c.strain_max:>7.3g} {samp:>11} {c.hold:>7.4g} "
                     f"{c.window:>8} {c.duration:>8.4g} {p.total_points:>7} {errs} {p.D:>8.2f} {p.A:>9.3g}")
    return lines


# ---------------------------------------------------------------- running it

def _digest(cfg: DesignConfig, source: dict[str, Any]) -> str:
    return digest({"design": cfg.model_dump(mode="json"), "source": source})


def _check_overwrite(out_dir: Path, new_digest: str, overwrite: bool) -> None:
    path = out_dir / RESULT_FILE
    if overwrite or not path.is_file():
        return
    try:
        old = read_json(path, RESULT_FILE).get("digest")
    except (OSError, DamagedFileError):
        old = None
    if old != new_digest:
        raise RunError(f"{path} exists and was made from another design (or another posterior); not "
                       "overwritten. Pass --force to replace it, or set output.dir")


def no_candidate_error(cfg: DesignConfig, preds: list[Prediction]) -> BayesDnlrError:
    """Why no candidate can be recommended, naming the key."""
    where = cfg.source or "design"
    k = cfg.constraints
    if not any(p.feasible for p in preds):
        parts = []
        if k.max_duration is not None:
            shortest = min(p.candidate.duration for p in preds)
            if shortest > k.max_duration:
                parts.append(f"constraints.max_duration: no candidate meets it: the shortest planned test "
                             f"lasts {shortest:.4g} s > {k.max_duration:g} s")
        if k.max_points is not None:
            fewest = min(p.total_points for p in preds)
            if fewest > k.max_points:
                parts.append(f"constraints.max_points: no candidate meets it: the smallest planned test "
                             f"has {fewest} points > {k.max_points}")
        if not parts:
            parts.append("constraints: no candidate meets max_duration and max_points together; widen "
                         "one or plan other conditions")
        return ConfigError(f"{where}: " + "; ".join(parts))
    notes = sorted({p.note for p in preds if p.feasible and not p.identifiable and p.note})
    return ConfigError(f"{where}: conditions: no candidate within the constraints identifies the free "
                       f"parameters for criterion {cfg.criterion} "
                       f"({'; '.join(notes) or 'criterion undefined'})")


def run_design(cfg: DesignConfig, *, overwrite: bool = False, write: bool = True) -> DesignResult:
    """Predict every candidate, recommend one and write the tables (docs/design.md)."""
    t0 = time.perf_counter()
    draws, free, source = resolve_draws(cfg)
    d = _digest(cfg, source)
    out_dir = cfg.out_dir
    if write:
        _check_overwrite(out_dir, d, overwrite)
    kind, _, name = cfg.criterion.partition("_")
    if kind in ("sd", "err") and name not in free:
        raise ConfigError(f"{cfg.source or 'design'}: criterion: {cfg.criterion} asks about {name}, which "
                          f"is not free (free: {', '.join(free)})")
    k = cfg.constraints
    preds = [predict(c, draws, free, cfg.model.modes, cfg.model.decades, k.max_duration, k.max_points,
                     shift_of(cfg))
             for c in expand(cfg)]
    ok = [p for p in preds if p.feasible and math.isfinite(p.value(cfg.criterion))]
    if not ok:
        raise no_candidate_error(cfg, preds)
    best = min(ok, key=lambda p: p.value(cfg.criterion))
    result = DesignResult(cfg, draws, list(free), preds, best, cfg.criterion, out_dir,
                          time.perf_counter() - t0, source, d)
    if write:
        write_tables(result)
    return result


def to_dict(res: DesignResult) -> dict[str, Any]:
    r = res.recommended

    def one(p: Prediction) -> dict[str, Any]:
        c = p.candidate
        return {"candidate": c.index, "label": c.label(), "strain_rate": c.strain_rate,
                "strain_max": c.strain_max, "sample_rate": c.sample_rate, "n_points": c.n_points,
                "hold": c.hold, "window": c.window, "duration_s": c.duration, "points": p.total_points,
                "window_points": p.n_points, "feasible": p.feasible, "identifiable": p.identifiable,
                "parameters": p.names, "sd": p.sd, "err": p.err, "correlation": p.correlation,
                "delta_tilde": p.delta_tilde, "D": p.D, "A": p.A, "criterion": p.value(res.criterion),
                "note": p.note}

    from bayes_dnlr import __version__

    return jsonable({
        "name": res.cfg.name, "criterion": res.criterion, "digest": res.digest, "source": res.source,
        "averaged_over": res.draws.n, "noise": res.noise_text(), "free": res.free,
        "error_model": res.draws.note,
        "recommended": one(r), "candidates": [one(p) for p in res.predictions],
        "wall_time_s": res.wall_time_s, "version": __version__,
        "design": res.cfg.model_dump(mode="json"),
    })


def _csv(rows: list[dict[str, Any]]) -> str:
    keys: list[str] = []
    for row in rows:
        keys += [k for k in row if k not in keys]

    def cell(v: Any) -> str:
        if v is None or (isinstance(v, float) and not math.isfinite(v)):
            return ""
        if isinstance(v, float):
            return f"{v:.6g}"
        s = safe_cell(str(v))
        return '"' + s.replace('"', '""') + '"' if ("," in s or '"' in s or "\n" in s) else s

    head = ",".join(cell(k) for k in keys)
    return "\n".join([head] + [",".join(cell(r.get(k)) for k in keys) for r in rows]) + "\n"


def markdown(res: DesignResult, figure: str | None = None) -> str:
    r = res.recommended
    c = r.candidate
    lines = [f"# Design {res.cfg.name}", "",
             f"{len(res.predictions)} candidates; {res.draws.source}; {res.noise_text()}; "
             f"criterion `{res.criterion}` (smaller is better).", "",
             *([f"**Note:** {res.draws.note}", ""] if res.draws.note else []),
             f"**Recommended:** {c.label()} ({c.duration:.4g} s, {r.total_points} points).", "",
             "| parameter | predicted sd | Err |", "|---|---|---|"]
    lines += [f"| {k} | {fmt(r.sd[k], 3)} | {100 * r.err[k]:.3g} % |" for k in r.names]
    lines += ["", "Predicted Δ̃ (eq. 35: Err on the diagonal, ρ off it):", "",
              "| | " + " | ".join(r.names) + " |", "|---" * (len(r.names) + 1) + "|"]
    for i, a in enumerate(r.names):
        cells = [f"{100 * r.delta_tilde[i, j]:.3g} %" if i == j else f"{r.delta_tilde[i, j]:+.4f}"
                 for j in range(len(r.names))]
        lines.append(f"| {a} | " + " | ".join(cells) + " |")
    lines += ["", f"Best {min(TOP, len(res.ranked()))} candidates within the constraints:", "", "```"]
    lines += _ranking_lines(res, TOP) + ["```", ""]
    if figure:
        lines += [f"![Predicted Err(E)]({figure})", ""]
    lines.append("All candidates: design.csv. Method: docs/design.md.")
    return "\n".join(lines) + "\n"


def write_tables(res: DesignResult) -> None:
    res.out_dir.mkdir(parents=True, exist_ok=True)
    write_atomic(res.out_dir / TABLE_FILE, _csv(res.rows()))
    write_atomic(res.out_dir / MARKDOWN_FILE, markdown(res, FIGURE_FILE))
    write_json(res.out_dir / RESULT_FILE, to_dict(res))
    res.files = [res.out_dir / n for n in (TABLE_FILE, MARKDOWN_FILE, RESULT_FILE)]
