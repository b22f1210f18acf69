"""LS-DYNA keyword input: ``*MAT_GENERAL_VISCOELASTIC`` (``*MAT_076``).

Card 1: MID, RO, BULK (PCF, EF, TREF, A, B blank); card 2: LCID, NT, BSTART, TRAMP, LCIDK, NTK,
BSTARTK, TRAMPK (blank: the series is given directly); then one card per term: GI, BETAI, KI,
BETAKI, with G(t) = Σ G_i exp(-β_i t), K(t) = Σ K_i exp(-βk_i t). The long-term moduli are the terms
with β = 0. At most MAX_TERMS cards (docs/export.md for the sources). Fixed 10-character fields.
For a constant ν: G_i = E_i / (2(1+ν)), K_i = E_i / (3(1-2ν)), β_i = 1/τ_i.

An Arrhenius temperature law goes into card 1: TREF (K), A = Ea/R (K), B = 0, for the scaled time
t' = ∫ Φ dt, Φ = exp(-A (1/T - 1/TREF)) = 1/a_T. The WLF law is not written: the form MAT_076
gives A and B (the exponential's base and sign) could not be checked here, so its card says so and
holds the numbers for a user to enter (docs/export.md). MAT_076 has no stress shift: said, not
written.
"""

from __future__ import annotations

from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.model.shift import LN10
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
    if ctx.shift is not None:
        lines += [f"$ {line}" for line in shift_support(ctx.shift, card.params).lines]
    lines += ["$ G_i = E_i/(2(1+nu)), K_i = E_i/(3(1-2nu)), BETA_i = 1/tau_i; the first term (BETA = 0) "
              "is the long-term modulus",
              "*MAT_GENERAL_VISCOELASTIC_TITLE", f"{ctx.material}_{card.label}",
              "$      MID        RO      BULK       PCF        EF      TREF         A         B",
              (i10(mid) + f10(ctx.density_tonne_mm3) + f10(k0)
               + ("" if ctx.shift is None else shift_fields(ctx.shift, card.params))),
              "$     LCID        NT    BSTART     TRAMP     LCIDK       NTK   BSTARTK    TRAMPK",
              i10(0) + i10(0) + " " * FIELD * 2 + i10(0) + i10(0),
              "$       GI     BETAI        KI    BETAKI"]
    lines += [f10(g) + f10(b) + f10(k) + f10(bk) for g, b, k, bk in rows]
    lines.append("*END")
    return "\n".join(lines) + "\n"


def shift_fields(law: ShiftLaw, params: dict[str, float]) -> str:
    """PCF, EF (blank), TREF, A, B of card 1 for an Arrhenius law; nothing otherwise."""
    if law.temperature != "arrhenius":
        return ""
    return " " * FIELD * 2 + f10(kelvin(law.reference)) + f10(activation_temperature(params["Ea"])) + f10(0.0)


def shift_support(law: ShiftLaw, params: dict[str, float]) -> Support:
    """What the card says of the run's shift law, and the summary's line."""
    lines: list[str] = []
    if law.temperature == "arrhenius":
        lines += para("TEMPERATURE SHIFT: card 1 TREF, A and B = 0, MAT_076's Arrhenius shift, the scaled "
                      "time t' = int Phi dt with Phi = exp(-A (1/T - 1/TREF)) = 1/a_T: A = 1000 Ea/R = "
                      f"{activation_temperature(params['Ea']):.10g} K (Ea = {params['Ea']:.6g} kJ/mol), "
                      f"TREF = T_ref = {kelvin(law.reference):.10g} K: the law needs absolute temperatures, "
                      "so the model's temperatures must be in K. The form above is the one this card "
                      "assumes; it was not checked against the LS-DYNA manual here (docs/export.md): "
                      "check it in your version's MAT_076 remarks before use.")
        summary = ("TREF, A, B = 0 of MAT_076 (Arrhenius; temperatures in K; the form not verified against "
                   "the manual here)")
    elif law.temperature == "wlf":
        lines += para("NO TEMPERATURE SHIFT written: this card holds the series at "
                      f"T_ref = {law.reference:g} degC only. MAT_076 takes a WLF law in TREF, A, B, but the "
                      "form it gives them (the exponential's base and its sign) could not be checked against "
                      "the LS-DYNA manual here, so the fields are left blank rather than risk a shift the "
                      "wrong way. The model's law: "
                      f"log10 a_T = -C1 (T - T_ref)/(C2 + T - T_ref), C1 = {params['C1']:.10g}, "
                      f"C2 = {params['C2']:.10g} K; at a temperature T divide every BETAI and BETAKI by "
                      "a_T(T). If your manual gives Phi = exp(-A (T - TREF)/(B + T - TREF)) with "
                      f"t' = int Phi dt, the model's law is TREF = {kelvin(law.reference):.15g} K, "
                      f"A = -ln(10) C1 = {-LN10 * params['C1']:.15g}, B = C2 = {params['C2']:.15g}.")
        summary = (f"NO temperature shift written (MAT_076's WLF form not verified here): the cards hold "
                   f"T_ref = {law.reference:g} °C only; the card's comments give the law's numbers")
    else:
        summary = "no temperature law in the run's model: TREF, A, B blank"
    return solver_support(law, params, lines, summary, "MAT_076")


def _fields(line: str) -> list[str]:
    return [line[i:i + FIELD].strip() for i in range(0, len(line), FIELD)]


def parse(text: str) -> dict:
    """The numbers of a file written by ``render``: MID, RO, BULK, TREF, A, B (None when blank) and
    the (G, β, K, βk) rows."""
    lines = [x.rstrip("\n") for x in text.splitlines() if x.strip() and not x.startswith("$")]
    i = next(k for k, x in enumerate(lines) if x.upper().startswith("*MAT_GENERAL_VISCOELASTIC"))
    j = i + (2 if lines[i].upper().endswith("_TITLE") else 1)
    card1 = _fields(lines[j])
    rows = []
    for line in lines[j + 2:]:
        if line.startswith("*"):
            break
        rows.append(tuple(float(v) for v in _fields(line)[:4]))
    card1 += [""] * (8 - len(card1))
    shift = {k: (float(v) if v else None) for k, v in zip(("tref", "a", "b"), card1[5:8], strict=True)}
    return {"mid": int(card1[0]), "ro": float(card1[1]), "bulk": float(card1[2]), "rows": rows, **shift}
