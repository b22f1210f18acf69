"""Which emcee moves suit the DNLR posterior? Integrated autocorrelation time τ per move.

On the 2000-point 3-parameter example (E-tau_max correlation about -0.998), 32 walkers, every move
starts from the same draw of the linearized posterior and runs ``--steps`` steps; τ (emcee's
estimator, c = 5) is measured after a burn-in of 5 τ. Fewer steps per τ means fewer steps to the
same ESS; the cost of a step is the same for every move (one model evaluation per walker).

    .venv/bin/python benchmarks/moves.py [config.yaml] [--steps 4000] [--repeats 2]

Without a config, a synthetic test (ramp 5e-3 1/s to strain 1.9, 2000 points, E 2854, G 2.32,
tau_max 5.79, noise 0.3 MPa) is used.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def variants():
    import emcee.moves as mv

    return {
        "stretch (a=2)": lambda: mv.StretchMove(),
        "DE": lambda: mv.DEMove(),
        "DE(0.8)+snooker(0.2)": lambda: [(mv.DEMove(), 0.8), (mv.DESnookerMove(), 0.2)],
        "DE(0.9)+snooker(0.1)": lambda: [(mv.DEMove(), 0.9), (mv.DESnookerMove(), 0.1)],
        "DE(0.5)+snooker(0.5)": lambda: [(mv.DEMove(), 0.5), (mv.DESnookerMove(), 0.5)],
        "DE(0.8)+stretch(0.2)": lambda: [(mv.DEMove(), 0.8), (mv.StretchMove(), 0.2)],
    }


def setup(config: str | None):
    from bayes_dnlr.config import load_config
    from bayes_dnlr.data import load_test
    from bayes_dnlr.inference.posterior.density import build_log_posterior
    from bayes_dnlr.runs.fit import fit

    if config is None:
        from support.sampling import write_case

        config = str(write_case(Path(tempfile.mkdtemp()), "moves"))
    cfg = load_config(config)
    res = fit(cfg, write=False).only
    fitd = res.to_dict()
    test = load_test(cfg)
    post = build_log_posterior(cfg, test, float(res.sigma0))
    return cfg, fitd, post


def run(post, fitd, moves, steps: int, walkers: int, seed: int) -> tuple[np.ndarray, float, float]:
    import emcee

    from bayes_dnlr.inference.mcmc.ensemble import start_ensemble
    from bayes_dnlr.runs.target import start_point

    x0, cov = start_point(post, fitd, None)
    coords, lp = start_ensemble(post, post.priors, x0, cov, walkers, seed)
    sampler = emcee.EnsembleSampler(walkers, post.ndim, post, moves=moves, vectorize=True)
    sampler._random.seed(seed)
    t0 = time.perf_counter()
    sampler.run_mcmc(emcee.State(coords, log_prob=lp), steps)
    wall = time.perf_counter() - t0
    chain = post.priors.to_physical(sampler.get_chain())
    tau0 = emcee.autocorr.integrated_time(chain, tol=0)
    burn = int(np.ceil(5 * tau0.max()))
    tau = emcee.autocorr.integrated_time(chain[burn:], tol=0)
    return tau, wall / steps, float(np.mean(sampler.acceptance_fraction))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", nargs="?")
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--walkers", type=int, default=32)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    cfg, fitd, post = setup(args.config)
    post(post.priors.from_physical(np.array([[fitd["estimate"][k] for k in post.names]])))  # compile
    names = post.names
    print(f"{cfg.name}: {post.n} points, {args.walkers} walkers, {args.steps} steps, "
          f"{args.repeats} seeds; GN correlation E-tau_max = "
          f"{np.asarray(fitd['correlation'])[0, names.index('tau_max')]:.4f}")
    head = f"{'moves':<22} " + " ".join(f"{'tau ' + k:>12}" for k in names)
    print(head + f" {'tau max':>8} {'accept':>7} {'ms/step':>8} {'ESS/s':>7}")
    for label, make in variants().items():
        taus, costs, accs = [], [], []
        for r in range(args.repeats):
            tau, cost, acc = run(post, fitd, make(), args.steps, args.walkers, seed=11 + r)
            taus.append(tau)
            costs.append(cost)
            accs.append(acc)
        tau = np.mean(taus, axis=0)
        cost = float(np.mean(costs))
        ess_per_s = args.walkers / tau.max() / cost
        print(f"{label:<22} " + " ".join(f"{t:>12.1f}" for t in tau)
              + f" {tau.max():>8.1f} {np.mean(accs):>7.2f} {1e3 * cost:>8.2f} {ess_per_s:>7.0f}")


if __name__ == "__main__":
    main()
