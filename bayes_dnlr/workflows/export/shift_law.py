"""The run's shift factor a(T, σ) = a_T(T)·a_σ(σ) (model/shift.py; docs/theory.md, "The shift
factor") as the cards carry it.

A shifted run's τ_max is the reference state's (``reference_temperature``, σ → 0), so every card's
Prony series is the reference state's too; a solver that has the temperature law shifts it to the
temperature of its analysis. What each format carries, and what it cannot, is the writer's
(``shift_support`` in abaqus.py, ansys.py, lsdyna.py, table.py); this module holds what they
share: the law, each card's values of its parameters, the posterior's intervals of them, the
test's temperature, and the units the solvers take (Ea in kJ/mol becomes E0 in mJ/mol, the energy
of the N-mm-s-tonne system, or Ea/R in K; °C becomes K where a law needs absolute temperatures).
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from bayes_dnlr.model.shift import GAS_CONSTANT, KELVIN, stress_shift, temperature_shift
from bayes_dnlr.vocabulary import SHIFT_LAW_PARAMETERS, UNITS

GAS_CONSTANT_MJ = GAS_CONSTANT * 1000.0     # mJ/(mol K): R in the cards' N-mm-s-tonne system
INTERVAL = (0.05, 0.95)                     # the 90 % interval the headers quote
WIDTH = 96                                  # comment lines of the cards' shift paragraphs


def para(text: str, indent: str = "  ") -> list[str]:
    """A paragraph as comment lines (no marker): the first flush, the others indented. No line
    holds a newline: a card's comment marker opens every one."""
    return textwrap.wrap(text, WIDTH, subsequent_indent=indent, break_on_hyphens=False,
                         break_long_words=False)


@dataclass(frozen=True)
class Spread:
    """A shift parameter across the posterior: its median and 90 % interval, or its fixed value."""

    median: float
    low: float
    high: float
    fixed: bool = False

    def text(self, unit: str) -> str:
        u = f" {unit}" if unit and unit != "-" else ""
        if self.fixed:
            return f"{self.median:.6g}{u}, fixed in the run's config"
        return (f"posterior median {self.median:.6g}{u}, 90 % interval {self.low:.6g} to "
                f"{self.high:.6g}{u}")


def _unit(name: str) -> str:
    u = UNITS[name]
    return "" if u == "-" else u


@dataclass(frozen=True)
class ShiftLaw:
    """The shift of a run's model (``model.shift``), the test's temperature and the posterior of
    the law's parameters."""

    temperature: str                     # arrhenius | wlf | none
    reference: float | None              # °C: where a_T = 1 (with a temperature law)
    stress: str                          # eyring | none
    driving: str                         # the stress that drives a_σ
    test_temperature: float | None       # °C: the test's (a column's mean), None when unknown
    spread: dict[str, Spread] = field(default_factory=dict)

    @property
    def parameters(self) -> tuple[str, ...]:
        return SHIFT_LAW_PARAMETERS[self.temperature] + SHIFT_LAW_PARAMETERS[self.stress]

    @property
    def has_temperature(self) -> bool:
        return self.temperature != "none"

    @property
    def has_stress(self) -> bool:
        return self.stress != "none"

    def a_T(self, params: Mapping[str, float], temperature: float | None = None) -> float:
        """a_T at ``temperature`` (°C; the test's when None) with the card's parameters: 1 without
        a temperature law or a temperature."""
        t = self.test_temperature if temperature is None else temperature
        if not self.has_temperature or t is None:
            return 1.0
        return float(temperature_shift(t, self.temperature, self.reference,
                                       **{k: params.get(k) for k in ("Ea", "C1", "C2")}))

    def lines(self, params: Mapping[str, float], t_range: tuple[float, float]) -> list[str]:
        """Plain-text lines every card of a shifted run opens with (after the common header)."""
        out = ["SHIFT FACTOR of the run's model (docs/theory.md): every mode relaxes in reduced time,",
               "  dpsi = dt / (a_T(T) * a_sigma(sigma)); the series above is the reference state's:"]
        ref = []
        if self.has_temperature:
            ref.append(f"T_ref = {self.reference:g} degC (a_T = 1)")
        if self.has_stress:
            ref.append("sigma -> 0 (a_sigma = 1)")
        out.append(f"  {', '.join(ref)}")
        if self.temperature == "arrhenius":
            out += para(f"  a_T: Arrhenius, ln a_T = (1000 Ea/R) (1/(T + 273.15) - 1/(T_ref + 273.15)), T in "
                        f"degC, R = {GAS_CONSTANT} J/(mol K)", "    ")
        elif self.temperature == "wlf":
            out.append("  a_T: WLF, log10 a_T = -C1 (T - T_ref) / (C2 + T - T_ref)")
        if self.has_stress:
            out.append(f"  a_sigma: Eyring, a_sigma = x / sinh(x), x = |s|/sigma_s, s the {self._driving()}")
        for k in self.parameters:
            spread = self.spread.get(k)
            said = ("" if spread is None else " (fixed in the run's config)" if spread.fixed
                    else f" in this card's draw ({spread.text(UNITS[k])})")
            value = f"{params[k]:.6g} {_unit(k)}".rstrip()
            out += para(f"    {k} = {value}{said}", "      ")
        if self.has_temperature and self.test_temperature is not None:
            a = self.a_T(params)
            out += para(f"  The test was at {self.test_temperature:g} degC: a_T = {a:.4g} (this draw); its "
                        f"loading times {t_range[0]:.3g}-{t_range[1]:.4g} s are {t_range[0] / a:.3g}-"
                        f"{t_range[1] / a:.4g} s at T_ref.", "    ")
        return out

    def _driving(self) -> str:
        return {"stress": "true stress", "peak": "largest |true stress| so far",
                "overstress": "overstress sigma - sigma^r"}.get(self.driving, self.driving)


@dataclass(frozen=True)
class Support:
    """What one format carries of a run's shift law: the comment lines its cards say it in, and one
    line for the export's summary."""

    lines: list[str]
    summary: str


def spread_of(values: Mapping[str, np.ndarray], fixed: Mapping[str, float],
              names: tuple[str, ...]) -> dict[str, Spread]:
    """Each shift parameter's posterior median and 90 % interval (its fixed value when fixed)."""
    out = {}
    for k in names:
        if k in fixed:
            v = float(fixed[k])
            out[k] = Spread(v, v, v, fixed=True)
        elif k in values:
            lo, med, hi = np.quantile(np.asarray(values[k], dtype=float), (INTERVAL[0], 0.5, INTERVAL[1]))
            out[k] = Spread(float(med), float(lo), float(hi))
    return out


def kelvin(celsius: float) -> float:
    return float(celsius) + KELVIN


def activation_temperature(ea_kj_mol: float) -> float:
    """Ea / R in K (Ea in kJ/mol): the Arrhenius law's one constant in a solver that takes it so."""
    return 1000.0 * float(ea_kj_mol) / GAS_CONSTANT


def activation_energy_mj(ea_kj_mol: float) -> float:
    """Ea in mJ/mol, the energy unit of the N-mm-s-tonne system (N mm = mJ)."""
    return 1.0e6 * float(ea_kj_mol)


def solver_support(law: ShiftLaw, params: Mapping[str, float], lines: list[str], summary: str,
                   option: str) -> Support:
    """A solver's Support: what it says of the temperature law (``lines``, ``summary``), then the
    stress shift it cannot carry (``option``: what shifts its Prony series, with temperature only)."""
    lines = lines + no_stress_shift(law, params, f"{option} shifts the Prony series with temperature only")
    if law.has_stress:
        summary += f"; NO stress shift ({option} has none): the cards are the σ → 0 linear limit"
    return Support(lines, summary)


def no_stress_shift(law: ShiftLaw, params: Mapping[str, float], why: str) -> list[str]:
    """The lines a card says when its format cannot carry the Eyring stress shift."""
    if not law.has_stress:
        return []
    once, four = 1 / stress_shift(1.0, 1.0), 1 / stress_shift(4.0, 1.0)
    return para(f"NO STRESS SHIFT in this card: {why}. The run's model has an Eyring stress shift "
                f"(sigma_s = {params['sigma_s']:.6g} MPa in this draw): every mode relaxes sinh(x)/x times "
                f"faster at stress s (x = |s|/sigma_s: {once:.3g} times at s = sigma_s, "
                f"{four:.3g} times at 4 sigma_s). This card is the sigma -> 0 (linear) "
                "limit of that model: it relaxes too slowly wherever |s| is not small against sigma_s (the "
                "strain limit above is measured against the model with its stress shift). A stress-dependent "
                "shift needs a user material implementing docs/theory.md's reduced time.")
