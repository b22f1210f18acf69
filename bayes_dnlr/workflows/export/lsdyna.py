"""LS-DYNA keyword input: ``*MAT_GENERAL_VISCOELASTIC`` (``*MAT_076``).

Card 1: MID, RO, BULK (PCF, EF, TREF, A, B blank); card 2: LCID, NT, BSTART, TRAMP, LCIDK, NTK,
BSTARTK, TRAMPK (blank: the series is given directly); then one card per term: GI, BETAI, KI,
BETAKI, with G(t) = Σ G_i exp(-β_i t), K(t) = Σ K_i exp(-βk_i t). The long-term moduli are the terms
with β = 0. At most MAX_TERMS cards (docs/export.md for the sources). Fixed 10-character fields.
For a constant ν: G_i = E_i / (2(1+ν)), K_i = E_i / (3(1-2ν)), β_i = 1/τ_i.
"""

from __future__ import annotations

from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.workflows.export.cards import Card
from bayes_dnlr.workflows.export.context import Context, header_lines

SOLVER = "LS-DYNA"
EXTENSION = "k"
MAX_TERMS = 18          # cards of GI/BETAI/KI/BETAKI, the long-term (β = 0) card included
FIELD = 10


def f10(x: float) -> str:
    """A real in a 10-character field with as many significant digits as fit in 9 characters (a
    blank always separates the fields for a reader)."""
    for digits in range(8, 0, -1):
        s = f"{x:.{digits}g}"
        if "e" in s:
            mant, exp = s.split("e")
            s = f"{mant}e{int(exp)}"
        elif "." not in s:
            s += "."
        if len(s) < FIELD:
            return s.rjust(FIELD)
    raise ValueError(f"{x!r} does not fit a {FIELD}-character field")


def i10(n: int) -> str:
    return str(n).rjust(FIELD)


def moduli(card: Card, nu: float) -> list[tuple[float, float, float, float]]:
    """(G_i, β_i, K_i, βk_i) rows: the long-term term (β = 0) first, then the Prony terms."""
    p = card.prony
    shear, bulk = 1.0 / (2.0 * (1.0 + nu)), 1.0 / (3.0 * (1.0 - 2.0 * nu))
    rows = [(p.e_inf * shear, 0.0, p.e_inf * bulk, 0.0)]
    rows += [(e * shear, 1.0 / tau, e * bulk, 1.0 / tau) for e, tau in zip(p.moduli, p.times, strict=True)]
    return rows


def check(card: Card) -> None:
    n = card.prony.terms + 1
    if n > MAX_TERMS:
        raise BayesDnlrError(
            f"--terms: *MAT_GENERAL_VISCOELASTIC takes at most {MAX_TERMS} terms (the long-term one "
            f"included) and the card has {n}: give --terms {MAX_TERMS - 1} or fewer (the refit over the "
            "test's time range and its error are printed)")


def render(card: Card, ctx: Context, mid: int = 1) -> str:
    check(card)
    nu = ctx.poisson.value
    if ctx.density_tonne_mm3 is None:
        raise BayesDnlrError("--density: LS-DYNA needs the mass density RO (kg/m³, e.g. 950 for HDPE "
                             "as measured); it is written in tonne/mm³")
    rows = moduli(card, nu)
    k0 = card.prony.e0 / (3.0 * (1.0 - 2.0 * nu))
    lines = ["*KEYWORD"] + [f"$ {line}" for line in header_lines(card, ctx)]
    lines += ["$ G_i = E_i/(2(1+nu)), K_i = E_i/(3(1-2nu)), BETA_i = 1/tau_i; the first term (BETA = 0) "
              "is the long-term modulus",
              "*MAT_GENERAL_VISCOELASTIC_TITLE", f"{ctx.material}_{card.label}",
              "$      MID        RO      BULK       PCF        EF      TREF         A         B",
              i10(mid) + f10(ctx.density_tonne_mm3) + f10(k0),
              "$     LCID        NT    BSTART     TRAMP     LCIDK       NTK   BSTARTK    TRAMPK",
              i10(0) + i10(0) + " " * FIELD * 2 + i10(0) + i10(0),
              "$       GI     BETAI        KI    BETAKI"]
    lines += [f10(g) + f10(b) + f10(k) + f10(bk) for g, b, k, bk in rows]
    lines.append("*END")
    return "\n".join(lines) + "\n"


def _fields(line: str) -> list[str]:
    return [line[i:i + FIELD].strip() for i in range(0, len(line), FIELD)]


def parse(text: str) -> dict:
    """The numbers of a file written by ``render``: MID, RO, BULK and the (G, β, K, βk) rows."""
    lines = [x.rstrip("\n") for x in text.splitlines() if x.strip() and not x.startswith("$")]
    i = next(k for k, x in enumerate(lines) if x.upper().startswith("*MAT_GENERAL_VISCOELASTIC"))
    j = i + (2 if lines[i].upper().endswith("_TITLE") else 1)
    card1 = _fields(lines[j])
    rows = []
    for line in lines[j + 2:]:
        if line.startswith("*"):
            break
        rows.append(tuple(float(v) for v in _fields(line)[:4]))
    return {"mid": int(card1[0]), "ro": float(card1[1]), "bulk": float(card1[2]), "rows": rows}
