"""Synthetic populations for the two-stage method: specimens' true E from Normal(mu, s), and each
specimen's stage-1 posterior drawn cheaply as normal draws around a noisy centre.

The cheap stage 1 stands in for a full `sample` per specimen: a well-identified single-test
posterior of E is close to normal (docs/sampling.md: posterior sd within a few % of the linearized
one), with a centre scattered by the measurement (the centre ~ Normal(E_k, sd_k)) and an sd of 1-2 %
of E, as the shipped HDPE examples give (about 25-35 MPa at 2850 MPa; more with model error).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayes_dnlr.config import ParameterSpec
from bayes_dnlr.inference.analyses.population import population
from bayes_dnlr.inference.posterior.priors import Prior

MU, S = 2850.0, 100.0                  # the material's mean E and the specimen-to-specimen sd, MPa
SD_RANGE = (25.0, 60.0)                # each specimen's posterior sd, MPa
PRIOR = Prior.from_spec("E", ParameterSpec(prior="uniform", low=100.0, high=20000.0))


@dataclass
class Replicate:
    mu_covered: bool
    s_covered: bool
    mu_mean: float
    s_mean: float
    passed_mc: bool


def draw_population(rng: np.random.Generator, n_specimens: int = 8, n_draws: int = 4000,
                    mu: float = MU, s: float = S) -> dict[str, np.ndarray]:
    """Stage-1 draws of each specimen: normal around a centre scattered by its own sd."""
    true = rng.normal(mu, s, n_specimens)
    sds = rng.uniform(*SD_RANGE, n_specimens)
    centres = rng.normal(true, sds)
    return {f"spec-{k + 1}": rng.normal(c, sd, n_draws)
            for k, (c, sd) in enumerate(zip(centres, sds, strict=True))}


def replicate(seed: int, n_specimens: int = 8) -> Replicate:
    rng = np.random.default_rng(seed)
    draws = draw_population(rng, n_specimens)
    pop = population(draws, dict.fromkeys(draws, PRIOR))
    lo, hi = pop.mu["hdi_90"]
    slo, shi = pop.s["hdi_90"]
    return Replicate(lo <= MU <= hi, slo <= S <= shi, pop.mu["mean"], pop.s["mean"], pop.passed)


def coverage(n_populations: int, seed0: int = 1000, n_specimens: int = 8) -> dict[str, float]:
    reps = [replicate(seed0 + i, n_specimens) for i in range(n_populations)]
    return {"n": n_populations, "mu": float(np.mean([r.mu_covered for r in reps])),
            "s": float(np.mean([r.s_covered for r in reps])),
            "mu_mean": float(np.mean([r.mu_mean for r in reps])),
            "s_mean": float(np.mean([r.s_mean for r in reps])),
            "mc_passed": float(np.mean([r.passed_mc for r in reps]))}
