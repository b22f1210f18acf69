"""What every exported file states besides its numbers: provenance, units, assumptions, limits."""

from __future__ import annotations

from dataclasses import dataclass, field

from bayes_dnlr.workflows.export.cards import Card, Poisson
from bayes_dnlr.workflows.export.shift_law import ShiftLaw

UNITS = "N, mm, s, tonne (stress and moduli in MPa, time in s, density in tonne/mm³)"
KG_M3_TO_TONNE_MM3 = 1.0e-12


@dataclass(frozen=True)
class Context:
    """The facts shared by the cards of one export."""

    material: str                   # material name in the card
    run: str                        # the run directory it comes from
    poisson: Poisson
    density: float | None           # kg/m³, or None
    modes: int
    decades: float
    strain_rate: float              # 1/s, the test's
    small_strain_limit: float       # strain up to which the median card follows the model within 1 %
    t_range: tuple[float, float]    # the test's time range, s
    notes: list[str] = field(default_factory=list)
    shift: ShiftLaw | None = None   # the run's shift factor (None: the model has none)

    @property
    def density_tonne_mm3(self) -> float | None:
        return None if self.density is None else self.density * KG_M3_TO_TONNE_MM3


def header_lines(card: Card, ctx: Context) -> list[str]:
    """Plain-text lines (no comment marker) that open every file."""
    p = card.params
    what = (f"posterior draw #{card.draw_index} nearest the {100 * card.quantile_of_E:g} % quantile of E"
            if card.quantile_of_E is not None else f"posterior draw #{card.draw_index} (ensemble member)")
    if card.refit is None:
        series = f"{card.prony.terms}-term series: the model's own spectrum (eq. 12-14), exact"
    else:
        r = card.refit
        series = (f"{card.prony.terms}-term series refitted (--terms {r.requested}) on "
                  f"{r.t_range[0]:.3g}-{r.t_range[1]:.4g} s: max error of E(t) {100 * r.max_error:.3g} %")
    lines = [
        f"bayes_dnlr export of run {ctx.run}, card '{card.label}': {what}",
        f"  E = {p['E']:.6g} MPa, G = {p['G']:.6g} MPa, tau_max = {p['tau_max']:.6g} s "
        f"({ctx.modes} modes over {ctx.decades:g} decades)",
        "SMALL-STRAIN LINEAR VISCOELASTIC PART OF THE DNLR MODEL ONLY:",
        "  E(t) = 3G + (E - 3G) * sum_j p_j exp(-t/tau_j)",
        "  (Blaise et al. eq. 12-14, and eq. 18 with eps_HT ~ 3 eps: docs/theory.md)",
        f"  {series}",
        f"  It follows the DNLR model within 1 % up to a strain of {ctx.small_strain_limit:.3g} at the "
        f"test's rate {ctx.strain_rate:.3g} 1/s{_conditions(ctx)}",
        "  The viscoplastic hardening of the model (the relaxed state G*eps_HT at large strain) is NOT",
        "  in this card: beyond that strain it needs a user material (Abaqus UMAT/VUMAT, LS-DYNA user",
        "  material, Ansys USERMAT) implementing eq. 18.",
        *_validity(ctx),
        "  3D: constant Poisson's ratio (shear and bulk relax alike: g_i = k_i).",
        f"Poisson's ratio: {'not given' if ctx.poisson.value is None else f'{ctx.poisson.value:.4g}'} "
        f"({ctx.poisson.source})",
        f"Units: {UNITS}",
    ]
    if ctx.shift is not None:
        lines += ctx.shift.lines(p, ctx.t_range)
    return lines + list(ctx.notes)


def _conditions(ctx: Context) -> str:
    """How the small-strain limit was measured, for a shifted model: at the test's temperature (the
    card shifted by the solver's a_T), against the model with its shift."""
    s = ctx.shift
    if s is None:
        return "."
    if s.has_temperature and s.test_temperature is not None:
        return f" and {s.test_temperature:g} degC (with its shift)."
    return " (with its shift)."


def _validity(ctx: Context) -> list[str]:
    s = ctx.shift
    times = f"{ctx.t_range[0]:.3g}-{ctx.t_range[1]:.4g} s"
    if s is None or not s.has_temperature:
        return [f"  Valid at the test's temperature, for loading times in {times}."]
    return [f"  Its relaxation times are at T_ref = {s.reference:g} degC (the shift below moves them); the",
            f"  test's loading times were {times}."]
