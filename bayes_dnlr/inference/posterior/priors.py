"""Priors of the sampled parameters, from the config's ``parameters:`` (and ``noise.sigma0`` prior).

Kinds: uniform (low, high), log-uniform (low, high), normal (mean, sd), log-normal (median, sd_log),
half-normal (scale); ``low``/``high`` truncate any of them. Densities are normalised on their
(truncated) support.

Positive scale parameters with a log-uniform or log-normal prior are *sampled* in log space,
z = ln x. The density of z carries the Jacobian |dx/dz| = x, so that the distribution of x is
exactly the one the config states (a log-uniform prior becomes flat in z). Everything the user
sees (chains, summaries) is in physical units; ``to_physical``/``from_physical`` convert.

When the spectrum's exponent alpha is sampled, E and alpha lie on a thin curved ridge (E holds
the weight of the modes too fast for the sampling step, which alpha sets): E is then sampled in
log space and alpha in the *spectral* coordinate z = -10^(-alpha) (Jacobian ln 10 · 10^(-alpha)),
in which ln E is close to linear along the ridge, so the ensemble moves follow it
(docs/theory.md, "The spectrum's exponent").

Outside the support every log-density is ``-inf``: never NaN, never an exception.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from bayes_dnlr.config import Config, ConfigError, ParameterSpec, SampledNoise
from bayes_dnlr.vocabulary import DISCREPANCY_PARAMETERS

LOG_SPACE_KINDS = ("log-uniform", "log-normal")
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
_LN10 = math.log(10.0)
_LOG_LN10 = math.log(_LN10)


def log_ndtr(x: float) -> float:
    """log Φ(x), the log of the standard normal cdf, to a few ulp for every x (scipy.special.log_ndtr
    without importing scipy: 0.2-0.4 s of a ``sample``). Right of 0, log1p of the upper tail; left,
    the log of erfc, which is relative-accurate down to x = -37; beyond, the asymptotic series
    log Φ(x) = -x²/2 - ln(-x) - ½ ln 2π + ln(1 - 1/x² + 3/x⁴ - 15/x⁶ + 105/x⁸)."""
    x = float(x)
    if math.isnan(x):
        return math.nan
    if x > 0.0:
        return math.log1p(-0.5 * math.erfc(x / math.sqrt(2.0)))
    if x > -37.0:
        return math.log(0.5 * math.erfc(-x / math.sqrt(2.0)))
    if x == -math.inf:
        return -math.inf
    z = 1.0 / (x * x)
    return -0.5 * x * x - math.log(-x) - _LOG_SQRT_2PI + math.log1p(z * (-1.0 + z * (3.0 + z * (
        -15.0 + 105.0 * z))))


def _log_diff_ndtr(a: float, b: float) -> float:
    """log(Φ(b) - Φ(a)) for a < b, accurate in both tails."""
    if a > 0:  # mirror into the left tail where log_ndtr is accurate
        a, b = -b, -a
    la, lb = float(log_ndtr(a)), float(log_ndtr(b))
    if la == -math.inf:
        return lb
    return lb + math.log1p(-math.exp(la - lb))


@dataclass(frozen=True)
class Prior:
    """One parameter's prior. ``low``/``high`` are the support in physical units."""

    name: str
    kind: str
    low: float
    high: float
    loc: float = 0.0        # normal: mean; log-normal: ln(median); half-normal: 0
    scale: float = 1.0      # normal: sd; log-normal: sd_log; half-normal: scale
    log_space: bool = False
    _log_norm: float = field(default=0.0, repr=False)  # log of the normalising constant
    spectral: bool = False  # sampled in z = -10^(-x) (the spectrum's exponent, module docstring)

    def renamed(self, name: str) -> Prior:
        """The same prior under another name (a test's parameter in the run's vector)."""
        return replace(self, name=name)

    @classmethod
    def from_spec(cls, name: str, spec: ParameterSpec | SampledNoise, key: str | None = None,
                  log_space: bool | None = None, spectral: bool = False) -> Prior:
        """Build from a config entry (a free parameter, or the sampled noise sigma0).

        ``key`` names the entry in error messages (default ``parameters.<name>``). ``log_space``
        forces sampling in ln x (for a positive scale such as the discrepancy amplitude, whose
        posterior on clean data piles up near 0); by default only log-uniform and log-normal are.
        """
        key = key or f"parameters.{name}"
        kind = spec.prior
        if kind is None:
            raise ConfigError(f"{key}: is fixed (value), it has no prior")
        low = -math.inf if spec.low is None else float(spec.low)
        high = math.inf if spec.high is None else float(spec.high)
        if kind in ("log-uniform", "log-normal", "half-normal"):
            low = max(low, 0.0)
        loc, scale = 0.0, 1.0
        if kind == "normal":
            loc, scale = float(spec.mean), float(spec.sd)  # type: ignore[union-attr,arg-type]
        elif kind == "log-normal":
            loc, scale = math.log(spec.median), float(spec.sd_log)  # type: ignore[union-attr,arg-type]
        elif kind == "half-normal":
            scale = float(spec.scale)  # type: ignore[arg-type]
        if not low < high:
            raise ConfigError(f"{key}: empty support [{low}, {high}]")
        if kind in ("uniform", "log-uniform") and not (math.isfinite(low) and math.isfinite(high)):
            raise ConfigError(f"{key}: prior '{kind}' needs finite low and high")
        if kind == "log-uniform" and low <= 0:
            raise ConfigError(f"{key}: prior 'log-uniform' needs low > 0")
        # normalising constants on the truncated support
        if kind == "uniform":
            log_norm = math.log(high - low)
        elif kind == "log-uniform":
            log_norm = math.log(math.log(high / low))
        elif kind == "normal":
            log_norm = _log_diff_ndtr((low - loc) / scale, (high - loc) / scale)
        elif kind == "log-normal":
            zl = -math.inf if low <= 0 else (math.log(low) - loc) / scale
            zh = math.inf if math.isinf(high) else (math.log(high) - loc) / scale
            log_norm = _log_diff_ndtr(zl, zh)
        elif kind == "half-normal":
            log_norm = _log_diff_ndtr(low / scale, high / scale)
        else:  # pragma: no cover - config/schema.py restricts the kinds
            raise ConfigError(f"{key}: unknown prior '{kind}'")
        in_log = kind in LOG_SPACE_KINDS if log_space is None else bool(log_space and low >= 0)
        return cls(name, kind, low, high, loc, scale, in_log and not spectral, log_norm, spectral)

    # ---- transforms between physical x and the sampling coordinate z
    def to_physical(self, z: np.ndarray) -> np.ndarray:
        z = np.asarray(z, dtype=float)
        if self.spectral:
            with np.errstate(divide="ignore", invalid="ignore"):
                return -np.log10(-z)
        if not self.log_space:
            return z
        with np.errstate(over="ignore"):
            return np.exp(z)

    def from_physical(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if self.spectral:
            with np.errstate(over="ignore"):
                return -(10.0 ** -x)
        if not self.log_space:
            return x
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.log(x)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """dz/dx at x."""
        x = np.asarray(x, dtype=float)
        if self.spectral:
            return _LN10 * 10.0 ** -x
        return 1.0 / x if self.log_space else np.ones_like(x)

    # ---- densities
    def logpdf(self, x: np.ndarray) -> np.ndarray:
        """log density of x (physical units); -inf outside the support and for NaN."""
        x = np.asarray(x, dtype=float)
        inside = (x >= self.low) & (x <= self.high)
        if self.kind in ("log-uniform", "log-normal"):
            inside &= x > 0
        xs = np.where(inside, x, 1.0 if self.log_space else self.loc)
        if self.kind == "uniform":
            lp = np.full_like(xs, -self._log_norm)
        elif self.kind == "log-uniform":
            lp = -np.log(xs) - self._log_norm
        elif self.kind in ("normal", "half-normal"):
            u = (xs - self.loc) / self.scale
            with np.errstate(over="ignore"):   # far in the tail: u² -> inf, density -> -inf
                lp = -0.5 * u * u - _LOG_SQRT_2PI - math.log(self.scale) - self._log_norm
        else:  # log-normal
            lx = np.log(xs)
            u = (lx - self.loc) / self.scale
            with np.errstate(over="ignore"):
                lp = -0.5 * u * u - _LOG_SQRT_2PI - math.log(self.scale) - lx - self._log_norm
        return np.where(inside, lp, -np.inf)

    def logpdf_sampling(self, z: np.ndarray) -> np.ndarray:
        """log density of the sampling coordinate z (the Jacobian x = e^z included)."""
        z = np.asarray(z, dtype=float)
        x = self.to_physical(z)
        lp = self.logpdf(x)
        if self.log_space:
            ok = np.isfinite(lp)
            lp = np.where(ok, lp + np.where(ok, z, 0.0), -np.inf)
        elif self.spectral:    # |dx/dz| = 1/(ln 10 · (-z))
            ok = np.isfinite(lp) & (z < 0)
            with np.errstate(divide="ignore", invalid="ignore"):
                lp = np.where(ok, lp - _LOG_LN10 - np.log(np.where(ok, -z, 1.0)), -np.inf)
        return lp

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n independent draws in physical units (inverse-cdf sampling)."""
        u = rng.uniform(size=n)
        if self.kind == "uniform":
            return self.low + u * (self.high - self.low)
        if self.kind == "log-uniform":
            return self.low * (self.high / self.low) ** u
        # truncated normal in the right variable: map u into [Φ(a), Φ(b)]
        if self.kind == "log-normal":
            a = -math.inf if self.low <= 0 else (math.log(self.low) - self.loc) / self.scale
            b = math.inf if math.isinf(self.high) else (math.log(self.high) - self.loc) / self.scale
        else:
            a, b = (self.low - self.loc) / self.scale, (self.high - self.loc) / self.scale
        from scipy.special import ndtri

        pa, pb = _ndtr(a), _ndtr(b)
        w = ndtri(pa + u * (pb - pa))
        x = self.loc + self.scale * w
        x = np.exp(x) if self.kind == "log-normal" else x
        return np.clip(x, self.low, self.high)


def _ndtr(v: float) -> float:
    return 0.0 if v == -math.inf else 1.0 if v == math.inf else math.exp(float(log_ndtr(v)))


@dataclass(frozen=True)
class PriorSet:
    """The joint (independent) prior of the sampled parameters, in their order."""

    priors: tuple[Prior, ...]

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.priors]

    @property
    def ndim(self) -> int:
        return len(self.priors)

    @property
    def log_space(self) -> np.ndarray:
        return np.array([p.log_space for p in self.priors])

    def to_physical(self, z: np.ndarray) -> np.ndarray:
        """(..., ndim) sampling coordinates -> physical values."""
        z = np.asarray(z, dtype=float)
        out = z.copy()
        with np.errstate(over="ignore"):
            out[..., self.log_space] = np.exp(z[..., self.log_space])
        for j, p in enumerate(self.priors):
            if p.spectral:
                out[..., j] = p.to_physical(z[..., j])
        return out

    def from_physical(self, x: np.ndarray) -> np.ndarray:
        """(..., ndim) physical values -> sampling coordinates."""
        x = np.asarray(x, dtype=float)
        out = x.copy()
        with np.errstate(divide="ignore", invalid="ignore"):
            out[..., self.log_space] = np.log(x[..., self.log_space])
        for j, p in enumerate(self.priors):
            if p.spectral:
                out[..., j] = p.from_physical(x[..., j])
        return out

    def jacobian(self, x: Sequence[float]) -> np.ndarray:
        """dz/dx at x (diagonal), to carry a physical covariance into sampling coordinates."""
        x = np.asarray(x, dtype=float)
        return np.array([p.jacobian(v) for p, v in zip(self.priors, x, strict=True)], dtype=float)

    def log_prior(self, z: np.ndarray) -> np.ndarray:
        """Joint log density of sampling coordinates z (k, ndim) -> (k,); -inf outside."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        lp = np.zeros(z.shape[0])
        for j, p in enumerate(self.priors):
            lp += p.logpdf_sampling(z[:, j])
        lp[~np.isfinite(lp)] = -np.inf
        return lp

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n joint draws (n, ndim) in physical units."""
        return np.column_stack([p.sample(rng, n) for p in self.priors])


def sampled_names(cfg: Config, discrepancy_priors: Mapping[str, ParameterSpec] | None = None
                  ) -> list[str]:
    """The sampled parameters: the free model parameters in canonical order, then sigma0 if sampled,
    then the discrepancy hyperparameters that are not fixed: by the resolved priors when given
    (fit.json; an amplitude fixed at 0 means the white likelihood, no hyperparameter), else by the
    config alone (the most there can be)."""
    names = list(cfg.free_parameters)
    if isinstance(cfg.noise.sigma0, SampledNoise):
        names.append("sigma0")
    if not cfg.noise.has_discrepancy:
        return names
    if discrepancy_priors is not None:
        amp = discrepancy_priors["disc_amplitude"]
        if amp.fixed and amp.value == 0.0:
            return names
        return names + [k for k in DISCREPANCY_PARAMETERS if not discrepancy_priors[k].fixed]
    d = cfg.noise.discrepancy
    return names + [k for k, spec in zip(DISCREPANCY_PARAMETERS, (d.amplitude, d.length), strict=True)
                    if spec is None or not spec.fixed]


def build_priors(cfg: Config, discrepancy_priors: Mapping[str, ParameterSpec] | None = None
                 ) -> PriorSet:
    """The prior of every sampled parameter (free model parameters, sigma0 when sampled, the
    discrepancy hyperparameters when their resolved priors are given)."""
    spectral = "alpha" in cfg.free_parameters      # the E-alpha ridge (module docstring)
    priors = [Prior.from_spec(k, cfg.parameters[k], spectral=spectral and k == "alpha",
                              log_space=True if spectral and k == "E" else None)
              for k in cfg.free_parameters]
    if isinstance(cfg.noise.sigma0, SampledNoise):
        priors.append(Prior.from_spec("sigma0", cfg.noise.sigma0, key="noise.sigma0"))
    if cfg.noise.has_discrepancy and discrepancy_priors is not None:
        for k in DISCREPANCY_PARAMETERS:
            spec = discrepancy_priors[k]
            if k in sampled_names(cfg, discrepancy_priors):
                key = f"noise.discrepancy.{k.removeprefix('disc_')}"
                priors.append(Prior.from_spec(k, spec, key=key, log_space=True))
    return PriorSet(tuple(priors))
