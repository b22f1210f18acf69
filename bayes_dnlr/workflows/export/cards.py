"""Material cards with uncertainty: which posterior draws become cards, the Prony series of each,
Poisson's ratio, and the checks printed with them.

- ``median``, ``q05``, ``q95``: the whole posterior draw whose E is nearest the 50 %, 5 % and 95 %
  quantile of E (its G and tau_max are those of the same draw, so the three cards sit on the
  posterior's E-tau_max ridge, ρ ≈ -0.999, and not at independent marginal quantiles);
- ``draw001`` ...: ``draws`` whole posterior draws at random (seeded), for an FE ensemble.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from bayes_dnlr.errors import BayesDnlrError
from bayes_dnlr.model.shift import NO_SHIFT, Shift
from bayes_dnlr.vocabulary import UNIVERSAL_EXPONENT
from bayes_dnlr.workflows.export.prony import Prony, Refit, from_parameters, refit

QUANTILES = {"q05": 0.05, "median": 0.5, "q95": 0.95}
SMALL_STRAIN_TOLERANCE = 0.01    # the card's validity: |card - model| / model below this on a ramp
STRAIN_FLOOR = 1e-5              # the refit range starts where the test's ramp reaches this strain
RAMP_CHECK_STRAIN = 0.002        # the small-strain check of docs/export.md: a ramp to 0.2 %


@dataclass(frozen=True)
class Card:
    """One material card: the posterior draw it comes from and its Prony series."""

    label: str
    params: dict[str, float]           # the whole draw (E, G, tau_max, ...)
    quantile_of_E: float | None        # the quantile of E this card stands for, or None (a draw)
    draw_index: int                    # index in the flattened posterior
    prony: Prony                       # what is written (the N-mode series, or the refit)
    refit: Refit | None = None
    a_test: float = 1.0                # a_T at the test's temperature (a shifted model's series is
                                       # the reference temperature's: its times are a_T times the test's)

    @property
    def at_test(self) -> Prony:
        """The card's series at the test's temperature (as a solver shifts it there)."""
        return self.prony.scaled(self.a_test)


@dataclass(frozen=True)
class TimeRange:
    """The time range of the test the cards are made for (refit range, checks)."""

    t_lo: float          # s: the smaller of the sampling step and the time to reach STRAIN_FLOOR
    t_hi: float          # s: the duration of the identification window
    strain_rate: float   # 1/s, the test's loading rate


@dataclass
class CardSet:
    cards: list[Card]
    time_range: TimeRange
    terms: int | None
    checks: dict[str, object] = field(default_factory=dict)


def pick_draws(E: np.ndarray, draws: int, seed: int) -> dict[str, tuple[int, float | None]]:
    """label -> (index of the whole draw, quantile of E or None)."""
    out: dict[str, tuple[int, float | None]] = {}
    for label, q in QUANTILES.items():
        out[label] = (int(np.argmin(np.abs(E - np.quantile(E, q)))), q)
    if draws:
        if draws > E.size:
            raise BayesDnlrError(f"--draws {draws}: the posterior holds {E.size} draws")
        idx = np.sort(np.random.default_rng(seed).choice(E.size, size=draws, replace=False))
        width = max(3, len(str(draws)))
        for k, i in enumerate(idx, start=1):
            out[f"draw{k:0{width}d}"] = (int(i), None)
    return out


def make_cards(values: dict[str, np.ndarray], modes: int, decades: float, time_range: TimeRange,
               terms: int | None = None, draws: int = 0, seed: int = 0,
               a_test: Callable[[Mapping[str, float]], float] | None = None) -> CardSet:
    """The cards (median, q05, q95 and ``draws`` random draws), each refitted to ``terms`` terms
    over the test's time range when ``terms`` is given. ``a_test``: a_T at the test's temperature of
    a draw, when the model has a temperature law (its series is the reference temperature's, so a
    refit covers the test's times divided by a_T)."""
    picks = pick_draws(values["E"], draws, seed)
    cards: list[Card] = []
    for label, (i, q) in picks.items():
        params = {k: float(v[i]) for k, v in values.items()}
        a = 1.0 if a_test is None else float(a_test(params))
        full = from_parameters(params["E"], params["G"], params["tau_max"], modes, decades,
                               params.get("alpha", UNIVERSAL_EXPONENT))
        fit = None
        if terms is not None:
            fit = refit(full, terms, time_range.t_lo / a, time_range.t_hi / a)
        cards.append(Card(label, params, q, i, fit.prony if fit else full, fit, a))
    return CardSet(cards, time_range, terms)


def ramp(rate: float, strain_max: float, n: int = 400,
         t_first: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A ramp from rest at ``rate`` to ``strain_max``: 0 and n log-spaced times from ``t_first``
    (default: a millionth of the ramp's duration)."""
    t_end = strain_max / rate
    t_first = t_end * 1e-6 if t_first is None else min(t_first, t_end / 10.0)
    t = np.concatenate([[0.0], np.geomspace(t_first, t_end, n)])
    return t, rate * t


def small_strain_limit(card: Card, rate: float, modes: int, decades: float,
                       strain_max: float = 2.0, shift: Shift = NO_SHIFT,
                       temperature: float | None = None) -> float:
    """The largest strain up to which the card's ramp response at ``rate`` stays within
    SMALL_STRAIN_TOLERANCE of the DNLR model (eq. 18, with ε_HT and the Hencky strain). With a
    ``shift``, at the test's ``temperature`` (°C): the card as a solver shifts it there against the
    model with its shift factor (its stress shift included, which no card holds)."""
    from bayes_dnlr.model import simulate

    t, e = ramp(rate, strain_max, 2000)
    p = card.params
    names = ("E", "G", "tau_max", "alpha", *shift.parameters)
    model = simulate(t, e, {k: p[k] for k in names if k in p}, modes, decades, shift=shift,
                     temperature=temperature if shift.temperature != "none" else None)
    diff = np.abs(card.at_test.response(t, e) - model) / np.maximum(np.abs(model), 1e-300)
    bad = np.flatnonzero(diff[1:] > SMALL_STRAIN_TOLERANCE)
    return float(strain_max if bad.size == 0 else e[1:][bad[0]])


def bracket_checks(cards: list[Card], time_range: TimeRange) -> dict[str, object]:
    """Do the q05 and q95 cards bracket the median card? In E(0), in the ramp response to 0.2 %
    at the test's rate (samples from the range's start on), and over how much of the test's time
    range in E(t); each card at the test's temperature (``Card.at_test``)."""
    by = {c.label: c for c in cards}
    lo, mid, hi = by["q05"].at_test, by["median"].at_test, by["q95"].at_test
    t = np.concatenate([[0.0], np.geomspace(time_range.t_lo, time_range.t_hi, 400)])
    m_lo, m_mid, m_hi = lo.modulus(t), mid.modulus(t), hi.modulus(t)
    ok = (m_lo <= m_mid) & (m_mid <= m_hi)
    first_bad = np.flatnonzero(~ok)
    tr, er = ramp(time_range.strain_rate, RAMP_CHECK_STRAIN, t_first=time_range.t_lo)
    r_lo, r_mid, r_hi = lo.response(tr, er), mid.response(tr, er), hi.response(tr, er)
    ramp_ok = bool(np.all((r_lo[1:] <= r_mid[1:]) & (r_mid[1:] <= r_hi[1:])))
    return {
        "E0": [lo.e0, mid.e0, hi.e0],
        "E0_bracketed": bool(lo.e0 <= mid.e0 <= hi.e0),
        "ramp_bracketed": ramp_ok,
        "modulus_bracketed_until_s": (None if first_bad.size == 0
                                      else (0.0 if first_bad[0] == 0 else float(t[first_bad[0] - 1]))),
    }


def ramp_error(short: Prony, full: Prony, rate: float, t_first: float | None = None) -> float:
    """max relative difference of the ramp responses to 0.2 % strain at ``rate`` (at the ramp's
    samples from ``t_first`` on: a refit holds on the test's time range)."""
    t, e = ramp(rate, RAMP_CHECK_STRAIN, t_first=t_first)
    a, b = short.response(t, e)[1:], full.response(t, e)[1:]
    return float(np.max(np.abs(a - b) / np.abs(b)))


# ---------------------------------------------------------------- Poisson's ratio

@dataclass(frozen=True)
class Poisson:
    value: float | None
    source: str


NU_STRAIN_MAX = 0.02     # the transverse-strain slope is taken over 0 < ε11 <= this ...
NU_STRAIN_CAP = 0.05     # ... or over the first NU_MIN_SAMPLES samples when they stay below this
NU_MIN_SAMPLES = 5


def poisson_from_strains(axial: np.ndarray, transverse: np.ndarray) -> tuple[float, int, float]:
    """ν = -dε22/dε11 by least squares through the origin over the small strains: the samples with
    0 < ε11 <= NU_STRAIN_MAX, or the first NU_MIN_SAMPLES samples if fewer (and they stay below
    NU_STRAIN_CAP). Returns (ν, samples used, largest ε11 used)."""
    axial = np.asarray(axial, dtype=float)
    transverse = np.asarray(transverse, dtype=float)
    ok = (axial > 0) & np.isfinite(transverse)
    m = ok & (axial <= NU_STRAIN_MAX)
    if m.sum() < NU_MIN_SAMPLES:
        first = np.flatnonzero(ok)[:NU_MIN_SAMPLES]
        if first.size < NU_MIN_SAMPLES or axial[first].max() > NU_STRAIN_CAP:
            raise BayesDnlrError(
                f"only {int(m.sum())} samples with 0 < ε11 <= {NU_STRAIN_MAX:g}: too few to take Poisson's "
                "ratio from the transverse strain; give --nu")
        m = np.zeros(axial.size, bool)
        m[first] = True
    a, tr = axial[m], transverse[m]
    return float(-(a @ tr) / (a @ a)), int(m.sum()), float(a.max())


def check_poisson(nu: Poisson, solver: str | None) -> None:
    """Solvers' elastic cards need -1 < ν < 0.5 (the bulk modulus E/(3(1-2ν)) is infinite at 0.5)."""
    if solver is None:
        return
    where = "--nu" if nu.source == "--nu" else f"Poisson's ratio ({nu.source})"
    if nu.value is None:
        raise BayesDnlrError(
            f"--nu: {solver} needs Poisson's ratio and the run has no transverse strain to take it from "
            "(data.columns.eps22). The paper's ν = 0.5 (isovolumic, eq. 3) cannot go into an elastic "
            f"card: its bulk modulus E/(3(1-2ν)) is infinite. Give --nu with a measured value below 0.5")
    if not (math.isfinite(nu.value) and -1.0 < nu.value < 0.5):
        raise BayesDnlrError(
            f"{where}: ν = {nu.value:.4g}; {solver} needs -1 < ν < 0.5 (ν = 0.5, the paper's isovolumic "
            "assumption, makes the bulk modulus E/(3(1-2ν)) infinite, and Abaqus/Explicit, LS-DYNA and "
            "most Ansys elements refuse it). Give --nu with a measured value below 0.5")
