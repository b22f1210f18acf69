"""E(t) at the reference temperature of a run whose tests were made at several temperatures: the
master curve of time-temperature superposition (the shift factor a_T, docs/theory.md).

A test at temperature T measures E(t) at its own temperature over its resolved times [t₁, t₂];
with the run's temperature law the same modes at the reference temperature relax a_T(T) times
faster, so that test measures the reference E(t) over the reduced times [t₁/a_T, t₂/a_T]. The
master curve is E(t) at the reference temperature over the union of those windows: a test below
the reference temperature (a_T > 1) reaches shorter reduced times than any test at it, which is how
E^u is approached from data. Each reported time is estimated (inference/modulus_estimate.py) from
the draws of the test whose reduced window holds it, with that test's band, spread and checks; a
time no window holds is an extrapolation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from bayes_dnlr.config import Config
from bayes_dnlr.inference.checks.band import Band
from bayes_dnlr.inference.modulus_estimate import (
    AtTemperature,
    BoundRefit,
    Source,
    estimate,
    fit_source,
)
from bayes_dnlr.inference.modulus_window import ResolvedWindow, nice_time
from bayes_dnlr.runs.modulus_block import at_temperature, has_modulus, judged, resolved
from bayes_dnlr.runs.testset import TestSet
from bayes_dnlr.runs.verdict import modulus_reasons

MAX_TIMES = 6        # the default reference times: the shortest, then one per decade
NO_SPREAD = ("the exponent's spread comes from one test's own fit, which a curve shared by the "
             "tests does not follow: sample parameters.alpha to carry it")


def reduced_windows(cfg: Config, tests: TestSet, sources: Mapping[str, Source],
                    fits: Mapping[str, Mapping[str, Any]]) -> dict[str, dict]:
    """Each test's resolved window (to the end of its linear range) at its temperature and in
    reduced time at the reference one (divided by a_T at the draws' median)."""
    out = {}
    for t, source in sources.items():
        view, data = cfg.for_test(t), tests.tests[t]
        at = at_temperature(view, data)
        a = float(at.factor(source.point())) if at.shifted else 1.0
        w = resolved(view, data, source, fits.get(t) or {})[2]
        out[t] = {"temperature": at.value, "a_T": a, "resolved": [w.shortest, w.longest],
                  "reduced": [w.shortest / a, w.longest / a]}
    return out


def default_times(windows: Mapping[str, dict]) -> list[float]:
    """The shortest reduced time any test resolves, rounded up to 1-2-5, then one time per decade
    up to the longest (MAX_TIMES at most)."""
    lo = min(w["reduced"][0] for w in windows.values())
    hi = max(w["reduced"][1] for w in windows.values())
    first = nice_time(lo)
    times = [first] if first <= hi else [lo]
    k = math.floor(math.log10(times[0])) + 1
    while len(times) < MAX_TIMES and 10.0**k <= hi:
        times.append(float(f"{10.0**k:.12g}"))
        k += 1
    return times


def _holder(windows: Mapping[str, dict], t: float) -> tuple[str, bool]:
    """The test whose reduced window holds ``t`` (the one that holds it farthest from its edges, in
    log time), or the nearest one when none does."""
    def margin(w: dict) -> float:
        lo, hi = w["reduced"]
        return min(math.log(t / lo), math.log(hi / t))
    best = max(windows, key=lambda k: margin(windows[k]))
    return best, margin(windows[best]) >= -1e-9


def _law_check(block: Mapping[str, Any] | None, temperature: float,
               reference: float) -> dict[str, Any] | None:
    """The held-out check (runs/shift_law.py) of the tests at ``temperature``, for E(t) the law
    carries from there to the reference temperature; None at the reference or where unchecked."""
    if not block or temperature == reference:
        return None
    for e in block.get("held_out") or []:
        if e["temperature"] == temperature and e["tests"]:
            return {"temperature": temperature, "ok": all(x["ok"] for x in e["tests"].values())}
    return None


def master_curve(cfg: Config, tests: TestSet, sources: Mapping[str, Source],
                 bands: Mapping[str, Band], fits: Mapping[str, Mapping[str, Any]],
                 refits: Mapping[str, Sequence[BoundRefit]], noise_ok: Mapping[str, bool],
                 shift_law: Mapping[str, Any] | None = None) -> dict[str, Any] | None:
    """The ``modulus_reference`` block (summary.json, fit.json): the reference temperature, each
    test's windows, the rows at the reference times (``output.modulus_at``, else
    ``default_times``), each with the test it comes from, and the curve over the union of the
    reduced windows. None without a temperature law or with tests at one temperature only."""
    s = cfg.model.shift
    if s.temperature == "none" or len(sources) < 2:
        return None
    windows = reduced_windows(cfg, tests, sources, fits)
    if len({w["temperature"] for w in windows.values()}) < 2:
        return None
    times = list(cfg.output.modulus_at) if cfg.output.modulus_at else default_times(windows)
    reference = AtTemperature()
    rows = []
    for t in times:
        test, inside = _holder(windows, t)
        w = windows[test]
        window = ResolvedWindow(w["reduced"][0], w["reduced"][1], 0.0, math.nan,
                                f"{test}'s times at {w['temperature']:g} °C over a_T = {w['a_T']:.4g}")
        why = (f"the reduced times of {test} ({w['temperature']:g} °C): its resolved "
               f"{w['resolved'][0]:.3g}-{w['resolved'][1]:.4g} s over a_T = {w['a_T']:.4g}")
        view = cfg.for_test(test)
        # no exponent's spread: it comes from one test's own fit, along its own least-squares path,
        # which a curve shared by the tests does not follow (sample parameters.alpha to carry it)
        found = judged(estimate(sources[test], [t], why, window, bands.get(test), None,
                                refits.get(test) or [], noise_ok.get(test, True), view.model.modes,
                                view.model.decades, None, reference), "")
        row = found.rows[0]
        row["test"] = test
        law = _law_check(shift_law, w["temperature"], s.reference_temperature)
        if law is not None:
            row["checks"]["shift_law"] = law
            row["trust_reasons"] = modulus_reasons(row)
            row["trust"] = not row["trust_reasons"]
        row["lacks"] = {**row.get("lacks", {}), "spectrum exponent": NO_SPREAD}
        row["checks"]["inside_window"] = inside and row["checks"]["inside_window"]
        rows.append(row)
    lo = min(w["reduced"][0] for w in windows.values())
    hi = max(w["reduced"][1] for w in windows.values())
    first = min(windows, key=lambda k: windows[k]["reduced"][0])
    union = ResolvedWindow(lo, hi, 0.0, math.nan, "the union of the tests' reduced windows")
    curve = estimate(sources[first], [lo], "", union, None, None, [], True,
                     cfg.model.modes, cfg.model.decades, None, reference).curve
    curve["windows"] = {t: w["reduced"] for t, w in windows.items()}
    return {"temperature": s.reference_temperature, "law": s.temperature, "windows": windows,
            "rows": rows, "curve": curve}


def test_sources(cfg: Config, layout, joint: Source) -> dict[str, Source]:
    """Each test's share of a joint source (draws under the run's names), under the test's own
    parameter names."""
    out = {}
    for t in layout.tests:
        view = cfg.for_test(t)
        draws = {k: joint.draws[layout.name(k, t)] for k in view.parameters
                 if layout.name(k, t) in joint.draws}
        held = {k: joint.fixed[layout.name(k, t)] for k in view.parameters
                if layout.name(k, t) in joint.fixed}
        fixed = {k: v for k, v in {**joint.fixed, **held, **view.fixed_values}.items()
                 if k not in draws}
        out[t] = Source(joint.kind, draws, fixed, joint.converged, joint.log_prior,
                        joint.under_model_error, dict(joint.lacks))
    return out



def fit_master_curve(cfg: Config, tests: TestSet, result) -> dict[str, Any] | None:
    """The master curve of a joint fit (``inference.lsq.run_fit.RunFit``): its Laplace draws
    (the joint generalized analysis under model error, else the white one), each test's band and
    checks as its own fit's E(t) has them."""
    from bayes_dnlr.inference.layout import Layout
    from bayes_dnlr.runs.bands import N_CURVES, fit_noise, test_band
    from bayes_dnlr.runs.modulus_block import analysis, fit_view

    s = cfg.model.shift
    if s.temperature == "none":
        return None
    joint = result.to_dict()
    estimate_, cov, names, under = analysis(joint)
    layout = Layout.build({t: cfg.for_test(t).free_parameters for t in cfg.test_names},
                          cfg.per_test_parameters)
    # the parameters the joint fit held (no test's window identifies them) at their held values
    held = {k: v["value"] for k, v in ((joint.get("identifiability") or {}).get("held") or {}).items()}
    drawn = fit_source(estimate_, cov, names, {**cfg.fixed_values, **held},
                       bool(joint.get("converged", True)), under)
    sources = {t: src for t, src in test_sources(cfg, layout, drawn).items()
               if has_modulus(cfg.for_test(t))}
    singles = {t: r.to_dict() for t, r in result.singles.items()}
    bands = {}
    for t, src in sources.items():
        own = cfg.for_test(t)
        view = fit_view(own, {"fixed": {k: v for k, v in src.fixed.items() if k in own.free_parameters}})
        bands[t] = test_band(view, tests.tests[t], {k: v[:N_CURVES] for k, v in src.draws.items()},
                             fit_noise(view, tests.tests[t], singles[t], under))
    white = {t: bool((singles[t].get("residuals") or {}).get("white", True)) for t in sources}
    return master_curve(cfg, tests, sources, bands, singles, {},
                        {t: under or white[t] for t in sources}, result.shift_law)
