"""The references of a run (``reference_moduli:``) as observations of the model's linear moduli: what
each one measured, at which time scale, with which sd, and the model's prediction there.

A point measured at a frequency f observes E'(2πf), the storage modulus of the modes of E(t)
(model/modulus.py, eq. 10-14 under a small sinusoidal strain); at a time t it observes E(t); a
DMA sweep observes E'(ω) and E''(ω) at each of its frequencies. Where every mode is frozen
(ω τ_1 ≥ ``FROZEN``) E'(ω) is E itself, and the words say so. A value without a time scale (a
data sheet's modulus) has no prediction: it is set beside E only, as the paper's Table 4 does.

The likelihood of the references a config puts in the data is Gaussian and independent of the
tests': log L = −½ Σ ((v − g(θ))/s)² − Σ ln s − (m/2) ln 2π over their elements.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bayes_dnlr.model.modulus import (
    FROZEN,
    complex_modulus,
    fastest_mode_product,
    relaxation_modulus,
)
from bayes_dnlr.numbers import frequency_text
from bayes_dnlr.vocabulary import SPECTRUM_EXPONENT, UNIVERSAL_EXPONENT

STORAGE, LOSS, RELAXATION = "storage", "loss", "relaxation"
# what a reference's prediction depends on; with a temperature law, its parameters too (a_T carries
# a reference's temperature to the spectrum's reference one)
SPECTRAL = ("E", "G", "tau_max", SPECTRUM_EXPONENT)
PREDICTED_BY = (*SPECTRAL, "Ea", "C1", "C2")
LOG_STEP = 1.0e-5        # central differences in ln tau_max and in alpha
TEMPERATURE_TOLERANCE = 1.0   # °C: a reference this close to the tests' temperature is at theirs
_LOG_2PI = math.log(2.0 * math.pi)


@dataclass
class Reference:
    """One entry of ``reference_moduli``, its elements as arrays of equal length m: the quantity
    observed (``STORAGE``, ``LOSS`` or ``RELAXATION``), where (Hz, or s), the value and its sd (MPa,
    NaN when not given), the shift factor of its time scale."""

    index: int
    label: str
    method: str
    use: str                     # "check" | "data"
    quantity: np.ndarray         # (m,) str
    at: np.ndarray               # (m,) Hz (storage, loss) or s (relaxation)
    value: np.ndarray            # (m,) MPa
    sd: np.ndarray               # (m,) MPa, NaN when not given
    test: str | None             # whose parameters predict it (None: the run's shared ones)
    shift: np.ndarray            # (m,) a_T of each element's temperature (1: the tests')
    temperature: np.ndarray      # (m,) °C, NaN when not given
    law: tuple[str, float] | None = None   # the model's temperature law and reference temperature:
    #                                        a_T then comes from each draw's Ea (C1, C2)
    spec: Any = field(repr=False, default=None)     # the config entry
    notes: list[str] = field(default_factory=list)     # what to say about it (its temperature)
    sweep: bool = False
    reading: list[str] = field(default_factory=list)   # how a sweep's file was read

    @property
    def m(self) -> int:
        return int(self.value.size)

    @property
    def predictable(self) -> bool:
        """A time scale was given: the model predicts it."""
        return self.m > 0 and bool(np.all(np.isin(self.quantity, (STORAGE, LOSS, RELAXATION))))

    @property
    def headline(self) -> int:
        """The element Table 4 shows: a point's own; for a sweep the storage modulus at its highest
        frequency (the one nearest E)."""
        if not self.sweep:
            return 0
        rows = np.flatnonzero(self.quantity == STORAGE)
        return int(rows[np.argmax(self.at[rows])]) if rows.size else 0

    def where(self, i: int | None = None) -> str:
        """Words for an element's time scale: "E'(5 MHz)", "E''(0.1 Hz)", "E(t = 0.001 s)"."""
        i = self.headline if i is None else i
        q, x = str(self.quantity[i]), float(self.at[i])
        if q == RELAXATION:
            return f"E(t = {x:.3g} s)"
        return ("E'" if q == STORAGE else "E''") + f"({frequency_text(x)})"


# ---------------------------------------------------------------- the shift of a time scale

def tests_temperature(cfg) -> float | None:
    """The tests' temperature (°C) when the config gives one (``data.temperature`` of every test, all
    equal), else None."""
    values = set()
    for view in cfg.test_configs():
        t = getattr(view.data, "temperature", None) if view.data is not None else None
        if not isinstance(t, int | float):
            return None
        values.add(float(t))
    return values.pop() if len(values) == 1 else None


def temperature_shift(cfg, temperature: np.ndarray, label: str, use: str
                      ) -> tuple[np.ndarray, list[str]]:
    """a_T of each element measured at ``temperature`` (°C, NaN: not given) relative to the tests,
    and what to say about it. THE place where the model's temperature shift factor (``model.shift``)
    is applied to a reference's time scale, when the model has one: τ_j(T) = a_T(T) τ_j. Without
    it a reference is predicted at the tests' temperature: said in a note, and an error for data
    measured elsewhere (a likelihood term of another temperature would pull the spectrum)."""
    temperature = np.asarray(temperature, dtype=float)
    shift = np.ones(temperature.size)
    given = temperature[np.isfinite(temperature)]
    if given.size == 0:
        return shift, []
    if cfg.model.shift.temperature != "none":
        # the law carries each temperature to the reference one, draw by draw (``predict``)
        return shift, []
    own = tests_temperature(cfg)
    lo, hi = float(given.min()), float(given.max())
    at = f"{lo:g} °C" if hi - lo <= TEMPERATURE_TOLERANCE else f"{lo:g}-{hi:g} °C"
    if own is not None and max(abs(lo - own), abs(hi - own)) <= TEMPERATURE_TOLERANCE:
        return shift, []
    if hi - lo > TEMPERATURE_TOLERANCE and use == "data":
        from bayes_dnlr.errors import BayesDnlrError

        raise BayesDnlrError(
            f"reference_moduli ({label}): its rows span {at}, and the model has no temperature "
            "(no shift factor, model.shift): it cannot put them in one likelihood. Keep the rows of "
            "one temperature, or use: check")
    if own is None:
        return shift, [f"measured at {at}; the model has no temperature (no shift factor): it is "
                       "predicted at the tests' own temperature, taken to be the same"]
    if use == "data":
        from bayes_dnlr.errors import BayesDnlrError

        raise BayesDnlrError(
            f"reference_moduli ({label}): measured at {at}, the tests at {own:g} °C, and the model has "
            "no shift factor (model.shift) to carry the time scale across: use: check, or give the "
            "model a temperature shift")
    return shift, [f"measured at {at}, the tests at {own:g} °C: predicted at the tests' temperature "
                   "(the model has no shift factor), so part of a disagreement may be the temperature"]


# ---------------------------------------------------------------- the model's prediction

def columns_of(values: Mapping[str, Any]) -> dict[str, np.ndarray | float]:
    """E, G, tau_max and alpha from a mapping of draws or values (alpha ½ and G 0 when absent)."""
    return {"E": values["E"], "G": values.get("G", 0.0), "tau_max": values["tau_max"],
            SPECTRUM_EXPONENT: values.get(SPECTRUM_EXPONENT, UNIVERSAL_EXPONENT)}


def law_factor(ref: Reference, values: Mapping[str, Any], rows: np.ndarray) -> np.ndarray | float:
    """a_T of the elements ``rows`` (one temperature) for each draw of ``values`` under the model's
    temperature law; 1 without one or at the reference temperature (a reference without a
    temperature is taken at it)."""
    from bayes_dnlr.model.shift import temperature_shift as a_t

    if ref.law is None:
        return 1.0
    T = float(ref.temperature[rows[0]])
    law, reference = ref.law
    if not np.isfinite(T) or T == reference:
        return 1.0
    return a_t(T, law, reference, **{k: values.get(k) for k in ("Ea", "C1", "C2")})


def predict(ref: Reference, values: Mapping[str, Any], modes: int = 50,
            decades: float = 6.0) -> np.ndarray:
    """The model's value of each element: (k, m) for k draws (or (m,) for one parameter set)."""
    c = columns_of(values)
    law = [values[k] for k in ("Ea", "C1", "C2") if ref.law is not None and k in values]
    scalar = all(np.ndim(v) == 0 for v in [*c.values(), *law])
    E, G, tau, a = (np.atleast_1d(np.asarray(c[k], dtype=float)) for k in SPECTRAL)
    k = max(E.size, G.size, tau.size, a.size, *(np.size(v) for v in law))
    out = np.full((k, ref.m), np.nan)
    groups = (np.round(np.nan_to_num(ref.temperature, nan=-1e9), 6) if ref.law is not None
              else ref.shift)
    for group in np.unique(groups):
        for q in (STORAGE, LOSS, RELAXATION):
            rows = np.flatnonzero((ref.quantity == q) & (groups == group))
            if not rows.size:
                continue
            shift = float(ref.shift[rows[0]])
            # a temperature law: the draws' own a_T times each τ_j (τ_max is the reference state's)
            t_eff = tau * np.atleast_1d(np.asarray(law_factor(ref, values, rows), dtype=float))
            if q == RELAXATION:
                v = relaxation_modulus(ref.at[rows] / shift, E, G, t_eff, a, modes, decades)
            else:
                v = complex_modulus(ref.at[rows], E, G, t_eff, a, modes, decades, shift)[q == LOSS]
            out[:, rows] = np.atleast_2d(v)
    return out[0] if scalar else out


def gradient(ref: Reference, params: Mapping[str, float], names: Sequence[str], modes: int = 50,
             decades: float = 6.0) -> np.ndarray:
    """∂g/∂β (m, len(names)) at ``params`` for the parameters ``names`` (β as the fit reports them:
    tau_max in s); E and G exactly (the prediction is linear in them), tau_max and alpha by central
    differences (in ln tau_max); zero for a parameter the references do not depend on."""
    p = {k: float(v) for k, v in columns_of(params).items()}
    law = {k: float(params[k]) for k in ("Ea", "C1", "C2") if k in params}
    p.update(law)
    out = np.zeros((ref.m, len(names)))
    for j, k in enumerate(names):
        if k == "E":
            out[:, j] = predict(ref, {**p, "E": 1.0, "G": 0.0}, modes, decades)
        elif k == "G":
            out[:, j] = (predict(ref, {**p, "E": 0.0, "G": 1.0}, modes, decades))
        elif k == "tau_max":
            up = predict(ref, {**p, "tau_max": p["tau_max"] * math.exp(LOG_STEP)}, modes, decades)
            down = predict(ref, {**p, "tau_max": p["tau_max"] * math.exp(-LOG_STEP)}, modes, decades)
            out[:, j] = (up - down) / (2 * LOG_STEP) / p["tau_max"]
        elif k == SPECTRUM_EXPONENT:
            a = p[SPECTRUM_EXPONENT]
            up = predict(ref, {**p, SPECTRUM_EXPONENT: a + LOG_STEP}, modes, decades)
            down = predict(ref, {**p, SPECTRUM_EXPONENT: a - LOG_STEP}, modes, decades)
            out[:, j] = (up - down) / (2 * LOG_STEP)
        elif k in ("Ea", "C1", "C2") and k in params:
            v = float(params[k])
            h = LOG_STEP * max(abs(v), 1.0)
            up = predict(ref, {**p, **law, k: v + h}, modes, decades)
            down = predict(ref, {**p, **law, k: v - h}, modes, decades)
            out[:, j] = (up - down) / (2 * h)
    return out


def regime(ref: Reference, params: Mapping[str, float], decades: float = 6.0) -> tuple[str, str]:
    """(kind, words) of a point's time scale at ``params``: "frozen" when every mode is frozen at
    its frequency (E'(ω) is E itself), "spectrum" inside the spectrum, "relaxation" for a time,
    "none" without a time scale."""
    i = ref.headline
    q = str(ref.quantity[i])
    if q == RELAXATION:
        return "relaxation", f"E(t) at t = {float(ref.at[i]):.3g} s after a small step (eq. 11-14)"
    if q not in (STORAGE, LOSS):
        return "none", "no time scale given: set beside E only (the paper's Table 4)"
    wt = fastest_mode_product(float(ref.at[i]), float(params["tau_max"]), decades, float(ref.shift[i]))
    if q == STORAGE and wt >= FROZEN:
        return "frozen", (f"every mode is frozen at {frequency_text(float(ref.at[i]))} (ω τ_1 = {wt:.3g}): "
                          "E'(ω) is E itself")
    return "spectrum", (f"{ref.where(i)} inside the spectrum (ω τ_1 = {wt:.3g}): the storage modulus of "
                        "the modes that have not relaxed at this frequency")


# ---------------------------------------------------------------- likelihood

def log_likelihood(refs: Sequence[Reference], values: Mapping[str, Any], modes: int = 50,
                   decades: float = 6.0) -> np.ndarray:
    """Σ log N(v | g(θ), s²) over the elements of ``refs`` (k,) (each must have its sd); -inf where
    a prediction is not finite."""
    total: np.ndarray | float = 0.0
    for ref in refs:
        g = np.atleast_2d(predict(ref, values, modes, decades))
        r = (ref.value[None, :] - g) / ref.sd[None, :]
        ll = -0.5 * np.sum(r * r, axis=1) - float(np.sum(np.log(ref.sd))) - 0.5 * ref.m * _LOG_2PI
        total = total + np.where(np.isfinite(ll), ll, -np.inf)
    return np.atleast_1d(np.asarray(total, dtype=float))


def data_references(refs: Sequence[Reference]) -> list[Reference]:
    """The references the likelihood takes (``use: data``)."""
    return [r for r in refs if r.use == "data"]


class ReferenceLikelihood:
    """The data references' log-likelihood as a function of the run's vector: ``theta`` (k, ndim)
    in the order ``names`` -> (k,). ``name_of(k, test)`` is the run's name of a reference's
    parameter k (``Layout.name``); a parameter not among ``names`` takes its value in ``fixed``."""

    def __init__(self, refs: Sequence[Reference], names: Sequence[str], name_of,
                 fixed: Mapping[str, float], modes: int = 50, decades: float = 6.0) -> None:
        self.refs = list(refs)
        self.modes, self.decades = modes, decades
        names = list(names)
        self.columns = []
        for ref in self.refs:
            cols: dict[str, int | float] = {}
            for k in PREDICTED_BY:
                g = name_of(k, ref.test) if ref.test is not None else k
                if g in names:
                    cols[k] = names.index(g)
                elif k in fixed:
                    cols[k] = float(fixed[k])
            if not {"E", "tau_max"} <= set(cols):
                raise ValueError(f"reference_moduli ({ref.label}): the run has no E or tau_max to "
                                 "predict it")
            self.columns.append(cols)

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        out = np.zeros(theta.shape[0])
        for ref, cols in zip(self.refs, self.columns, strict=True):
            values = {k: theta[:, c] if isinstance(c, int) else c for k, c in cols.items()}
            out += log_likelihood([ref], values, self.modes, self.decades)
        return out
