"""Abaqus input: ``*MATERIAL``, ``*ELASTIC, MODULI=INSTANTANEOUS`` (E(0), ν) and
``*VISCOELASTIC, TIME=PRONY`` with one data line g_i, k_i, τ_i per term (docs/export.md cites the
Abaqus Keywords Reference for both). Abaqus's relaxation function is
g_R(t) = 1 - Σ g_i (1 - exp(-t/τ_i)), so g_i = E_i / E(0), and k_i = g_i for a constant ν.

A temperature shift follows as ``*TRS``: Abaqus's reduced time is dξ = dt / A(θ), so A = a_T, and
its two native forms are the model's two laws: ``DEFINITION=WLF`` (θ_0, C1, C2; log10 A =
-C1 (θ - θ_0)/(C2 + θ - θ_0)) and ``DEFINITION=ARRHENIUS`` (θ_0, E0; ln A = (E0/R)(1/(θ - θ^Z) -
1/(θ_0 - θ^Z)), R and θ^Z from the model's ``*PHYSICAL CONSTANTS``). Temperatures in °C. *TRS has
no stress: the Eyring shift is said, not written.
"""

from __future__ import annotations

import re

from bayes_dnlr.model.shift import KELVIN
from bayes_dnlr.workflows.export.cards import Card
from bayes_dnlr.workflows.export.context import Context, header_lines
from bayes_dnlr.workflows.export.shift_law import (
    GAS_CONSTANT_MJ,
    ShiftLaw,
    Support,
    activation_energy_mj,
    para,
    solver_support,
)

SOLVER = "Abaqus"
EXTENSION = "inp"
MAX_LABEL = 80           # Abaqus labels (a material's name) are 1-80 characters, the first a letter
# what an Arrhenius *TRS needs in the model (a model-level option: not inside a material's card)
PHYSICAL_CONSTANTS = (f"*PHYSICAL CONSTANTS, ABSOLUTE ZERO={-KELVIN:g}, "
                      f"UNIVERSAL GAS CONSTANT={GAS_CONSTANT_MJ:.10g}")


def num(x: float) -> str:
    return f"{x:.10g}"


def exact(x: float) -> str:
    """A shift law's constant: it enters an exponential (ln a_T of 10 and more), so it keeps every
    digit a double holds that matters (10 digits would move a_T by 1e-9 relative, or more)."""
    return f"{x:.15g}"


def render(card: Card, ctx: Context) -> str:
    p = card.prony
    lines = [f"** {line}" for line in header_lines(card, ctx)]
    if ctx.shift is not None:
        lines += [f"** {line}" for line in shift_support(ctx.shift, card.params).lines]
    lines.append(f"*MATERIAL, NAME={ctx.material}_{card.label}")
    if ctx.density_tonne_mm3 is not None:
        lines += ["*DENSITY", num(ctx.density_tonne_mm3)]
    lines += ["*ELASTIC, MODULI=INSTANTANEOUS", f"{num(p.e0)}, {num(ctx.poisson.value)}",
              "*VISCOELASTIC, TIME=PRONY"]
    lines += [f"{num(g)}, {num(g)}, {num(tau)}" for g, tau in zip(p.ratios, p.times, strict=True)]
    if ctx.shift is not None:
        lines += trs(ctx.shift, card.params)
    return "\n".join(lines) + "\n"


def trs(law: ShiftLaw, params: dict[str, float]) -> list[str]:
    """The ``*TRS`` option and its data line (none without a temperature law)."""
    if law.temperature == "wlf":
        return ["*TRS, DEFINITION=WLF",
                f"{exact(law.reference)}, {exact(params['C1'])}, {exact(params['C2'])}"]
    if law.temperature == "arrhenius":
        return ["*TRS, DEFINITION=ARRHENIUS",
                f"{exact(law.reference)}, {exact(activation_energy_mj(params['Ea']))}"]
    return []


def shift_support(law: ShiftLaw, params: dict[str, float]) -> Support:
    """What the card says of the run's shift law, and the summary's line."""
    lines: list[str] = []
    if law.temperature == "wlf":
        lines += para("TEMPERATURE SHIFT: *TRS, DEFINITION=WLF (theta_0, C1, C2), Abaqus's reduced time "
                      "dxi = dt/A with log10 A = -C1 (theta - theta_0)/(C2 + theta - theta_0): A = a_T, the "
                      "model's law and constants. theta_0 = T_ref in degC, so the model's temperatures in "
                      "degC (C2 in K = degC). Below theta_0 - C2 Abaqus takes the response as elastic (the "
                      "law has no value there).")
        summary = "*TRS, DEFINITION=WLF (temperatures in °C)"
    elif law.temperature == "arrhenius":
        lines += para("TEMPERATURE SHIFT: *TRS, DEFINITION=ARRHENIUS (theta_0, E0), Abaqus's reduced time "
                      "dxi = dt/A with ln A = (E0/R) (1/(theta - theta_Z) - 1/(theta_0 - theta_Z)): A = a_T, "
                      f"the model's law. theta_0 = T_ref in degC; E0 = Ea = {params['Ea']:.6g} kJ/mol = "
                      f"{activation_energy_mj(params['Ea']):.10g} mJ/mol (the energy of N, mm: N mm = mJ). "
                      "R and theta_Z are the model's physical constants, a model-level option that a "
                      "material card does not hold: the model must have the line below (Abaqus stops with "
                      "an error without it), with temperatures in degC and R in mJ/(mol K):")
        lines.append(f"  {PHYSICAL_CONSTANTS}")
        summary = f"*TRS, DEFINITION=ARRHENIUS (temperatures in °C; the model needs {PHYSICAL_CONSTANTS})"
    else:
        summary = "no temperature law in the run's model: no *TRS"
    return solver_support(law, params, lines, summary, "*TRS")


def parse(text: str) -> dict:
    """The numbers of a file written by ``render``: E0, nu, density, the (g, k, tau) rows and the
    ``*TRS`` option (its DEFINITION and data line), when there is one."""
    out: dict = {"density": None, "rows": [], "trs": None}
    block = None
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("**"):
            continue
        if line.startswith("*"):
            block = re.split(r"[,\s]", line[1:], maxsplit=1)[0].upper()
            if block == "MATERIAL":
                out["name"] = line.split("NAME=", 1)[1].strip()
            elif block == "TRS":
                out["trs"] = {"definition": line.split("DEFINITION=", 1)[1].strip(), "values": []}
            continue
        values = [float(v) for v in line.split(",")]
        if block == "DENSITY":
            out["density"] = values[0]
        elif block == "ELASTIC":
            out["E0"], out["nu"] = values
        elif block == "VISCOELASTIC":
            out["rows"].append(tuple(values))
        elif block == "TRS":
            out["trs"]["values"] = values
    return out
