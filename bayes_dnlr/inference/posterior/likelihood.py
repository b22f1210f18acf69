"""The log-likelihood of one test, vectorised over emcee walkers: log L(θ) over the n samples of
the identification window, with r = y - σ_model(θ):

- white (``noise.discrepancy: none``): log L = -½ Σ r_i² / σ0² - n ln σ0 - (n/2) ln 2π, the paper's
  least-squares criterion (eq. 27 is -2 σ0² log L up to constants);
- with the model discrepancy (the default): r = δ + ε, δ a Gaussian process with amplitude and
  correlation length on the time or strain axis, log L = log N(r | 0, k(x, x) + σ0² I), exact and
  O(n) (inference/discrepancy/gp.py), all walkers of a call at once; with orthogonality columns
  (``target: l2``, inference/discrepancy/orthogonal.py) δ is conditioned on having no component along the
  sensitivities, log L = log N(r | 0, K - K V M⁻¹ Vᵀ K + σ0² I), O(n p²). The hyperparameters
  ``disc_amplitude`` and ``disc_length`` are sampled with the others, or fixed.

All walkers of a call are evaluated by one compiled call, in parallel over walkers
(inference/posterior/fused.py: the stress by the exponential integrator, the residual and the
likelihood, white or discrepancy, without Python per walker); ``fused=False`` keeps the reference
path, one basis integration (``DNLR.basis``) and a (n, 3) matrix-vector product per walker in
Python. A model failure (non-finite stress) gives ``-inf``: the function never returns NaN and never
raises for a bad point. The run's log-posterior sums these over its tests (density.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from bayes_dnlr.config import Config, ParameterSpec
from bayes_dnlr.data import TestData
from bayes_dnlr.inference.discrepancy.axis import Axis, test_axis
from bayes_dnlr.inference.discrepancy.hyper import AMPLITUDE, LENGTH, gp, is_white
from bayes_dnlr.inference.posterior import fused as fused_kernel
from bayes_dnlr.inference.test_model import model_of
from bayes_dnlr.model import DNLR
from bayes_dnlr.model.shift import DRIVING_CODE
from bayes_dnlr.vocabulary import (
    DISCREPANCY_PARAMETERS,
    SPECTRUM_EXPONENT,
    UNIVERSAL_EXPONENT,
)

_LOG_2PI = math.log(2.0 * math.pi)


def build_model(cfg: Config, test: TestData) -> DNLR:
    """The DNLR model on the test's strain history, from the first sample to the window's end."""
    return model_of(cfg, test)


def window_rows(test: TestData) -> slice | np.ndarray:
    """The compared samples as a slice when the window is contiguous (cheaper), else indices."""
    rows = np.flatnonzero(test.window[: test.model_end])
    if rows.size and rows[-1] - rows[0] + 1 == rows.size:
        return slice(int(rows[0]), int(rows[-1]) + 1)
    return rows


class TestLikelihood:
    """log L (k,) of one test at physical parameters theta (k, ndim) over the test's own ``names``.

    ``sigma0``: the fixed noise sd (MPa), or None when ``sigma0`` is one of the sampled parameters.
    ``fused``: evaluate the likelihood by one compiled parallel call per batch of walkers
    (default), or walker by walker in Python (the reference, ``log_likelihood_reference``).
    """

    def __init__(self, model: DNLR, observed: np.ndarray, rows: slice | np.ndarray,
                 names: Sequence[str], fixed: Mapping[str, float], sigma0: float | None,
                 discrepancy: Discrepancy | None = None, fused: bool = True) -> None:
        self.model = model
        self.rows = rows
        self.y = np.ascontiguousarray(observed, dtype=float)
        self.n = int(self.y.size)
        self.names = list(names)
        self.ndim = len(self.names)
        model_names = model.parameter_names()
        noise_names = ("sigma0", *DISCREPANCY_PARAMETERS)
        unknown = [k for k in self.names
                   if k not in model_names and k not in noise_names and k != SPECTRUM_EXPONENT]
        if unknown:
            raise ValueError(f"parameters {unknown} are not parameters of this model {model_names}")
        missing = [k for k in model_names if k not in self.names and k not in fixed]
        if missing:
            raise ValueError(f"model parameters {missing} are neither sampled nor fixed")
        if ("sigma0" in self.names) == (sigma0 is not None):
            raise ValueError("give sigma0 (fixed) or sample it, not both and not neither")
        if sigma0 is not None and not (math.isfinite(sigma0) and sigma0 > 0):
            raise ValueError(f"sigma0 must be a positive number, got {sigma0}")
        self.sigma0 = sigma0
        self.discrepancy = discrepancy
        disc_names = DISCREPANCY_PARAMETERS if discrepancy is not None else ()
        for k in disc_names:
            if k not in self.names and k not in discrepancy.fixed:  # type: ignore[union-attr]
                raise ValueError(f"{k} is neither sampled nor fixed")
        # where each model quantity comes from: a column of theta, or a constant
        self._source = {}
        for k in (*model_names, SPECTRUM_EXPONENT, "sigma0", *disc_names):
            if k in self.names:
                self._source[k] = self.names.index(k)
            elif k == SPECTRUM_EXPONENT:       # optional: eq. 12's ½ unless fixed otherwise
                self._source[k] = float(fixed.get(k, UNIVERSAL_EXPONENT))
            elif k == "sigma0":
                self._source[k] = float(sigma0)  # type: ignore[arg-type]
            elif k in disc_names:
                self._source[k] = float(discrepancy.fixed[k])  # type: ignore[union-attr]
            else:
                self._source[k] = float(fixed[k])
        self.has_relaxation = model.has_relaxation
        self.fused = fused
        self._prepare_fused()

    def _prepare_fused(self) -> None:
        """The compiled call's data: observed values and their model samples in the order of the
        discrepancy's axis (window order when white), the axis, the kernel and its start."""
        idx = np.arange(self.model.n_points, dtype=np.int64)[self.rows]
        y = self.y
        d = self.discrepancy
        if d is not None and d.axis.order is not None:
            idx, y = idx[d.axis.order], y[d.axis.order]
        self._idx = np.ascontiguousarray(idx, dtype=np.int64)
        self._y_axis = np.ascontiguousarray(y, dtype=float)
        if d is None:
            self._x, self._kind, self._gap = np.zeros(0), 0, math.inf
            self._V = np.zeros((0, 0))
        else:
            self._x = np.ascontiguousarray(d.axis.values, dtype=float)
            self._kind = gp.kernel_code(d.kernel)
            self._gap = gp._gap(self._x, d.axis.origin)
            self._V = gp._columns(d.columns, self._x.size)

    def _col(self, theta: np.ndarray, name: str) -> np.ndarray:
        src = self._source[name]
        return theta[:, src] if isinstance(src, int) else np.full(theta.shape[0], src)

    def predict(self, theta: np.ndarray) -> np.ndarray:
        """Model stress on the window, (k, n), for physical parameters theta (k, ndim)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        if self.model.is_shifted:
            return self._shifted_stress(theta)
        out = np.empty((theta.shape[0], self.n))
        for i, (e, g, t, s, tr, a) in enumerate(zip(*self._linear_and_times(theta), strict=True)):
            out[i] = self._stress(e, g, t, s, tr, a)
        return out

    def _linear_and_times(self, theta: np.ndarray) -> tuple[np.ndarray, ...]:
        e, g, t = (self._col(theta, k) for k in ("E", "G", "tau_max"))
        if self.has_relaxation:
            s, tr = self._col(theta, "sigma_inf"), self._col(theta, "tau_max_R")
        else:
            s = tr = np.zeros(theta.shape[0])
        return e, g, t, s, tr, self._col(theta, SPECTRUM_EXPONENT)

    def _shifted_stress(self, theta: np.ndarray) -> np.ndarray:
        """The shifted model's stress on the window (k, n) (no basis: model/dnlr.py), NaN rows
        where it is not defined."""
        used = [*self.model.parameter_names(), SPECTRUM_EXPONENT]
        k = theta.shape[0]
        sets, ln_at = self.model.kernel_rows(
            lambda name: self._col(theta, name) if name in used else None, k)
        out = np.empty((k, self.model.n_points))
        with np.errstate(all="ignore"):
            self.model.stress_rows_into(sets, ln_at, out)
        return out[:, self.rows]

    def _stress(self, e: float, g: float, t: float, s: float, tr: float, a: float) -> np.ndarray:
        b = self.model.basis(t, tr if self.has_relaxation else None, alpha=a).values[self.rows]
        if self.has_relaxation:
            return b @ np.array([e, g, s])
        return b[:, :2] @ np.array([e, g])

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """y - model (k, n) for physical parameters theta (k, ndim); rows of non-finite models hold
        NaN."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        if self.model.is_shifted:
            return self.y[None, :] - self._shifted_stress(theta)
        out = np.empty((theta.shape[0], self.n))
        cols = self._linear_and_times(theta)
        for i in range(theta.shape[0]):
            try:
                with np.errstate(all="ignore"):     # overflow -> inf -> -inf later, silently
                    out[i] = self.y - self._stress(*(c[i] for c in cols))
            except (ValueError, ZeroDivisionError, FloatingPointError):
                out[i] = np.nan
        return out

    def log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        """log-likelihood (k,) of physical parameters theta (k, ndim); -inf on failure."""
        if not self.fused:
            return self.log_likelihood_reference(theta)
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        k = theta.shape[0]
        used = [*self.model.parameter_names(), SPECTRUM_EXPONENT]    # alpha: ½ unless free
        sets, ln_at = self.model.kernel_rows(
            lambda name: self._col(theta, name) if name in used else None, k)
        sig = np.ascontiguousarray(self._col(theta, "sigma0"), dtype=float)
        if self.discrepancy is not None:
            amp = np.ascontiguousarray(self._col(theta, AMPLITUDE), dtype=float)
            length = np.ascontiguousarray(self._col(theta, LENGTH), dtype=float)
        else:
            amp = length = sig
        out = np.empty(k)
        shifted = None if ln_at is None else (ln_at, DRIVING_CODE[self.model.shift.driving])
        fused_kernel.evaluate(sets, sig, amp, length, self.model.kernel_args, self._y_axis,
                              self._idx, self._x, self._kind, self._gap, self._V,
                              self.discrepancy is not None, out, shifted)
        return out

    def log_likelihood_reference(self, theta: np.ndarray) -> np.ndarray:
        """``log_likelihood`` walker by walker in Python through the basis (the reference the
        compiled call is tested against; also the baseline of benchmarks/sample_command.py)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        sig = self._col(theta, "sigma0")
        if self.discrepancy is not None:
            return self._log_likelihood_gp(theta, sig)
        out = np.full(theta.shape[0], -np.inf)
        if self.model.is_shifted:
            R = self.residuals(theta)
            for i in range(theta.shape[0]):
                rss = float(R[i] @ R[i])
                if sig[i] > 0 and np.isfinite(sig[i]) and math.isfinite(rss):
                    out[i] = -0.5 * rss / sig[i] ** 2 - self.n * (math.log(sig[i]) + 0.5 * _LOG_2PI)
            return out
        cols = self._linear_and_times(theta)
        for i in range(theta.shape[0]):
            if not (sig[i] > 0 and np.isfinite(sig[i])):
                continue
            try:
                with np.errstate(all="ignore"):     # overflow -> inf -> -inf below, silently
                    r = self.y - self._stress(*(c[i] for c in cols))
                    rss = float(r @ r)
            except (ValueError, ZeroDivisionError, FloatingPointError):
                continue
            if math.isfinite(rss):
                out[i] = -0.5 * rss / sig[i] ** 2 - self.n * (math.log(sig[i]) + 0.5 * _LOG_2PI)
        return out

    def _log_likelihood_gp(self, theta: np.ndarray, sig: np.ndarray) -> np.ndarray:
        d = self.discrepancy
        assert d is not None
        R = self.residuals(theta)
        if d.axis.order is not None:
            R = R[:, d.axis.order]
        bad = ~np.all(np.isfinite(R), axis=1)
        R[bad] = 0.0
        out = gp.log_likelihood_batch(d.axis.values, R, sig, self._col(theta, AMPLITUDE),
                                      self._col(theta, LENGTH), d.kernel, d.axis.origin, d.columns)
        out[bad] = -np.inf
        return out


@dataclass(frozen=True)
class Discrepancy:
    """The discrepancy term of a likelihood: kernel, axis, and the hyperparameters held fixed."""

    kernel: str
    axis: Axis
    fixed: dict[str, float] = field(default_factory=dict)   # disc_amplitude / disc_length values
    columns: np.ndarray | None = None   # (n, p) in axis order: the orthogonal discrepancy's V


def build_likelihood(cfg: Config, test: TestData, sigma0: float | None, names: Sequence[str],
                     discrepancy_priors: Mapping[str, ParameterSpec] | None = None,
                     kernel: str | None = None, columns: np.ndarray | None = None) -> TestLikelihood:
    """The likelihood of a (single-test) config and its test data over the sampled ``names``;
    sigma0 None when it is sampled.

    ``discrepancy_priors``: the resolved priors (or fixed values) of disc_amplitude and
    disc_length (fit.json's discrepancy block); needed when the config has a discrepancy.
    ``kernel``: the kernel fit.json records (needed with ``kernel: auto``; else the config's).
    ``columns`` (n, p), in the order of the discrepancy's axis: the orthogonal discrepancy, δ
    conditioned on columnsᵀ δ = 0 (inference/discrepancy/orthogonal.py); None: the plain discrepancy.
    """
    model = build_model(cfg, test)
    rows = window_rows(test)
    observed = test.stress[: test.model_end][rows]
    disc = None
    if cfg.noise.has_discrepancy:
        if discrepancy_priors is None:
            raise ValueError("a likelihood with a discrepancy needs its resolved priors (run fit)")
    if cfg.noise.has_discrepancy and not is_white(discrepancy_priors):
        axis = test_axis(cfg.noise.discrepancy, test, rows)
        kernel = kernel or cfg.noise.discrepancy.kernel
        if kernel == "auto":
            raise ValueError("kernel: auto needs the kernel that fit chose (fit.json's discrepancy block)")
        disc = Discrepancy(kernel, axis,
                           {k: float(v.value) for k, v in discrepancy_priors.items() if v.fixed},
                           columns)
    return TestLikelihood(model, observed, rows, names, cfg.fixed_values, sigma0, disc)
