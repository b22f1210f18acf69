"""Does the prediction come true? Simulate tests with a candidate's planned conditions and the
design's noise (white σ0 plus the model discrepancy δ, a draw of the Gaussian process), fit each
with ``fit`` (generalized least squares with the known hyperparameters when there is a
discrepancy: the likelihood the prediction assumes) and compare the spread of the estimates with
the predicted sd (benchmarks/design_validation.py, tests/workflows/design/test_design.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayes_dnlr.config import DEFAULT_PRIORS, parse_config
from bayes_dnlr.data import TestData
from bayes_dnlr.inference.discrepancy import gp
from bayes_dnlr.model import simulate
from bayes_dnlr.workflows.design.candidates import Candidate, planned_protocol, window_mask
from bayes_dnlr.workflows.design.fisher import Draws, Prediction, predict


@dataclass
class Replicates:
    """The estimates of ``n`` simulated tests of one candidate, and the prediction they test."""

    prediction: Prediction
    estimates: np.ndarray          # (n, p) in prediction.names order
    failed: int                    # fits that did not converge (left out)

    @property
    def names(self) -> list[str]:
        return self.prediction.names

    def spread(self) -> dict[str, float]:
        """Sample sd of the estimates per parameter."""
        return {k: float(np.std(self.estimates[:, j], ddof=1)) for j, k in enumerate(self.names)}

    def ratio(self) -> dict[str, float]:
        """Observed spread / predicted sd per parameter."""
        s = self.spread()
        return {k: s[k] / self.prediction.sd[k] for k in self.names}

    def ratio_interval(self, level: float = 0.95) -> tuple[float, float]:
        """Where the ratio of a correct prediction falls with probability ``level`` (χ² with n-1 dof)."""
        from scipy.stats import chi2

        n = self.estimates.shape[0]
        a = (1.0 - level) / 2.0
        return (math.sqrt(chi2.ppf(a, n - 1) / (n - 1)), math.sqrt(chi2.ppf(1.0 - a, n - 1) / (n - 1)))


def discrepancy_draws(x: np.ndarray, amplitude: float, length: float, kind: str, size: int,
                      rng: np.random.Generator, start: float | None = None) -> np.ndarray:
    """``size`` draws (size, n) of the zero-mean process with kernel ``kind`` on the points ``x``
    (any order), by the Cholesky factor of the exact covariance (gp.covariance; conditioned on
    δ(start) = 0 when ``start`` is given)."""
    order = np.argsort(x, kind="stable")
    xs = x[order]
    K = gp.covariance(xs, amplitude, length, kind, start=start)
    K[np.diag_indices_from(K)] += 1e-10 * amplitude**2
    L = np.linalg.cholesky(K)
    draws = (L @ rng.standard_normal((xs.size, size))).T
    out = np.empty_like(draws)
    out[:, order] = draws
    return out


def _config(candidate: Candidate, names: list[str], params: dict[str, float], draws: Draws,
            modes: int, decades: float):
    nz = draws.noise[0]
    w = candidate.window_spec.model_dump(exclude_none=True, exclude={"fixed"})
    parameters = {k: ({"value": float(params[k])} if k not in names else DEFAULT_PRIORS[k])
                  for k in params}
    disc = ("none" if nz.amplitude == 0 else
            {"kernel": draws.kernel, "axis": draws.axis, "start": draws.start,
             "amplitude": {"value": nz.amplitude}, "length": {"value": nz.length}})
    raw = {"name": "design-validation",
           "data": {"file": "memory.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                    "observable": "stress", "window": w,
                    "relaxation_start": None},
           "model": {"modes": modes, "decades": decades},
           "parameters": parameters,
           "noise": {"sigma0": nz.sigma0, "discrepancy": disc},
           "fit": {"multistart": 0}}
    return raw


def replicate(candidate: Candidate, draws: Draws, free: list[str], n_tests: int, seed: int,
              modes: int = 50, decades: float = 6.0) -> Replicates:
    """Simulate ``n_tests`` tests of ``candidate`` at the design's (single) parameter guess and noise,
    fit each, and return the estimates with the prediction."""
    from bayes_dnlr.inference.lsq.identify import fit_test

    if draws.n != 1:
        raise ValueError("validation uses one parameter set (a guess)")
    params, nz = draws.params[0], draws.noise[0]
    pred = predict(candidate, draws, free, modes, decades)
    if not pred.identifiable:
        raise ValueError(f"{candidate.label()}: no prediction ({pred.note})")
    prot = planned_protocol(candidate, params)
    switch = prot.relaxation_start
    true = simulate(prot.time, prot.strain, params, modes, decades, switch)
    rng = np.random.default_rng(seed)
    noise = rng.normal(0.0, nz.sigma0, (n_tests, prot.time.size))
    if nz.amplitude > 0:
        mask = window_mask(candidate.window_spec, prot.time, prot.strain)
        along = prot.time if draws.axis == "time" else prot.strain
        origin = float(along[0]) if draws.start == "pinned" else None
        delta = np.zeros_like(noise)
        delta[:, mask] = discrepancy_draws(along[mask], nz.amplitude, nz.length, draws.kernel, n_tests,
                                           rng, origin)
        noise += delta
    raw = _config(candidate, pred.names, params, draws, modes, decades)
    raw["data"]["relaxation_start"] = switch
    cfg = parse_config(raw, source=Path("design-validation.yaml"))
    window = window_mask(candidate.window_spec, prot.time, prot.strain)
    est, failed = [], 0
    for y in true + noise:
        test = TestData(path=Path("memory.csv"), sha256="0" * 64, time=prot.time, strain=prot.strain,
                        strain_input=prot.strain, stress=y, nominal_strain=np.expm1(prot.strain),
                        nominal_stress=None, window=window, relaxation_start=switch,
                        strain_rate=candidate.strain_rate, observable="stress")
        r = fit_test(cfg, test)
        source = r.discrepancy if r.discrepancy is not None else {"estimate": r.estimate,
                                                                  "converged": r.converged}
        if not source.get("converged", r.converged):
            failed += 1
            continue
        est.append([source["estimate"][k] for k in pred.names])
    return Replicates(pred, np.array(est), failed)


def _chunk(args: tuple) -> tuple[list[list[float]], int]:
    raw, n, seed = args
    from bayes_dnlr.workflows.design.candidates import expand
    from bayes_dnlr.workflows.design.config import parse_design
    from bayes_dnlr.workflows.design.run import resolve_draws

    cfg = parse_design(raw)
    draws, free, _ = resolve_draws(cfg)
    r = replicate(expand(cfg)[0], draws, free, n, seed, cfg.model.modes, cfg.model.decades)
    return r.estimates.tolist(), r.failed


def validate_design(raw: dict, n_tests: int, seed: int = 0, jobs: int = 1) -> Replicates:
    """``replicate`` for the first candidate of a design mapping (a guess, one condition), in
    ``jobs`` processes (each its own seed stream)."""
    from bayes_dnlr.workflows.design.candidates import expand
    from bayes_dnlr.workflows.design.config import parse_design
    from bayes_dnlr.workflows.design.run import resolve_draws

    cfg = parse_design(raw)
    draws, free, _ = resolve_draws(cfg)
    pred = predict(expand(cfg)[0], draws, free, cfg.model.modes, cfg.model.decades)
    sizes = [n_tests // jobs + (1 if i < n_tests % jobs else 0) for i in range(jobs)]
    args = [(raw, n, seed + 1000 * i) for i, n in enumerate(sizes) if n > 0]
    if jobs <= 1:
        parts = [_chunk(a) for a in args]
    else:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(jobs, mp_context=mp.get_context("spawn")) as pool:
            parts = list(pool.map(_chunk, args))
    est = np.array([row for rows, _ in parts for row in rows])
    return Replicates(pred, est, sum(f for _, f in parts))
