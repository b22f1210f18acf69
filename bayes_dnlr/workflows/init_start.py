"""``init``'s answer to a first sample that already carries load (data/checks.first_sample_warning):
the config gets the remedy the file points to, a check line names the other, and ``none`` is never
written where the warning fires (docs/data-input.md, section 0 and 'The first sample').

What the file shows is where its strain counts from. A first sample whose strain lies clearly above
zero (more than FIRST_SAMPLE_NOISE sd of the strain's noise) was measured from the unloaded length:
the first rows are missing (a cropped toe, as in the rHDPE export), and ``initial_state:
ramp-from-zero`` puts them back as a loading from zero at the initial rate. A strain at zero under
load was zeroed there (a preload, a seating load): nothing tells where the unloaded length was, and
``toe: compensate`` takes the standards' zero point, where the linear start meets zero stress
(ASTM D638 X1, ISO 527-1). Measured on the shipped Bluehill-like export (E = 2854 MPa) with its
first 3-20 rows cut (18-72 % of the peak force), white least squares on init's window:
ramp-from-zero 2776-2910 MPa, compensate 2558-1295 MPa (the start's steepest slope, on a cropped
curve, is already past the linear part), none 4372-20000 (the prior's bound); with the strain also
zeroed at the first sample, compensate 2553-1433 and ramp-from-zero, with no strain to ramp over,
none's. On the rHDPE export both remedies agree under model error (posterior E 2440 ± 158 and 2411
± 189 MPa; none 1774 ± 87 and a verdict that the model does not describe the test).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from bayes_dnlr.data.checks import FIRST_SAMPLE_NOISE, noise_sd


@dataclass(frozen=True)
class Remedy:
    """A config key and value that answer a loaded first sample, and why (a sentence)."""

    key: str            # "initial_state" or "toe"
    value: str
    why: str


def remedies(strain: np.ndarray) -> list[Remedy]:
    """The remedies in the order the measured strain ``strain`` (as the reader reads it, unloaded
    start assumed) points to them: the one that fits where the strain counts from first."""
    e = np.asarray(strain, dtype=float)
    e0 = float(e[0])
    sd = noise_sd(e[:200])
    level = max(FIRST_SAMPLE_NOISE * (sd if np.isfinite(sd) else 0.0), 1e-6)
    ramp = Remedy("initial_state", "ramp-from-zero",
                  f"its strain, {e0:.4g}, lies clearly above zero (the strain's noise sd is about "
                  f"{sd:.2g}): it counts from the unloaded length and the first rows are missing; "
                  "ramp-from-zero lets the model load the specimen from zero strain at the initial rate")
    compensate = Remedy("toe", "compensate",
                        f"its strain, {e0:.4g}, is zero within its noise (sd about {sd:.2g}): the strain "
                        "was zeroed under load (a preload); compensate measures it from point B, where "
                        "the linear start meets zero stress (ASTM D638 X1, ISO 527-1)")
    return [ramp, compensate] if e0 > level else [compensate, ramp]


def other_words(chosen: Remedy) -> str:
    """The other remedy, for the check line: when it is the right one instead."""
    if chosen.key == "initial_state":
        return ("`data.toe: compensate` instead if the strain was zeroed under load (a preload) or the "
                "start holds slack")
    return "`data.initial_state: ramp-from-zero` instead if the strain counts from the unloaded length"


def apply(data: dict[str, Any], remedy: Remedy | None) -> dict[str, Any]:
    """``data`` (a config's data section) with ``remedy`` and without the other key's remedy."""
    out = {k: v for k, v in data.items() if k not in ("toe", "initial_state")}
    if remedy is not None:
        out[remedy.key] = remedy.value
    return out
