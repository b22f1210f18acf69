"""Ansys Mechanical APDL commands: ``MP,EX`` and ``MP,PRXY`` (instantaneous moduli), ``MP,DENS``,
and ``TB,PRONY,MAT,1,N,SHEAR`` / ``TB,PRONY,MAT,1,N,BULK`` with ``TBDATA`` pairs (α_i, τ_i), the
relative moduli α_i = E_i / E(0) (the same for shear and bulk at constant ν). Six constants per
TBDATA command. Read inside /PREP7 (``/INPUT`` or a Mechanical command snippet).
"""

from __future__ import annotations

from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.workflows.export.cards import Card
from bayes_dnlr.workflows.export.context import Context, header_lines

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
    return "\n".join(lines) + "\n"


def parse(text: str) -> dict:
    """The numbers of a file written by ``render``: EX, PRXY, DENS and the (α, τ) pairs per option."""
    out: dict = {"dens": None, "SHEAR": [], "BULK": []}
    option = None
    for line in text.splitlines():
        if not line or line.startswith("!"):
            continue
        f = line.split(",")
        key = f[0].upper()
        if key == "MP":
            out[{"EX": "ex", "PRXY": "prxy", "DENS": "dens"}[f[1].upper()]] = float(f[3])
        elif key == "TB":
            option = f[5].upper()
            out[f"n_{option}"] = int(f[4])
        elif key == "TBDATA":
            out[option].extend(float(v) for v in f[2:])
    for option in ("SHEAR", "BULK"):
        v = out[option]
        out[option] = list(zip(v[0::2], v[1::2], strict=True))
    return out
