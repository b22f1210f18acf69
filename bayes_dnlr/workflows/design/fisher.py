"""The predicted uncertainty of a planned test: the paper's a-priori stochastic analysis (eq. 22,
32-35) under the likelihood ``sample`` uses.

For parameters θ and the noise model (white σ0, plus the model discrepancy δ with fixed
hyperparameters: K = k(x, x) + σ0² I), the Fisher information of the free parameters is XᵀK⁻¹X,
X the sensitivity matrix of eq. 22 on the window. With K = L Lᵀ it is (L⁻¹X)ᵀ(L⁻¹X), and L⁻¹X
costs O(n p) by the Kalman filter of inference/discrepancy/gp.py. The predicted covariance is its inverse
(eq. 32 with K in place of σ0² I), from which come the sd, Err (eq. 33), ρ (eq. 34) and Δ̃ (eq. 35).

Given several draws θ_k (a posterior), the criteria are averaged over them (Bayesian design):
the predicted variances and relative variances are means over the draws, the D-criterion is the
mean of log det of the relative covariance (Chaloner & Verdinelli 1995).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from bayes_dnlr.config import ConfigError
from bayes_dnlr.inference.discrepancy import gp
from bayes_dnlr.inference.discrepancy.axis import make_axis
from bayes_dnlr.inference.lsq.sensitivity import correlation, covariance, sensitivity_matrix
from bayes_dnlr.model import DNLR
from bayes_dnlr.model.shift import NO_SHIFT, Shift
from bayes_dnlr.vocabulary import LOG_COORDINATES, RELAXATION_PARAMETERS, UNIVERSAL_EXPONENT
from bayes_dnlr.workflows.design.candidates import Candidate, planned_protocol, window_mask


@dataclass(frozen=True)
class NoiseDraw:
    """White noise σ0 and the discrepancy's amplitude a (0: white) and length ℓ."""

    sigma0: float
    amplitude: float = 0.0
    length: float = 1.0


@dataclass(frozen=True)
class ErrorModel:
    """A kernel of a run's model of the error, with its weight and (maximum-likelihood) noise: the
    sandwich that widens the sampled kernel's covariance (docs/model-error.md)."""

    weight: float
    kernel: str
    noise: NoiseDraw


@dataclass
class Draws:
    """What the prediction averages over: parameter sets and their noise (one each for a guess)."""

    params: list[dict[str, float]]
    noise: list[NoiseDraw]
    kernel: str = "exp"
    axis: str = "time"
    source: str = ""
    start: str = "stationary"          # stationary | pinned (δ = 0 at the test's first sample)
    note: str = ""                     # the words on ``widen``, when there is one
    widen: list[ErrorModel] = field(default_factory=list)   # the run's kernels, for the sandwich

    @property
    def n(self) -> int:
        return len(self.params)

    @property
    def white(self) -> bool:
        return all(nz.amplitude == 0 for nz in self.noise)


@dataclass
class Prediction:
    """The predicted stochastic analysis of one candidate."""

    candidate: Candidate
    names: list[str] = field(default_factory=list)     # free parameters on this candidate
    n_points: int = 0                                    # samples compared with the model (window)
    total_points: int = 0                                # samples of the whole test
    feasible: bool = True                                # within the constraints
    identifiable: bool = False                           # a finite prediction exists
    sd: dict[str, float] = field(default_factory=dict)
    err: dict[str, float] = field(default_factory=dict)
    correlation: np.ndarray | None = None
    delta_tilde: np.ndarray | None = None
    D: float = math.nan                                  # mean log det of the relative covariance
    A: float = math.nan                                  # trace of the mean relative covariance
    note: str = ""

    def value(self, criterion: str) -> float:
        """The criterion's value (smaller is better); NaN when it does not apply."""
        if not self.identifiable:
            return math.nan
        if criterion in ("D", "A"):
            return getattr(self, criterion)
        kind, _, name = criterion.partition("_")
        table = self.sd if kind == "sd" else self.err
        return table.get(name, math.nan)


def free_names(candidate: Candidate, free: Sequence[str], relaxation: bool) -> tuple[list[str], str]:
    """The parameters identified on this candidate, and why some were dropped."""
    names = [k for k in free if k not in candidate.window_spec.fixed]
    notes = []
    if not relaxation:
        dropped = [k for k in names if k in RELAXATION_PARAMETERS]
        if dropped:
            names = [k for k in names if k not in dropped]
            notes.append(f"{', '.join(dropped)} fixed (no hold in the window)")
    return names, "; ".join(notes)


def _sandwich(delta: np.ndarray, axis, X: np.ndarray, noise: NoiseDraw, draws: Draws) -> np.ndarray:
    """Σ_k w_k Δ (Xᵀ C⁻¹ C_k C⁻¹ X) Δ: the covariance of the estimate under the sampled kernel's C
    when the error follows the run's kernels C_k (their weights), as `fit` and `sample` widen it
    (inference/discrepancy/gls.py)."""
    Z = gp.solve(axis.values, axis.sort(X), noise.sigma0, noise.amplitude, noise.length, draws.kernel,
                 axis.origin)
    total = sum(m.weight * gp.sandwich(axis.values, Z, delta, m.noise.sigma0, m.noise.amplitude,
                                       m.noise.length, m.kernel, axis.origin) for m in draws.widen)
    return 0.5 * (total + total.T)


def _sensitivities(model: DNLR, theta: dict[str, float], names: list[str], mask: np.ndarray,
                   relaxation: bool) -> np.ndarray:
    """X (eq. 22) on the window: exact from the basis, or for the shifted model by its central
    differences (``DNLR.jacobian``, in ln of the LOG_COORDINATES)."""
    if model.is_shifted:
        J = model.jacobian(theta, names)[mask]
        scale = np.array([theta[k] if k in LOG_COORDINATES else 1.0 for k in names])
        return J / scale[None, :]
    basis = model.basis(theta["tau_max"], theta.get("tau_max_R") if relaxation else None, grad=True,
                        alpha=theta.get("alpha", UNIVERSAL_EXPONENT))
    return sensitivity_matrix(basis, theta, names, mask)


def predict(candidate: Candidate, draws: Draws, free: Sequence[str], modes: int, decades: float,
            max_duration: float | None = None, max_points: int | None = None,
            shift: Shift = NO_SHIFT) -> Prediction:
    """The predicted sd, Err, ρ, Δ̃, D and A of ``candidate`` averaged over ``draws`` (``shift``:
    a stress shift of the model; a planned test has no temperature, so no temperature shift)."""
    if shift.temperature != "none":
        raise ConfigError("model.shift.temperature: design plans tests without a temperature, so a "
                          "temperature shift cannot be predicted; leave it out (a stress shift can)")
    pred = Prediction(candidate, total_points=candidate.total_points)
    pred.feasible = ((max_duration is None or candidate.duration <= max_duration * (1 + 1e-12))
                     and (max_points is None or candidate.total_points <= max_points))
    prot = planned_protocol(candidate, draws.params[0])
    mask = window_mask(candidate.window_spec, prot.time, prot.strain)
    if not mask.any():
        pred.note = "the window holds no sample of this test"
        return pred
    end = int(np.flatnonzero(mask)[-1]) + 1
    switch = prot.relaxation_start
    relaxation = switch is not None and prot.time[end - 1] > switch
    model = DNLR(prot.time[:end], prot.strain[:end], modes, decades, switch if relaxation else None,
                 shift)
    mask = mask[:end]
    names, pred.note = free_names(candidate, free, relaxation)
    pred.names, pred.n_points = names, int(mask.sum())
    if pred.n_points <= len(names):
        few = f"{pred.n_points} samples for {len(names)} parameters"
        pred.note = "; ".join(filter(None, [pred.note, few]))
        return pred
    axis = None
    if not draws.white:
        origin = None
        if draws.start == "pinned":
            origin = float(prot.time[0] if draws.axis == "time" else prot.strain[0])
        axis = make_axis(draws.axis, prot.time[:end][mask], prot.strain[:end][mask], origin)
    p = len(names)
    cov_sum, rel_sum, logdet = np.zeros((p, p)), np.zeros((p, p)), []
    for theta, noise in zip(draws.params, draws.noise, strict=True):
        X = _sensitivities(model, theta, names, mask, relaxation)
        values = np.array([theta[k] for k in names])
        try:
            if noise.amplitude > 0:
                Xw, _ = gp.whiten(axis.values, axis.sort(X), noise.sigma0, noise.amplitude, noise.length,
                                  draws.kernel, axis.origin)
                delta = covariance(Xw, 1.0, values)            # eq. 32 with K: (XᵀK⁻¹X)⁻¹
                if draws.widen:
                    delta = _sandwich(delta, axis, X, noise, draws)
            else:
                delta = covariance(X, noise.sigma0, values)    # eq. 32
        except np.linalg.LinAlgError as err:
            pred.note = "; ".join(filter(None, [pred.note, f"not identifiable ({err})"]))
            return pred
        rel = delta / np.outer(values, values)
        cov_sum += delta
        rel_sum += rel
        sign, ld = np.linalg.slogdet(rel)
        logdet.append(ld if sign > 0 else math.inf)
    n = draws.n
    cov, rel = cov_sum / n, rel_sum / n
    sd, err = np.sqrt(np.diag(cov)), np.sqrt(np.diag(rel))
    corr = correlation(rel)                               # eq. 34 (of the mean relative covariance)
    dt = corr.copy()
    np.fill_diagonal(dt, err)                             # eq. 35
    pred.sd = dict(zip(names, map(float, sd), strict=True))
    pred.err = dict(zip(names, map(float, err), strict=True))
    pred.correlation, pred.delta_tilde = corr, dt
    pred.D = float(np.mean(logdet))
    pred.A = float(np.trace(rel))
    pred.identifiable = bool(np.all(np.isfinite(sd)) and math.isfinite(pred.D))
    return pred
