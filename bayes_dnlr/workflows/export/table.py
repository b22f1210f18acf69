"""Solver-neutral cards: CSV (one row per term, the scalars in '#' lines) and JSON, with units."""

from __future__ import annotations

import json

from bayes_dnlr.runs.folder import jsonable
from bayes_dnlr.workflows.export.cards import Card
from bayes_dnlr.workflows.export.context import UNITS, Context, header_lines


def content(card: Card, ctx: Context) -> dict:
    p = card.prony
    nu = ctx.poisson.value
    return {
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


def render_json(card: Card, ctx: Context) -> str:
    return json.dumps(jsonable(content(card, ctx)), indent=2, allow_nan=False) + "\n"


def render_csv(card: Card, ctx: Context) -> str:
    c = content(card, ctx)
    lines = [f"# {line}" for line in header_lines(card, ctx)]
    for k in ("E0", "E_inf", "poisson_ratio", "G0", "K0", "density"):
        unit = {"poisson_ratio": "", "density": " kg/m^3"}.get(k, " MPa")
        v = c[k]
        lines.append(f"# {k} = {'' if v is None else f'{v:.10g}'}{unit if v is not None else ''}")
    lines.append("i,tau_s,E_i_MPa,g_i")
    lines += [f"{i},{t['tau']:.10g},{t['E_i']:.10g},{t['g_i']:.10g}" for i, t in enumerate(c["terms"], 1)]
    return "\n".join(lines) + "\n"
