"""Solver-neutral cards: CSV (one row per term, the scalars in '#' lines) and JSON, with units. A
shifted run's cards carry its shift law whole: the law, the reference state, the card's values and
the posterior's intervals (``shift``)."""

from __future__ import annotations

import json

from bayes_dnlr.runs.folder import jsonable
from bayes_dnlr.vocabulary import UNITS as PARAMETER_UNITS
from bayes_dnlr.workflows.export.cards import Card
from bayes_dnlr.workflows.export.context import UNITS, Context, header_lines
from bayes_dnlr.workflows.export.shift_law import ShiftLaw, Support


def content(card: Card, ctx: Context) -> dict:
    p = card.prony
    nu = ctx.poisson.value
    out = {
        "card": card.label,
        "model": "small-strain linear viscoelastic part of the DNLR model: "
                 "E(t) = E_inf + sum_i E_i exp(-t/tau_i)",
        "notes": header_lines(card, ctx),
        "units": {"modulus": "MPa", "time": "s", "density": "kg/m^3", "system": UNITS},
        "parameters": card.params,
        "quantile_of_E": card.quantile_of_E,
        "posterior_draw": card.draw_index,
        "E0": p.e0,
        "E_inf": p.e_inf,
        "poisson_ratio": nu,
        "poisson_source": ctx.poisson.source,
        "G0": None if nu is None else p.e0 / (2.0 * (1.0 + nu)),
        "K0": None if nu is None or nu >= 0.5 else p.e0 / (3.0 * (1.0 - 2.0 * nu)),
        "density": ctx.density,
        "terms": [{"tau": float(t), "E_i": float(e), "g_i": float(g)}
                  for t, e, g in zip(p.times, p.moduli, p.ratios, strict=True)],
        "refit": None if card.refit is None else {
            "requested_terms": card.refit.requested, "time_range_s": list(card.refit.t_range),
            "max_relative_error_of_E_t": card.refit.max_error},
        "small_strain_limit": ctx.small_strain_limit,
        "strain_rate": ctx.strain_rate,
    }
    if ctx.shift is not None:
        out["shift"] = shift_block(ctx.shift, card.params)
    return out


LAWS = {"arrhenius": "ln a_T = (1000 Ea/R) (1/(T + 273.15) - 1/(T_ref + 273.15)), T in degC, R in J/(mol K)",
        "wlf": "log10 a_T = -C1 (T - T_ref)/(C2 + T - T_ref)",
        "eyring": "a_sigma = x/sinh(x), x = |s|/sigma_s"}


def shift_block(law: ShiftLaw, params: dict[str, float]) -> dict:
    """The shift law as data: the series is the reference state's; the law's parameters of this
    card's draw, with the posterior's median and 90 % interval (or fixed)."""
    return {
        "temperature_law": law.temperature, "reference_temperature_C": law.reference,
        "stress_law": law.stress, "driving": law.driving if law.has_stress else None,
        "series_at": {"temperature_C": law.reference if law.has_temperature else None,
                      "stress": "sigma -> 0" if law.has_stress else None},
        "test_temperature_C": law.test_temperature,
        "a_T_at_test": law.a_T(params) if law.has_temperature else None,
        "parameters": {k: {"value": params[k], "unit": PARAMETER_UNITS[k],
                           **({"fixed": True} if law.spread[k].fixed else
                              {"posterior_median": law.spread[k].median, "q05": law.spread[k].low,
                               "q95": law.spread[k].high})}
                       for k in law.parameters if k in law.spread},
        "laws": {k: LAWS[k] for k in (law.temperature, law.stress) if k in LAWS},
    }


def shift_support(law: ShiftLaw, params: dict[str, float]) -> Support:
    """A table carries the whole law: nothing to say beyond the common lines."""
    return Support([], "written whole (law, reference state, each card's values, the posterior's intervals)")


def render_json(card: Card, ctx: Context) -> str:
    return json.dumps(jsonable(content(card, ctx)), indent=2, allow_nan=False) + "\n"


def render_csv(card: Card, ctx: Context) -> str:
    c = content(card, ctx)
    lines = [f"# {line}" for line in header_lines(card, ctx)]
    for k in ("E0", "E_inf", "poisson_ratio", "G0", "K0", "density"):
        unit = {"poisson_ratio": "", "density": " kg/m^3"}.get(k, " MPa")
        v = c[k]
        lines.append(f"# {k} = {'' if v is None else f'{v:.10g}'}{unit if v is not None else ''}")
    if ctx.shift is not None:
        law = ctx.shift
        lines.append(f"# shift = temperature {law.temperature}, stress {law.stress}; series at "
                     + ", ".join(([f"T_ref = {law.reference:.10g} degC"] if law.has_temperature else [])
                                 + (["sigma -> 0"] if law.has_stress else [])))
        lines += [f"# {k} = {card.params[k]:.10g} {PARAMETER_UNITS[k]}" for k in law.parameters]
    lines.append("i,tau_s,E_i_MPa,g_i")
    lines += [f"{i},{t['tau']:.10g},{t['E_i']:.10g},{t['g_i']:.10g}" for i, t in enumerate(c["terms"], 1)]
    return "\n".join(lines) + "\n"
