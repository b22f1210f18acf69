"""Abaqus input: ``*MATERIAL``, ``*ELASTIC, MODULI=INSTANTANEOUS`` (E(0), ν) and
``*VISCOELASTIC, TIME=PRONY`` with one data line g_i, k_i, τ_i per term (docs/export.md cites the
Abaqus Keywords Reference for both). Abaqus's relaxation function is
g_R(t) = 1 - Σ g_i (1 - exp(-t/τ_i)), so g_i = E_i / E(0), and k_i = g_i for a constant ν.
"""

from __future__ import annotations

import re

from bayes_dnlr.workflows.export.cards import Card
from bayes_dnlr.workflows.export.context import Context, header_lines

SOLVER = "Abaqus"
EXTENSION = "inp"
MAX_LABEL = 80           # Abaqus labels (a material's name) are 1-80 characters, the first a letter


def num(x: float) -> str:
    return f"{x:.10g}"


def render(card: Card, ctx: Context) -> str:
    p = card.prony
    lines = [f"** {line}" for line in header_lines(card, ctx)]
    lines.append(f"*MATERIAL, NAME={ctx.material}_{card.label}")
    if ctx.density_tonne_mm3 is not None:
        lines += ["*DENSITY", num(ctx.density_tonne_mm3)]
    lines += ["*ELASTIC, MODULI=INSTANTANEOUS", f"{num(p.e0)}, {num(ctx.poisson.value)}",
              "*VISCOELASTIC, TIME=PRONY"]
    lines += [f"{num(g)}, {num(g)}, {num(tau)}" for g, tau in zip(p.ratios, p.times, strict=True)]
    return "\n".join(lines) + "\n"


def parse(text: str) -> dict:
    """The numbers of a file written by ``render``: E0, nu, density and the (g, k, tau) rows."""
    out: dict = {"density": None, "rows": []}
    block = None
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("**"):
            continue
        if line.startswith("*"):
            block = re.split(r"[,\s]", line[1:], maxsplit=1)[0].upper()
            if block == "MATERIAL":
                out["name"] = line.split("NAME=", 1)[1].strip()
            continue
        values = [float(v) for v in line.split(",")]
        if block == "DENSITY":
            out["density"] = values[0]
        elif block == "ELASTIC":
            out["E0"], out["nu"] = values
        elif block == "VISCOELASTIC":
            out["rows"].append(tuple(values))
    return out
