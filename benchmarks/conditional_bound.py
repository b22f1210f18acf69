"""How far a better hyperparameter proposal could take the conditional move: τ against an oracle.

``sample``'s conditional move (inference/mcmc/blocks.py) draws the discrepancy's hyperparameters h
from a Student t fitted to the other half of the ensemble, and the model parameters from their
linearized conditional given h. Its τ is 4-6 steps where the white chain's is 1.5-2. This script
asks which half limits it. On the shipped example re-simulated with a correlated error (exp kernel,
0.5 MPa, 20 s; or the config given), 32 walkers, ``--steps`` steps per run, two seeds:

1. a long chain of the conditional move gives draws of h's posterior marginal (``--long`` steps);
2. ``de``: sample's moves (DEMove 0.3 + the conditional move 0.7);
3. ``oracle``: the same, with h' drawn instead from a Gaussian kernel density of 2000 of those
   draws (bandwidth 0.15 × their covariance), its exact density in the Metropolis-Hastings ratio,
   so that h' comes from (nearly) the true marginal and only the conditional's linearization
   stands between the move and independent draws;
4. ``hold h``: the conditional's model block alone (h kept), DEMove 0.3 beside it;
5. the white chain (``noise.discrepancy: none``, sample's ``de`` moves with the Laplace move).

τ is emcee's estimator after a burn-in of 5 τ. If the oracle's τ stays well above the white
chain's, no proposal of h alone brings the discrepancy chain to the white one's steps.

    .venv/bin/python benchmarks/conditional_bound.py [config.yaml] [--steps 1500] [--long 3000]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from chain_mixing import CORRELATED  # noqa: E402
from moves import run, setup  # noqa: E402
from reference_job import load  # noqa: E402
from sample_command import copy_run  # noqa: E402

KDE_POINTS = 2000
BANDWIDTH = 0.15


def conditional_moves(mapper, h_draws: np.ndarray | None = None, hold: bool = False):
    """DEMove 0.3 beside the conditional move (0.7), its h' from ``h_draws``' kernel density when
    given, or h kept (``hold``)."""
    import emcee.moves as mv

    from bayes_dnlr.inference.mcmc.blocks import ConditionalMove, t_logpdf

    class Variant(ConditionalMove):
        def get_proposal(self, s, c, random):
            if h_draws is None and not hold:
                return super().get_proposal(s, c, random)
            ns, d, p = s.shape[0], self.hyper.size, self.model.size
            h_old = s[:, self.hyper]
            if hold:
                h_new, lq = h_old, np.zeros(2 * ns)
            else:
                chol = np.linalg.cholesky(np.cov(h_draws.T) * BANDWIDTH**2)
                h_new = (h_draws[random.randint(h_draws.shape[0], size=ns)]
                         + random.randn(ns, d) @ chol.T)
                lq = kde_logpdf(np.concatenate([h_old, h_new]), h_draws, chol)
            u_new = random.randn(ns, p) / np.sqrt(random.chisquare(self.dof, size=ns)
                                                  / self.dof)[:, None]
            u_old, ld_old, theta_new, ld_new = self.mapper.standardize_and_place(
                h_old, s[:, self.model], h_new, u_new)
            q = s.copy()
            q[:, self.hyper] = h_new
            q[:, self.model] = theta_new
            lt_u = t_logpdf(np.concatenate([u_old, u_new]), np.zeros(p), np.eye(p), self.dof)
            factors = lq[:ns] - lq[ns:] + lt_u[:ns] - lt_u[ns:] + ld_new - ld_old
            bad = ~np.isfinite(factors)
            q[bad] = s[bad]
            factors[bad] = -np.inf
            return q, factors

    return [(mv.DEMove(), 0.3), (Variant(mapper), 0.7)]


def kde_logpdf(x: np.ndarray, points: np.ndarray, chol: np.ndarray) -> np.ndarray:
    """log density (up to a constant) at the rows of x of the mixture of N(point, chol cholᵀ)."""
    z = np.linalg.solve(chol, (x[:, None, :] - points[None]).reshape(-1, x.shape[1]).T).T
    a = -0.5 * np.sum(z.reshape(x.shape[0], points.shape[0], -1) ** 2, axis=2)
    top = a.max(axis=1)
    return top + np.log(np.exp(a - top[:, None]).sum(axis=1))


def marginal_draws(target, mapper, steps: int) -> np.ndarray:
    """KDE_POINTS draws of h's posterior marginal from a long chain of sample's moves."""
    import emcee

    from bayes_dnlr.inference.mcmc.ensemble import start_ensemble

    post = target.post
    coords, lp = start_ensemble(post, target.priors, target.x0, target.cov, 32, 3)
    sampler = emcee.EnsembleSampler(32, post.ndim, post, moves=conditional_moves(mapper),
                                    vectorize=True)
    sampler.run_mcmc(emcee.State(coords, log_prob=lp), steps)
    h = sampler.get_chain(discard=steps // 10, flat=True)[:, mapper.hyper]
    return h[np.linspace(0, h.shape[0] - 1, KDE_POINTS).astype(int)]


def report(label: str, target, make, steps: int) -> np.ndarray:
    taus = []
    for seed in (11, 12):
        tau, _, acc = run(target, make(), steps, 32, seed)
        taus.append(tau)
        print(f"  {label:<10s} seed {seed}: tau " + ", ".join(
            f"{k} {t:.1f}" for k, t in zip(target.names, tau, strict=True))
            + f"; acceptance {acc:.2f}", flush=True)
    return np.mean(taus, axis=0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", nargs="?")
    ap.add_argument("--steps", type=int, default=1500)
    ap.add_argument("--long", type=int, default=3000)
    args = ap.parse_args()
    print(load())
    with tempfile.TemporaryDirectory(prefix="bd-bound-") as tmp:
        configs = {}
        if args.config is None:
            for lik, noise in (("disc", {"sigma0": "residuals"}), ("white", {"discrepancy": "none"})):
                d = copy_run(Path(tmp), f"corr-{lik}", truth=CORRELATED, noise=noise)
                subprocess.run([sys.executable, "-m", "bayes_dnlr", "simulate",
                                str(d / "config.yaml"), "--force"], check=True, capture_output=True)
                configs[lik] = str(d / "config.yaml")
        else:
            configs["disc"] = args.config
        _, _, target = setup(configs["disc"])
        z0 = target.priors.from_physical(target.x0)
        mapper = target.post.conditional_map(z0)
        if mapper is None:
            sys.exit("no discrepancy hyperparameter is sampled in this run: nothing to compare")
        target.post(z0[None])
        print(f"{target.names}; {args.steps} steps per run, h marginal from {args.long} steps")
        h = marginal_draws(target, mapper, args.long)
        rows = {"de": report("de", target, lambda: conditional_moves(mapper), args.steps),
                "oracle": report("oracle", target, lambda: conditional_moves(mapper, h),
                                 args.steps),
                "hold h": report("hold h", target,
                                 lambda: conditional_moves(mapper, hold=True), args.steps)}
        if "white" in configs:
            from bayes_dnlr.inference.mcmc.ensemble import linearized_root, make_moves

            _, _, white = setup(configs["white"])
            lap = linearized_root(white.priors, white.x0, white.cov)
            rows["white"] = report("white", white, lambda: make_moves("de", None, lap),
                                   args.steps)
    model = [k for k in target.names if not k.startswith("disc_")]
    for label, tau in rows.items():
        names = target.names if label != "white" else model
        print(f"{label:<8s} mean tau: " + ", ".join(
            f"{k} {t:.1f}" for k, t in zip(names, tau, strict=True)) + f"; max {tau.max():.1f}")
    print(load())


if __name__ == "__main__":
    main()
