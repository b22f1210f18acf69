"""Cards from fixed inputs (no fit, no sampling), for the tests of export's writers. Without a shift
law the renderers' output for them is held byte for byte in tests/workflows/export/golden/ (written
by the renderers before the shift law entered the cards), so that a run without a shift keeps
writing exactly what it wrote before; ``shifted`` gives the same cards a shift law."""

from __future__ import annotations

import numpy as np

from bayes_dnlr.workflows.export.cards import Card, CardSet, Poisson, TimeRange
from bayes_dnlr.workflows.export.context import Context
from bayes_dnlr.workflows.export.prony import Prony, Refit, from_parameters
from bayes_dnlr.workflows.export.shift_law import ShiftLaw, Spread

PARAMS = {"E": 2854.0, "G": 2.32, "tau_max": 5.79, "alpha": 0.5}
SHORT = Prony(6.96, np.array([812.5, 640.25, 701.0, 693.29]), np.array([0.004, 0.21, 3.3, 5.79]))


def fixed_cards() -> list[Card]:
    """A median card (the model's 50-term series), two quantile cards and one refitted draw."""
    cards = []
    for label, q, i, scale in (("q05", 0.05, 11, 0.97), ("median", 0.5, 17, 1.0), ("q95", 0.95, 23, 1.03)):
        p = {**PARAMS, "E": PARAMS["E"] * scale, "tau_max": PARAMS["tau_max"] / scale}
        cards.append(Card(label, p, q, i, from_parameters(p["E"], p["G"], p["tau_max"])))
    cards.append(Card("draw001", dict(PARAMS), None, 42, SHORT,
                      Refit(SHORT, (0.002, 380.0), 0.0123, 4)))
    return cards


def fixed_context(notes: list[str] | None = None, shift: ShiftLaw | None = None) -> Context:
    return Context(material="tiny", run="runs/tiny", poisson=Poisson(0.45, "--nu"), density=950.0,
                   modes=50, decades=6.0, strain_rate=0.01, small_strain_limit=0.28,
                   t_range=(0.002, 100.0), notes=list(notes or []), shift=shift)


SHIFT_VALUES = {"Ea": 104.5, "C1": 8.86, "C2": 101.6, "sigma_s": 7.25}


def shifted(temperature: str, stress: str = "none", test_temperature: float = 40.0
            ) -> tuple[Card, Context]:
    """The median card with a shift law (T_ref = 20 °C; the test at ``test_temperature``): its
    draw holds the law's parameters, the posterior's spread of them is made up (Ea fixed)."""
    law = ShiftLaw(temperature, 20.0 if temperature != "none" else None, stress, "stress",
                   test_temperature, {})
    spread = {k: (Spread(v, v, v, fixed=True) if k == "Ea" else Spread(v, 0.8 * v, 1.3 * v))
              for k, v in SHIFT_VALUES.items() if k in law.parameters}
    law = ShiftLaw(law.temperature, law.reference, law.stress, law.driving, law.test_temperature, spread)
    card = fixed_cards()[1]
    card = Card(card.label, {**card.params, **{k: SHIFT_VALUES[k] for k in law.parameters}},
                card.quantile_of_E, card.draw_index, card.prony, card.refit)
    return card, fixed_context(shift=law)


def fixed_set() -> CardSet:
    return CardSet(fixed_cards(), TimeRange(0.002, 100.0, 0.01), None,
                   {"E0": [2768.38, 2854.0, 2939.62], "E0_bracketed": True, "ramp_bracketed": True,
                    "modulus_bracketed_until_s": 3.2})
