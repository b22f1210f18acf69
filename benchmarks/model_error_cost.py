"""The likelihood's cost per ensemble step under model error, against the plain discrepancy and white.

On the shipped example (runs/hdpe-a-5e-3, 2000 points, 3 free parameters) and on the synthetic
relaxation test of the test suite (700 points, 5 free parameters), 32 walkers evaluated as emcee
does (two calls of 16), on one thread, CPU time, best of ``--repeats`` interleaved rounds:

- white: ``noise.discrepancy: none``;
- exp, matern32: the plain discrepancy (the sampler of the default ``target: generalized`` is the
  plain exp one: its draws are adjusted after sampling, at no cost per step);
- exp-orthogonal, matern32-orthogonal: ``target: l2``, the orthogonal discrepancy (δ conditioned on
  having no component along the p sensitivities, inference/discrepancy/kalman.py).

Prints µs per step and the ratios to white and to the plain discrepancy of the same kernel, with
the seconds of the reference job (../shared/tools/refjob.py, or $BAYES_DNLR_REFJOB, when present)
measured in the same run and the load average before and after.

    .venv/bin/python benchmarks/model_error_cost.py [--repeats 25]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
from reference_job import seconds as _refjob  # benchmarks/ is the script's folder

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def _posteriors(cfg, test, center: np.ndarray, hyper: tuple[float, float]) -> dict:
    from bayes_dnlr.config import ParameterSpec, parse_config
    from bayes_dnlr.inference.discrepancy.gls import columns_for
    from bayes_dnlr.inference.posterior.density import build_log_posterior

    raw = cfg.model_dump(mode="json", exclude_none=True)
    priors = {"disc_amplitude": ParameterSpec(prior="half-normal", scale=1.0),
              "disc_length": ParameterSpec(prior="log-uniform", low=0.1, high=1e3)}
    rng = np.random.default_rng(0)
    base = center * (1 + 1e-3 * rng.standard_normal((32, center.size)))
    out = {}
    for label in ("white", "exp", "matern32", "exp-orthogonal", "matern32-orthogonal"):
        kernel = label.split("-")[0]
        raw["noise"]["discrepancy"] = "none" if label == "white" else {"kernel": kernel, "axis": "time"}
        c = parse_config(raw, source=cfg.source)
        columns = None
        if label.endswith("orthogonal"):
            columns = columns_for(c, test, dict(zip(c.free_parameters, center, strict=True)))[0].V
        post = build_log_posterior(c, test, 0.3, discrepancy_priors=None if label == "white" else priors,
                                   columns=columns)
        th = base if label == "white" else np.column_stack([base, np.full(32, hyper[0]),
                                                            np.full(32, hyper[1])])
        for half in (th[:16], th[16:]):
            post.log_likelihood(half)            # compile / load outside the timing
        out[label] = (post, (th[:16], th[16:]))
    return out


def _time(posts: dict, repeats: int) -> dict[str, float]:
    """CPU seconds per step (one thread: CPU time is what the step costs whatever else runs on the
    machine), best of ``repeats`` interleaved rounds."""
    best = dict.fromkeys(posts, np.inf)
    for _ in range(repeats):              # interleaved: a change of load hits every likelihood alike
        for label, (post, halves) in posts.items():
            t0 = time.process_time()
            for _ in range(10):
                for h in halves:
                    post.log_likelihood(h)
            best[label] = min(best[label], (time.process_time() - t0) / 10)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=25)
    args = ap.parse_args()
    from support.sampling import TRUTH_RELAX, make_test

    from bayes_dnlr.config import load_config, parse_config
    from bayes_dnlr.data import load_test
    from bayes_dnlr.model import set_threads

    set_threads(1)
    print(f"load average before: {os.getloadavg()}; one thread, CPU time")
    ref0 = _refjob()
    cases = []
    cfg = load_config(ROOT / "runs" / "hdpe-a-5e-3" / "config.yaml")
    cases.append(("shipped example, 2000 points, p = 3", cfg, load_test(cfg),
                  np.array([2854.0, 2.32, 5.79]), (0.4, 20.0)))
    window = np.ones(700, bool)
    window[100:150] = False
    relax = make_test(relaxation=True, window=window)
    raw = {"name": "t", "data": {"file": "x.csv", "columns": {"time": "t", "strain": "e", "stress": "s"},
                                 "observable": "stress", "relaxation_start": 80.0},
           "noise": {"sigma0": 0.3, "discrepancy": "none"}}
    cases.append(("synthetic relaxation test, 650 points, p = 5", parse_config(raw), relax,
                  np.array([TRUTH_RELAX[k] for k in ("E", "G", "tau_max", "sigma_inf", "tau_max_R")]),
                  (0.5, 30.0)))
    for title, c, test, center, hyper in cases:
        best = _time(_posteriors(c, test, center, hyper), args.repeats)
        print(f"\n{title}: likelihood per ensemble step, 32 walkers (2 calls of 16), CPU µs")
        for label, t in best.items():
            kernel = label.split("-")[0]
            extra = (f"   {t / best[kernel]:.2f} x the plain {kernel}" if label.endswith("orthogonal")
                     else "")
            print(f"  {label:<22s} {1e6 * t:8.0f} µs   {t / best['white']:.2f} x white{extra}")
    ref1 = _refjob()
    if ref0 is not None:
        print(f"\nreference job: {ref0:.3f} s before, {ref1:.3f} s after")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
