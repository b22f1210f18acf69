"""Which emcee moves suit the DNLR posterior? Integrated autocorrelation time τ per move.

On a run's posterior as ``sample`` builds it (the config's folder is copied and fitted there), 32
walkers, every move starts from the same draw of the linearized posterior and runs ``--steps``
steps; τ (emcee's estimator, c = 5) is measured after a burn-in of 5 τ. Fewer steps per τ means
fewer steps to the same ESS; the cost of a step is about the same for every move (one model
evaluation per walker). "de" is ``sample``'s default: DEMove with the Laplace move on a white
chain, with the conditional move when the discrepancy's hyperparameters are sampled, with the
complement move where neither linearization can be trusted.

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


def variants(chosen):
    """Each compared move set; ``de`` as ``sample`` makes it (``chosen``: its independence move,
    runs.sample.independence_moves: the Laplace move on a white chain, the conditional move with
    sampled discrepancy hyperparameters, the complement move where neither applies)."""
    import emcee.moves as mv

    from bayes_dnlr.inference.mcmc.ensemble import make_moves

    return {
        "stretch (a=2)": lambda: mv.StretchMove(),
        "DE (de-plain)": lambda: mv.DEMove(),
        "DE(0.8)+snooker(0.2)": lambda: [(mv.DEMove(), 0.8), (mv.DESnookerMove(), 0.2)],
        "DE(0.8)+stretch(0.2)": lambda: [(mv.DEMove(), 0.8), (mv.StretchMove(), 0.2)],
        "de (sample's default)": lambda: make_moves("de", *chosen),
    }


def setup(config: str | None):
    """The config, and the run's target as ``sample`` builds it (fit.json written into a copy)."""
    import json
    import shutil

    from bayes_dnlr.config import load_config
    from bayes_dnlr.runs.fit import fit
    from bayes_dnlr.runs.records import FitRecord
    from bayes_dnlr.runs.target import build_target
    from bayes_dnlr.runs.testset import load_tests

    tmp = Path(tempfile.mkdtemp())
    if config is None:
        from support.sampling import write_case

        config = str(write_case(tmp, "moves"))
    else:        # its folder copied without outputs: the run's own fit.json is left as it is
        src = Path(config).resolve()
        shutil.copytree(src.parent, tmp / src.parent.name, ignore=shutil.ignore_patterns(
            "fit.json", "chains.h5", "posterior.nc", "summary.json", "*.lock", ".cache", "figures"))
        config = str(tmp / src.parent.name / src.name)
    cfg = load_config(config)
    tests = load_tests(cfg)
    fit(cfg, test=tests)
    fitd = json.loads((cfg.run_dir / "fit.json").read_text())
    target = build_target(cfg, tests, FitRecord.from_dict(fitd, cfg.test_names))
    return cfg, fitd, target


def run(target, moves, steps: int, walkers: int, seed: int) -> tuple[np.ndarray, float, float]:
    import emcee

    from bayes_dnlr.inference.mcmc.ensemble import start_ensemble

    post = target.post
    coords, lp = start_ensemble(post, target.priors, target.x0, target.cov, walkers, seed)
    sampler = emcee.EnsembleSampler(walkers, post.ndim, post, moves=moves, vectorize=True)
    sampler._random.seed(seed)
    t0 = time.perf_counter()
    sampler.run_mcmc(emcee.State(coords, log_prob=lp), steps)
    wall = time.perf_counter() - t0
    chain = target.priors.to_physical(sampler.get_chain())
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
    cfg, fitd, target = setup(args.config)
    from bayes_dnlr.runs.sample import independence_moves

    post, names = target.post, target.names
    z0 = target.priors.from_physical(target.x0)
    chosen = independence_moves("de", target, None, args.walkers)   # as sample chooses
    post(z0[None])  # compile
    corr = np.asarray(fitd["correlation"], dtype=float)
    rho = f"{corr[0, names.index('tau_max')]:.4f}" if corr.shape[0] == len(names) else "-"
    print(f"{cfg.name}: {len(names)} parameters ({', '.join(names)}), {args.walkers} walkers, "
          f"{args.steps} steps, {args.repeats} seeds; GN correlation E-tau_max = {rho}")
    head = f"{'moves':<22} " + " ".join(f"{'tau ' + k:>12}" for k in names)
    print(head + f" {'tau max':>8} {'accept':>7} {'ms/step':>8} {'ESS/s':>7}")
    for label, make in variants(chosen).items():
        taus, costs, accs = [], [], []
        for r in range(args.repeats):
            tau, cost, acc = run(target, make(), args.steps, args.walkers, seed=11 + r)
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
