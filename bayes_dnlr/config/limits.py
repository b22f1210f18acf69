"""Range checks of a validated config that need more than one key: magnitudes a computation can
hold, signs the model needs, and the memory the chain will take. Run by ``parse_config`` before
any work is done, so that a number the model cannot use is a one-line error naming its key, not a
traceback after the fit (docs/config.md, "Validation rules").

Limits (a number beyond them overflows the model or the least squares in double precision, and is
no measurement of a polymer):

- moduli and stresses (E, G, sigma_inf, sigma0, the discrepancy amplitude): |x| <= 1e7 MPa
  (10 TPa, ten times diamond's modulus);
- times (tau_max, tau_max_R, a correlation length): <= 1e12 s (about 32 000 years);
- the spectrum's exponent alpha: |x| <= 10 (p_j ∝ tau_j^10 over 6 decades already puts all the
  weight on the slowest modes);
- the shift's (model/shift.py): Ea <= 1e5 kJ/mol, C1 <= 1e4, C2 <= 1e5 K (a_T would overflow at
  any temperature step a test can have), sigma_s like a stress;
- tau_max, tau_max_R (eq. 12-14 take their logarithm) and sigma_s (a_σ = x/sinh x, x = |σ|/sigma_s):
  a fixed value > 0 and a prior that does not reach below 0 (``low >= 0``; the posterior is -inf
  at 0), E and C2 a fixed value > 0;
- the chain (walkers x max_steps x sampled parameters, float64, held in memory while sampling and
  written to chains.h5) must fit in half of this machine's memory.
"""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING

from bayes_dnlr.config.noise_section import NoiseConfig, SampledNoise
from bayes_dnlr.vocabulary import UNITS

if TYPE_CHECKING:
    from bayes_dnlr.config.parameter_section import ParameterSpec
    from bayes_dnlr.config.schema import Config

MAX_STRESS = 1.0e7      # MPa
MAX_TIME = 1.0e12       # s
MAX_EXPONENT = 10.0                 # the spectrum's exponent alpha (dimensionless)
LIMITS = {"MPa": MAX_STRESS, "s": MAX_TIME, "-": MAX_EXPONENT, "kJ/mol": 1.0e5, "K": 1.0e5}
NAME_LIMITS = {"C1": 1.0e4}         # dimensionless, but not an exponent of the spectrum
POSITIVE = ("tau_max", "tau_max_R", "sigma_s")   # the spectrum's logarithm (eq. 12), x/sinh x
POSITIVE_FIXED = ("E", "tau_max", "tau_max_R", "sigma_s", "C2")
SPEC_NUMBERS = ("value", "low", "high", "mean", "sd", "median", "scale")
MEMORY_SHARE = 0.5      # of the physical memory the chain may take
# float64, and the growing buffer doubles (inference/mcmc/ensemble.py, _Growing)
CHAIN_BYTES_PER_VALUE = 8 * 2


def _magnitude(spec, key: str, unit: str, limit: float | None = None) -> str | None:
    limit = LIMITS[unit] if limit is None else limit
    for k in SPEC_NUMBERS:
        v = getattr(spec, k, None)
        if v is not None and abs(v) > limit:
            shown = "" if unit == "-" else f" {unit}"
            return (f"{key}.{k}: {v:g} is beyond what the model can compute with; expected "
                    f"|{k}| <= {limit:g}{shown}")
    return None


def _parameter(name: str, spec: ParameterSpec) -> str | None:
    key = f"parameters.{name}"
    bad = _magnitude(spec, key, UNITS[name], NAME_LIMITS.get(name))
    if bad:
        return bad
    if spec.fixed:
        if name in POSITIVE_FIXED and not spec.value > 0:
            return f"{key}.value: must be > 0 {UNITS[name]}, got {spec.value:g}"
        return None
    if name in POSITIVE and not spec.bounds()[0] >= 0:
        why = ("a_σ = x/sinh x with x = |σ|/sigma_s" if name == "sigma_s"
               else "the spectrum takes its logarithm, eq. 12")
        return (f"{key}: the prior reaches {spec.bounds()[0]:g} {UNITS[name]}, but {name} must be > 0 "
                f"({why}): give low >= 0 (log-uniform with low > 0 is the usual choice)")
    return None


def _noise(noise: NoiseConfig, key: str) -> str | None:
    s0 = noise.sigma0
    if isinstance(s0, float | int) and not isinstance(s0, bool) and s0 > MAX_STRESS:
        return f"{key}.sigma0: {s0:g} is beyond any stress noise; expected <= {MAX_STRESS:g} MPa"
    if isinstance(s0, SampledNoise):
        bad = _magnitude(s0, f"{key}.sigma0", "MPa")
        if bad:
            return bad
        if s0.low is not None and (s0.low < 0 or (s0.prior == "log-uniform" and s0.low == 0)):
            need = "> 0" if s0.prior == "log-uniform" else ">= 0"
            return f"{key}.sigma0.low: a noise sd is {need} MPa, got {s0.low:g}"
    if noise.has_discrepancy:
        d = noise.discrepancy
        for part, unit in (("amplitude", "MPa"), ("length", "s")):
            spec = getattr(d, part)
            if spec is not None:
                bad = _magnitude(spec, f"{key}.discrepancy.{part}", unit)
                if bad:
                    return bad
    return None


def sampled_dimension(cfg: Config) -> int:
    """The most parameters the sampler can carry for ``cfg`` (model parameters, one per test where
    ``per: test``, sigma0 when sampled and the discrepancy hyperparameters of each test)."""
    n_tests = len(cfg.test_names)
    n = sum(n_tests if cfg.parameters[k].per_test else 1 for k in cfg.free_parameters)
    noises = [t.noise for t in cfg.tests] if cfg.tests is not None else [cfg.noise]
    for noise in noises:
        n += isinstance(noise.sigma0, SampledNoise)
        if noise.has_discrepancy:
            d = noise.discrepancy
            n += sum(spec is None or not spec.fixed for spec in (d.amplitude, d.length))
    return n


def physical_memory() -> float:
    """Bytes of physical memory (inf when the system does not say)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE")) * float(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return math.inf


def fewest_sampled(cfg: Config) -> int:
    """The fewest parameters the sampler can carry for ``cfg`` (the discrepancy's hyperparameters
    may drop out after the fit): the free model parameters and sigma0 when sampled."""
    n_tests = len(cfg.test_names)
    n = sum(n_tests if cfg.parameters[k].per_test else 1 for k in cfg.free_parameters)
    noises = [t.noise for t in cfg.tests] if cfg.tests is not None else [cfg.noise]
    return n + sum(isinstance(noise.sigma0, SampledNoise) for noise in noises)


def _walkers(cfg: Config) -> str | None:
    ndim = fewest_sampled(cfg)
    if cfg.sampler.walkers >= 2 * ndim:
        return None
    names = cfg.free_parameters + (["sigma0"] if ndim > len(cfg.free_parameters) else [])
    return (f"sampler.walkers: {cfg.sampler.walkers} walkers for {ndim} sampled parameters "
            f"({', '.join(names)}); the ensemble moves need at least 2 × {ndim} = {2 * ndim} "
            f"(32 is a good choice)")


def _allocation(cfg: Config) -> str | None:
    s = cfg.sampler
    ndim = sampled_dimension(cfg)
    need = float(s.walkers) * float(s.max_steps) * (ndim + 1) * CHAIN_BYTES_PER_VALUE
    have = MEMORY_SHARE * physical_memory()
    if need <= have:
        return None
    return (f"sampler.walkers x sampler.max_steps: {s.walkers} walkers x {s.max_steps} steps x "
            f"{ndim} sampled parameters need about {need / 1e9:.3g} GB of memory for the chain (and "
            f"about half of that on disk for chains.h5), more than {MEMORY_SHARE:.0%} of this "
            f"machine's {2 * have / 1e9:.3g} GB: lower walkers or max_steps (32 walkers are usual)")


def range_errors(cfg: Config) -> list[str]:
    """One message per key whose value is out of range (key path first), in config order."""
    found = [_parameter(k, spec) for k, spec in cfg.parameters.items()]
    if cfg.tests is not None:
        found += [_noise(t.noise, f"tests[{i}].noise") for i, t in enumerate(cfg.tests)]
    else:
        found.append(_noise(cfg.noise, "noise"))
    found += [_walkers(cfg), _allocation(cfg)]
    return [f for f in found if f]
