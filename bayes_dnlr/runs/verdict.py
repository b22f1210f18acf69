"""The verdict of a sampled run's checks (runs/checks.py computes them): the thresholds that
decide it, and its words, one sentence per check, a failed one with what to do (docs/sampling.md,
"Checks and verdict")."""

from __future__ import annotations

from typing import Any

from bayes_dnlr.inference.checks import physical, power_scaling
from bayes_dnlr.numbers import fmt
from bayes_dnlr.vocabulary import base_name

COVERAGE_LOW = 0.80         # overall share below this: the band is too narrow for the data
COVERAGE_HIGH = 0.97        # above this: wider than the scatter (said, not a failure)
E_WEIGHTED_LOW = 0.99       # the misfit lies where E draws more than 1 % of its information: it reaches E
SEGMENT_LOW = 0.50          # a segment (with enough points) below this: the model fails there
SEGMENT_MIN_POINTS = 20
SHIFT_SD = 1.0              # widening a bound moves E by more than this many posterior sd
SCORE_Z = 2.5               # the data pull alpha from ½ by more than this many sd: a model-form error


def prior_shaped_e(sensitivity: dict[str, float]) -> dict[str, float]:
    """The E (one, or one per test) whose posterior the prior shapes: power-scaling sensitivity
    above ``power_scaling.SENSITIVE``."""
    return {k: v for k, v in sensitivity.items() if base_name(k) == "E" and v > power_scaling.SENSITIVE}


def _prior_words(sensitive: dict[str, float], sources: dict[str, dict[str, float]]) -> str:
    """The sentence of a prior that shapes E's interval, naming the priors that do it."""
    by = {n: v for k in sensitive for n, v in (sources.get(k) or {}).items()
          if v > power_scaling.SENSITIVE}
    text = ("The prior shapes E's interval: power-scaling sensitivity "
            + ", ".join(f"{k} {v:.2f}" for k, v in sensitive.items())
            + f" (above {power_scaling.SENSITIVE})")
    if not by:
        return text + "; widen the informative priors or give more data."
    named = ", ".join(f"{n} ({v:.2f})" for n, v in sorted(by.items(), key=lambda kv: -kv[1]))
    if all(base_name(n) == "E" for n in by):
        return text + f", through the prior of {named}; give E a wider prior or more data."
    return (text + f", through the prior of {named}, not E's own: widen that prior, fix the parameter, "
            "or give more data.")


def _share(x: float) -> str:
    return f"{100 * x:.0f} %"


def _cap(text: str) -> str:
    """A sentence's first letter capitalised (a symbol such as σ∞ stays as it is)."""
    return text[:1].upper() + text[1:] if text[:1].isascii() else text


def _coverage_reaches_e(c: dict) -> bool:
    """Whether a test's misfit lies where E draws its information (the E-weighted coverage below
    E_WEIGHTED_LOW; without the weights, any misfit counts)."""
    w = c.get("E_weighted")
    return w is None or w < E_WEIGHTED_LOW


def _coverage_words(test: str, c: dict, several: bool) -> tuple[bool, str]:
    who = f"{test}: " if several else ""
    low_segments = [(name, s["share"]) for name, s in c["segments"].items()
                    if s["share"] is not None and s["points"] >= SEGMENT_MIN_POINTS
                    and s["share"] < SEGMENT_LOW]
    ok = c["overall"] >= COVERAGE_LOW and not low_segments
    text = f"{who}the 90 % predictive band holds {_share(c['overall'])} of the points"
    if ok and c["overall"] > COVERAGE_HIGH:
        return True, text + (" (80-97 % expected): the band is wider than the data's scatter, so the "
                             "intervals lean to the safe side.")
    if ok:
        return True, text + " (80-97 % expected)."
    where = ", ".join(f"{_share(s)} in the {name}" for name, s in low_segments)
    text += ((f", {where}" if where else "")
             + ": the model with its noise model does not describe this test there")
    if not _coverage_reaches_e(c):
        return False, (text + f", but E draws little of its information from there (the band holds "
                       f"{_share(c['E_weighted'])} of the points weighted by their share of E's "
                       "variance): E's interval stands; the other parameters', and any prediction "
                       "there, do not. A model or window that describes that part would tell.")
    return False, (text + ", and E's interval rests on a misfit the likelihood does not model. Look at "
                   "the residuals of that part (a toe, a second process, a window past yield) and "
                   "fix the start or the window.")


def _plausibility_words(test: str, checks: dict, several: bool) -> list[tuple[str, bool, str]]:
    """(kind, ok, sentence) per physical check; kind 'adequate' or 'trust'."""
    who = f"{test}: " if several else ""
    out = []
    s = checks.get("sigma_inf")
    if s is not None and not s["ok"]:
        out.append(("adequate", False,
                    f"{who}σ∞ = {fmt(s['sigma_inf_median'], 4)} MPa (posterior median) lies above the last "
                    "stress of the "
                    f"hold ({fmt(s['last_stress'], 4)} MPa), which still falls: impossible. The model's "
                    "relaxation does not describe this hold (a second, slower process?); a longer hold "
                    "or a relaxation spectrum of its own would tell."))
    for k in ("tau_max", "tau_max_R"):
        c = checks.get(k)
        if c is not None and not c["ok"]:
            span = (f"test's duration ({fmt(c['test_duration'], 3)} s)" if "reduced_duration" not in c
                    else f"test's duration in reduced time ({fmt(c['reduced_duration'], 3)} s, its "
                         f"{fmt(c['test_duration'], 3)} s over the stress shift a_σ at the data's "
                         "stress)")
            out.append(("trust", False,
                        f"{who}{k} = {fmt(c['median'], 3)} s (posterior median) is more than "
                        f"{physical.SPAN_FACTOR:g}× the {span}: the test does not measure "
                        "it, and what trades off with it comes from the prior box."))
    c = checks.get("E_chord")
    if c is not None and not c["ok"]:
        out.append(("adequate", False,
                    f"{who}E's 95 % quantile ({fmt(c['E_q95'])} MPa) lies below the standards' chord "
                    f"({fmt(c['chord'])} MPa"
                    + (f", by more than {physical.CHORD_Z:g} of its noise sd of {fmt(c['chord_sd'])} MPa"
                       if c.get("chord_sd") else "")
                    + "), a lower bound of the instantaneous modulus: impossible. "
                    "The model does not describe the start of this curve (a toe, a preload)."))
    return out


def _noise_model_words(test: str, c: dict, several: bool) -> tuple[bool, str | None]:
    if c["ok"]:
        return True, None
    who = f"{test}: " if several else ""
    return False, (f"{who}the residuals of the fit are signed waves, not noise, and this posterior used "
                   "the white likelihood (noise.discrepancy: none): E's interval ignores the model "
                   "error, so it is too narrow, and its centre follows the waves. Sample with the "
                   "discrepancy (leave noise.discrepancy out: the default).")


def _model_form_words(test: str, c: dict, several: bool) -> tuple[bool, str | None]:
    if c["ok"]:
        return True, None
    who = f"{test}: " if several else ""
    rel = c.get("E_relative_per_tenth")
    moves = (f"; E moves by {100 * rel:+.0f} % per +0.1 of the exponent" if rel is not None else "")
    if c.get("E_shift_sd") is not None:
        moves += f", {c['E_shift_sd']:+.1f} posterior sd at the exponent the data prefer"
    return False, (f"{who}the data pull the spectrum's exponent away from Cunat's ½ by {c['z']:+.1f} sd "
                   f"(score test, {c['likelihood']}){moves}: the model's form does not fit (a strain toe, "
                   "a second process, another spectrum shape) and E's interval does not carry it. "
                   "Sample the exponent (parameters.alpha, docs/model-form.md), fix the start of the "
                   "curve, or check E against an independent measurement (reference_moduli:).")


def _stress_shift_words(test: str, c: dict, several: bool) -> tuple[bool, str | None]:
    if c["ok"]:
        return True, None
    who = f"{test}: " if several else ""
    sigma = f"; sigma_s about {fmt(c['sigma_s'], 3)} MPa" if c.get("sigma_s") else ""
    return False, (f"{who}the data ask for a stress shift (its score test, z = {c['z']:.1f}{sigma}), "
                   f"and admitting it moves E to {fmt(c['E_shifted'])} MPa, {c['E_shift_sd']:+.1f} "
                   "posterior sd: the stress-blind model reads the curve's nonlinearity as "
                   "relaxation, and E, its extrapolation to t → 0, follows it. Set "
                   "model.shift.stress: eyring (docs/theory.md).")


def _bound_words(entries: list[dict]) -> tuple[bool, list[str]]:
    """(whether no bound decides E, a sentence per parameter whose posterior piles against a bound)."""
    said = _bound_sentences(entries)
    return all(ok for ok, _ in said), [w for _, w in said]


def _bound_sentences(entries: list[dict]) -> list[tuple[bool, str]]:
    """(ok, sentence) per parameter whose posterior piles against a bound of its prior."""
    out = []
    for b in entries:
        shift = b.get("E_shift_sd") or {}
        big = {k: v for k, v in shift.items() if abs(v) > SHIFT_SD}
        where = f"its prior's {b['side']} bound ({fmt(b['bound'], 4)})"
        if big:
            moves = ", ".join(f"{k} by {v:+.1f} posterior sd" for k, v in big.items())
            name = base_name(b["parameter"])
            if b.get("identified", True):
                remedy = (f"Widen parameters.{name} and run again: the data identify {name}, so a "
                          "wider box lets them place it.")
            else:
                remedy = (f"Do not just widen it: this window does not identify {name} (its "
                          "sensitivity is negligible or its linearized sd is wider than its box), "
                          "so a wider box only moves where the box decides it. Fix "
                          f"parameters.{name} at a value another test measures, or identify on a "
                          f"window that measures {name}.")
            out.append((False, f"The posterior of {b['parameter']} piles against {where}; "
                               f"{_widened_words(b)} moves {moves} (least squares): the prior box decides "
                               f"E. {remedy}"))
        elif b.get("note") or not b.get("widened"):
            out.append((True, f"The posterior of {b['parameter']} piles against {where}"
                              + (f" ({b['note']})." if b.get("note") else ".")))
        else:
            out.append((True, f"The posterior of {b['parameter']} piles against {where}; "
                              f"{_widened_words(b)} moves E by less than {SHIFT_SD:g} sd (least squares)."))
    return out


def _widened_words(b: dict) -> str:
    """'moving that bound to 10 (the prior's box widened ×10, to [0, 10])': what the refit changed, in
    numbers, so that no bound is said to widen ×10 without the box it gives."""
    if not b.get("widened"):
        return "widening it ×10"
    lo, hi = b["widened"]
    new = lo if b["side"] == "low" else hi
    return (f"moving that bound to {fmt(new, 4)} (the prior's box widened ×10, to "
            f"[{fmt(lo, 4)}, {fmt(hi, 4)}])")


# ---------------------------------------------------------------- E(t)'s trust

def modulus_reasons(row: dict[str, Any], who: str = "") -> list[str]:
    """The sentences of the checks that withdraw an E(t)'s trust (inference/modulus_estimate.py
    computes them), each with what to do; empty when it is trusted."""
    t = f"E({fmt(row['t'], 3)} s)"
    c = row["checks"]
    out = []
    linear = row.get("linear_range")
    if not c["inside_window"] and linear and row["t"] > row["resolved"][1]:
        out.append(f"{who}{t} lies beyond the test's linear range (it ends at t = "
                   f"{fmt(linear['time'], 3)} s, where the stress reaches {fmt(linear['stress'], 3)} MPa, "
                   f"{fmt(linear['sigma_s'], 3)} MPa sigma_s): " + (
                       "the model reaches it through its stress shift, an extrapolation in stress"
                       if linear.get("model_shift") else
                       "the stress-blind model reads the curve's nonlinearity there as relaxation; "
                       "set model.shift.stress: eyring (docs/theory.md)"))
    elif not c["inside_window"]:
        lo, hi = row["resolved"]
        out.append(f"{who}{t} lies outside the times the test resolves ({fmt(lo, 3)}-{fmt(hi, 4)} s): "
                   "an extrapolation through the model's spectrum, not a measurement")
    width = c.get("width")
    if width and not width["ok"]:
        out.append(f"{who}{t}'s 90 % interval spans ±{100 * width['half_width']:.0f} % of its value: "
                   "it says little about the material at this time; a test that resolves it (a "
                   "denser record, a slower rate) or a time inside the well-measured part would")
    shape = c.get("shape")
    if shape and not shape["ok"]:
        out.append(f"{who}the data pull the spectrum's exponent to {shape['alpha_pulled']:.2f} (eq. 12 "
                   f"holds it at ½), which moves {t} by {fmt(shape['move'], 3)} MPa, "
                   f"{abs(shape['z']):.1f} of its sd: the assumed spectrum's shape, not the data, "
                   "decides it; sample the exponent (parameters.alpha, docs/model-form.md)")
    law = c.get("shift_law")
    if law and not law["ok"]:
        out.append(f"{who}the temperature law does not carry the tests at {law['temperature']:g} °C "
                   f"from the others (its held-out check): {t} at the reference temperature from "
                   "them is the law's, not the data's")
    stress = c.get("stress")
    if stress and not stress["ok"]:
        out.append(f"{who}the data ask for a stress shift (its score test, z = {stress['score_z']:.1f}"
                   + (f"; sigma_s about {fmt(stress['sigma_s'], 3)} MPa" if stress.get("sigma_s") else "")
                   + f"), and admitting it moves {t} by {fmt(stress['move'], 3)} MPa, "
                   f"{abs(stress['z']):.1f} of its sd: the stress-blind model reads the curve's "
                   "nonlinearity as relaxation; set model.shift.stress: eyring (docs/theory.md)")
    local = c.get("local")
    if local and not local["ok"]:
        # the reported value (after the exponent's pull) where it is the farther one
        pulled = abs(local.get("z_reported", 0.0)) > abs(local["z"])
        z_far = local["z_reported"] if pulled else local["z"]
        whose = "the value reported, after the exponent's pull" if pulled else "the whole window's"
        out.append(f"{who}fitted on its first {fmt(local['window_end'], 3)} s alone, where {t} is "
                   f"measured, the model gives {fmt(local['local_mean'])} ± {fmt(local['local_sd'], 2)} "
                   f"MPa, {abs(z_far):.1f} of that sd from {whose}: what follows (a "
                   "slower process, yield read as relaxation, a hold one spectrum does not describe) "
                   f"moves {t}; identify on data.window: {{time_max: {fmt(local['time_max'], 4)}}}, "
                   "or give the model the form it lacks (docs/model-form.md)")
    band = c.get("band")
    if band and not band["ok"]:
        lo, hi = band["information_times"]
        out.append(f"{who}the 90 % band holds {100 * band['share']:.0f} % of the samples that carry "
                   f"{t}'s information (t = {fmt(lo, 3)}-{fmt(hi, 3)} s; at least "
                   f"{100 * max(band['floor'], 0):.0f} % expected of a calibrated band): the model "
                   f"misses the data where this modulus is measured; {band_remedy(band)}")
    start = c.get("start")
    if start and start.get("toe"):
        out.append(f"{who}the curve's slope rises over its start ({start['convexity_z']:+.1f} sd): "
                   "a toe (slack, seating), which no relaxing material gives and the model fits as a "
                   f"softer start, so {t} comes out low; " + (
                       "it remains after the toe's compensation (data.toe: compensate): fix the start "
                       "of the test (docs/data-input.md)" if start.get("compensated") else
                       "compensate it (data.toe: compensate) or fix the start (docs/data-input.md)"))
    elif start and not start["ok"]:
        out.append(f"{who}the data's {start.get('standard', 'ISO 527-1')} chord "
                   f"({fmt(start['data_chord'])} MPa, measured "
                   f"{fmt(start['times'][0], 2)}-{fmt(start['times'][1], 2)} s into the loading) is "
                   f"{abs(start['z']):.1f} sd from the model's ({fmt(start['model_chord'])} MPa): the "
                   "model does not follow the start of this curve (a preload, a loading it misses)")
    big = {k: v for k, v in (c.get("bounds") or {}).items() if abs(v) > SHIFT_SD}
    if big:
        moves = ", ".join(f"{k} moves it by {v:+.1f} sd" for k, v in big.items())
        out.append(f"{who}the prior box decides {t}: widening the bound of {moves}")
    prior = c.get("prior")
    if prior is not None and prior > power_scaling.SENSITIVE:
        out.append(f"{who}the prior shapes {t} (power-scaling sensitivity {prior:.2f})")
    if c.get("noise_model") is False:
        out.append(f"{who}a white likelihood on residuals that are not white: {t}'s interval ignores "
                   "the model error")
    if not c["converged"]:
        out.append(f"{who}the " + ("fit" if row.get("source") == "fit" else "chain")
                   + " has not converged")
    return out


def band_remedy(band: dict[str, Any]) -> str:
    """What to do when the model misses the data where E(t) is measured: where the test has parts
    the model does not describe (unloading, a long hold), identify on the part it does."""
    if band.get("first_turn") is not None:
        return (f"the model does not follow unloading: identify on the first loading, "
                f"data.window: {{time_max: {band['first_turn']:.6g}}} (its peak), where E(t) is "
                "measured")
    start, window = band.get("relaxation_start"), band.get("window")
    if start is not None and window:
        ramp = float(start - window[0])
        end = float(start + 10.0 * ramp)
        if end < float(window[1]):
            return (f"one spectrum does not describe the whole hold: identify on the loading and the "
                    f"start of the hold, e.g. data.window: {{time_max: {end:.4g}}} (ten times "
                    "the loading's length), and compare")
    return ("the model's form does not describe the curve where E(t) is measured (docs/model-form.md): "
            "read the residuals there")

def shift_law_words(block: dict[str, Any] | None) -> str | None:
    """The verdict's sentence on the temperature law's held-out check (runs/shift_law.py); None
    without one, or when it was not checked."""
    if not block or block.get("ok") is None:
        return None
    bad = [(e["temperature"], t, x) for e in block["held_out"] for t, x in e["tests"].items()
           if not x["ok"]]
    if not bad:
        shares = [x["coverage"] for e in block["held_out"] for x in e["tests"].values()]
        lo, hi = 100 * min(shares), 100 * max(shares)
        held = [e for e in block["held_out"] if e["tests"]]
        missed = [e.get("note") or f"{e['temperature']:g} °C" for e in block["held_out"]
                  if not e["tests"]]
        temps = ", ".join(f"{e['temperature']:g}" for e in held)
        return (f"The temperature law predicts the tests at {temps} °C from the others, each held "
                f"out in turn ({lo:.0f} %" + (f"-{hi:.0f} %" if round(hi) != round(lo) else "")
                + " of their points in the 90 % band)"
                + (f"; not held out: {'; '.join(missed)}" if missed else "") + ".")
    T, t, x = bad[0]
    return (f"The temperature law does not predict the tests at {T:g} °C from the others: {t} lies "
            f"beyond the prediction of the fit without them (χ² {x['chi2']:.0f} on {x['points']} "
            f"points, p = {x['p']:.2g}; {100 * x['coverage']:.0f} % of its points in the 90 % "
            "band): the law fits every temperature but does not carry one to another; E(t) at the "
            "reference temperature from those tests is the law's, not the data's. Try the other "
            "law (model.shift.temperature), or tests at more temperatures.")



def verdict(checks: dict[str, Any], converged: bool, several: bool) -> tuple[bool, bool, str, list[str]]:
    """(adequate, trust_interval, the verdict's first sentence, one sentence per check) from the
    checks; summary.json's ``verdict`` is the sentences joined. The first sentence says the decision
    first; the sentences of the checks that fail come before those that pass, so that a verdict that
    does not trust E's interval opens with why."""
    adequate, trust = True, True
    said: list[tuple[bool, str]] = []          # (ok, sentence)
    reaches_e = implausible = False
    for t, c in checks["predictive_coverage"].items():
        ok, text = _coverage_words(t, c, several)
        adequate &= ok
        reaches_e |= not ok and _coverage_reaches_e(c)
        said.append((ok, text))
    for t, c in checks["plausibility"].items():
        for kind, ok, text in _plausibility_words(t, c, several):
            said.append((ok, text))
            if kind == "adequate":
                adequate &= ok
                implausible |= not ok
            else:
                trust &= ok
    for t, c in (checks.get("noise_model") or {}).items():
        ok, text = _noise_model_words(t, c, several)
        trust &= ok
        if text:
            said.append((ok, text))
    for t, c in (checks.get("model_form") or {}).items():
        ok, text = _model_form_words(t, c, several)
        trust &= ok
        if text:
            said.append((ok, text))
    for t, c in (checks.get("stress_shift") or {}).items():
        ok, text = _stress_shift_words(t, c, several)
        trust &= ok
        if text:
            said.append((ok, text))
    refs = checks.get("reference_moduli")
    if refs:
        for e in refs["entries"]:
            if e["fired"]:
                trust = False
                said.append((False, e["words"] + "."))
    for ok, text in _bound_sentences(checks["bound_limited"]):
        trust &= ok
        said.append((ok, text))
    sens = prior_shaped_e(checks["prior_sensitivity"])
    if sens:
        trust = False
        said.append((False, _prior_words(sens, checks.get("prior_sources") or {})))
    law = shift_law_words(checks.get("shift_law"))
    if law:
        ok = bool(checks["shift_law"]["ok"])
        trust &= ok
        said.append((ok, law))
    if not converged:
        trust = False
        said.append((False, "The chain has not converged: its intervals are not final (raise "
                            "sampler.max_steps and run `sample` again)."))
    trust &= not reaches_e
    trust &= not implausible
    these = "these tests" if several else "this test"
    head = ("Use E's interval as it is." + ("" if adequate else f" The model does not describe all "
                                            f"of {these} (below), but not where E is measured.")
            if trust else
            f"Do not use E's interval as it is: the model's predictive band holds {these}, but the "
            "checks below find what the interval misses." if adequate else
            f"The model does not describe {these}: E's interval is not reliable.")
    said = [x for x in said if not x[0]] + [x for x in said if x[0]]
    return adequate, trust, head, [_cap(w) for _, w in said]
