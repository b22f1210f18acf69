"""Ansys Mechanical APDL commands: ``MP,EX`` and ``MP,PRXY`` (instantaneous moduli), ``MP,DENS``,
and ``TB,PRONY,MAT,1,N,SHEAR`` / ``TB,PRONY,MAT,1,N,BULK`` with ``TBDATA`` pairs (α_i, τ_i), the
relative moduli α_i = E_i / E(0) (the same for shear and bulk at constant ν). Six constants per
TBDATA command. Read inside /PREP7 (``/INPUT`` or a Mechanical command snippet).

A temperature shift follows as ``TB,SHIFT`` (the shift function of a TB,PRONY material): the WLF
form (Tr, C1, C2) or, for the Arrhenius law, the Tool-Narayanaswamy form without fictive
temperature (Tr, H/R). Ansys's reduced time takes A = 1/a_T (ξ = ∫ A dt; log10 A =
C1 (T - Tr)/(C2 + T - Tr), ln A = (H/R)(1/Tr - 1/T)): the model's C1, C2 as they are, H/R = Ea/R.
The card states the forms it assumes (docs/export.md: not verified against the Ansys manual here).
TB,SHIFT has no stress: the Eyring shift is said, not written.
"""

from __future__ import annotations

from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.workflows.export.abaqus import exact
from bayes_dnlr.workflows.export.cards import Card
from bayes_dnlr.workflows.export.context import Context, header_lines
from bayes_dnlr.workflows.export.shift_law import (
    ShiftLaw,
    Support,
    activation_temperature,
    kelvin,
    para,
    solver_support,
)

SOLVER = "Ansys"
EXTENSION = "mac"
MAX_TERMS = 100


def num(x: float) -> str:
    return f"{x:.10g}"


def render(card: Card, ctx: Context, mat: int = 1) -> str:
    p = card.prony
    if p.terms > MAX_TERMS:
        raise BayesDnlrError(f"--terms: TB,PRONY takes at most {MAX_TERMS} terms, the card has {p.terms}")
    lines = [f"! {line}" for line in header_lines(card, ctx)]
    if ctx.shift is not None:
        lines += [f"! {line}" for line in shift_support(ctx.shift, card.params).lines]
    lines += [f"! material {ctx.material}_{card.label}", f"MPDELE,ALL,{mat}", f"TBDELE,ALL,{mat}",
              f"MP,EX,{mat},{num(p.e0)}", f"MP,PRXY,{mat},{num(ctx.poisson.value)}"]
    if ctx.density_tonne_mm3 is not None:
        lines.append(f"MP,DENS,{mat},{num(ctx.density_tonne_mm3)}")
    pairs = [v for g, tau in zip(p.ratios, p.times, strict=True) for v in (g, tau)]
    for option in ("SHEAR", "BULK"):
        lines.append(f"TB,PRONY,{mat},1,{p.terms},{option}")
        for start in range(0, len(pairs), 6):
            chunk = ",".join(num(v) for v in pairs[start:start + 6])
            lines.append(f"TBDATA,{start + 1},{chunk}")
    if ctx.shift is not None:
        lines += tb_shift(ctx.shift, card.params, mat)
    return "\n".join(lines) + "\n"


def tb_shift(law: ShiftLaw, params: dict[str, float], mat: int = 1) -> list[str]:
    """``TB,SHIFT`` and its constants (none without a temperature law)."""
    if law.temperature == "wlf":
        return [f"TB,SHIFT,{mat},1,3,WLF",
                f"TBDATA,1,{exact(law.reference)},{exact(params['C1'])},{exact(params['C2'])}"]
    if law.temperature == "arrhenius":
        return [f"TB,SHIFT,{mat},1,2,TN",
                f"TBDATA,1,{exact(kelvin(law.reference))},{exact(activation_temperature(params['Ea']))}"]
    return []


def shift_support(law: ShiftLaw, params: dict[str, float]) -> Support:
    """What the card says of the run's shift law, and the summary's line."""
    lines: list[str] = []
    check = ("The form above is the one this card assumes; it was not checked against the Ansys manual "
             "here (docs/export.md): check it in your version's TB,SHIFT documentation before use.")
    if law.temperature == "wlf":
        lines += para("TEMPERATURE SHIFT: TB,SHIFT, WLF (Tr, C1, C2), Ansys's reduced time xi = int A dt "
                      "with log10 A = C1 (T - Tr)/(C2 + T - Tr): A = 1/a_T, the model's C1 and C2 as they "
                      "are. Tr = T_ref in degC, so the model's temperatures in degC (C2 in K = degC). "
                      + check)
        summary = "TB,SHIFT WLF (temperatures in °C; the form not verified against the Ansys manual here)"
    elif law.temperature == "arrhenius":
        lines += para("TEMPERATURE SHIFT: TB,SHIFT, TN (Tr, H/R), the Tool-Narayanaswamy form without "
                      "fictive temperature: Ansys's reduced time xi = int A dt with "
                      "ln A = (H/R) (1/Tr - 1/T): A = 1/a_T. "
                      f"H/R = 1000 Ea/R = {activation_temperature(params['Ea']):.10g} K "
                      f"(Ea = {params['Ea']:.6g} kJ/mol); Tr = T_ref = {kelvin(law.reference):.10g} K: the "
                      "law needs absolute temperatures, so the model's temperatures must be in K. " + check)
        summary = ("TB,SHIFT TN, Arrhenius (temperatures in K; the form not verified against the Ansys "
                   "manual here)")
    else:
        summary = "no temperature law in the run's model: no TB,SHIFT"
    return solver_support(law, params, lines, summary, "TB,SHIFT")


def parse(text: str) -> dict:
    """The numbers of a file written by ``render``: EX, PRXY, DENS, the (α, τ) pairs per option, and
    the TB,SHIFT form and constants when there is one."""
    out: dict = {"dens": None, "SHEAR": [], "BULK": [], "shift": None}
    option = None
    for line in text.splitlines():
        if not line or line.startswith("!"):
            continue
        f = line.split(",")
        key = f[0].upper()
        if key == "MP":
            out[{"EX": "ex", "PRXY": "prxy", "DENS": "dens"}[f[1].upper()]] = float(f[3])
        elif key == "TB" and f[1].upper() == "SHIFT":
            option = "shift"
            out["shift"] = {"form": f[5].upper(), "n": int(f[4]), "values": []}
        elif key == "TB":
            option = f[5].upper()
            out[f"n_{option}"] = int(f[4])
        elif key == "TBDATA" and option == "shift":
            out["shift"]["values"].extend(float(v) for v in f[2:])
        elif key == "TBDATA":
            out[option].extend(float(v) for v in f[2:])
    for option in ("SHEAR", "BULK"):
        v = out[option]
        out[option] = list(zip(v[0::2], v[1::2], strict=True))
    return out
